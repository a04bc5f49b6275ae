//! Adam (Kingma and Ba, 2015) on a flat parameter vector.

use super::Float;

#[derive(Clone, Debug)]
pub struct Adam<T> {
    /// Step size; the caller may change it between steps (annealing).
    pub lr: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    m: Vec<T>,
    v: Vec<T>,
    t: i32,
}

impl<T: Float> Adam<T> {
    /// Adam for `n` parameters with the usual moments (0.9, 0.999) and eps 1e-8.
    pub fn new(n: usize, lr: f64) -> Adam<T> {
        Adam {
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            m: vec![T::default(); n],
            v: vec![T::default(); n],
            t: 0,
        }
    }

    /// One descent step: params -= lr m_hat / (sqrt(v_hat) + eps).
    pub fn step(&mut self, params: &mut [T], grad: &[T]) {
        assert_eq!(params.len(), self.m.len());
        assert_eq!(grad.len(), self.m.len());
        self.t += 1;
        let (b1, b2) = (T::of(self.beta1), T::of(self.beta2));
        let (c1, c2) = (T::of(1.0 - self.beta1), T::of(1.0 - self.beta2));
        let step = T::of(self.lr / (1.0 - self.beta1.powi(self.t)));
        let v_scale = T::of(1.0 / (1.0 - self.beta2.powi(self.t)));
        let eps = T::of(self.eps);
        for (((p, &g), m), v) in params
            .iter_mut()
            .zip(grad)
            .zip(&mut self.m)
            .zip(&mut self.v)
        {
            *m = b1 * *m + c1 * g;
            *v = b2 * *v + c2 * g * g;
            *p = *p - step * *m / ((*v * v_scale).sqrt() + eps);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adam_minimises_a_quadratic() {
        // f(p) = sum (p_i - i)^2 from p = 0.
        let mut p = vec![0.0f64; 3];
        let mut adam = Adam::new(3, 0.05);
        for _ in 0..2000 {
            let g: Vec<f64> = p
                .iter()
                .enumerate()
                .map(|(i, x)| 2.0 * (x - i as f64))
                .collect();
            adam.step(&mut p, &g);
        }
        for (i, x) in p.iter().enumerate() {
            assert!((x - i as f64).abs() < 1e-3, "{p:?}");
        }
    }

    #[test]
    fn first_step_moves_each_parameter_by_lr() {
        let mut p = vec![1.0f32, 1.0];
        let mut adam = Adam::new(2, 0.1);
        adam.step(&mut p, &[3.0, -0.5]);
        assert!(
            (p[0] - 0.9).abs() < 1e-6 && (p[1] - 1.1).abs() < 1e-6,
            "{p:?}"
        );
    }
}
