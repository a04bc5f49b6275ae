//! A multilayer perceptron: tanh (or ReLU) hidden layers, a linear output layer.

use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

use super::Float;

/// Sizes `[inputs, hidden..., outputs]` and the flat parameter vector (see
/// the module docs for its layout).
#[derive(Clone, Debug, PartialEq)]
pub struct Mlp<T> {
    sizes: Vec<usize>,
    params: Vec<T>,
    activation: Activation,
}

/// The hidden layers' nonlinearity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Activation {
    #[default]
    Tanh,
    Relu,
}

impl Activation {
    fn apply<T: Float>(self, y: T) -> T {
        match self {
            Activation::Tanh => y.tanh(),
            Activation::Relu if y > T::default() => y,
            Activation::Relu => T::default(),
        }
    }

    /// The derivative at the pre-activation whose output is `h`.
    fn slope<T: Float>(self, h: T) -> T {
        match self {
            Activation::Tanh => T::of(1.0) - h * h,
            Activation::Relu if h > T::default() => T::of(1.0),
            Activation::Relu => T::default(),
        }
    }
}

/// One forward pass's activations, kept for the backward pass, and the
/// backward pass's scratch. Reused across calls so nothing allocates once the
/// batch size settles.
#[derive(Clone, Debug, Default)]
pub struct Tape<T> {
    batch: usize,
    /// `acts[0]` is the input, `acts[l + 1]` the output of layer `l`.
    acts: Vec<Vec<T>>,
    delta: Vec<T>,
    next: Vec<T>,
}

impl<T: Float> Mlp<T> {
    /// A network with weights drawn from N(0, 1 / fan_in) (the scale that keeps
    /// tanh layers' activations of order one), the last layer's scaled by
    /// `out_gain`, and zero biases.
    pub fn new(sizes: &[usize], out_gain: f64, rng: &mut StdRng) -> Mlp<T> {
        assert!(sizes.len() >= 2 && sizes.iter().all(|&s| s > 0));
        let mut params = Vec::with_capacity(param_count(sizes));
        for (l, pair) in sizes.windows(2).enumerate() {
            let (n_in, n_out) = (pair[0], pair[1]);
            let gain = if l + 2 == sizes.len() { out_gain } else { 1.0 };
            let std = gain / (n_in as f64).sqrt();
            for _ in 0..n_in * n_out {
                let z: f64 = StandardNormal.sample(rng);
                params.push(T::of(std * z));
            }
            params.extend(std::iter::repeat_n(T::default(), n_out));
        }
        Mlp {
            sizes: sizes.to_vec(),
            params,
            activation: Activation::Tanh,
        }
    }

    /// The same network with another hidden-layer nonlinearity.
    pub fn with_activation(self, activation: Activation) -> Mlp<T> {
        Mlp { activation, ..self }
    }

    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// A network from its sizes and flat parameters.
    pub fn from_params(sizes: &[usize], params: Vec<T>) -> Result<Mlp<T>, String> {
        if sizes.len() < 2 || sizes.contains(&0) {
            return Err(format!("bad layer sizes {sizes:?}"));
        }
        if params.len() != param_count(sizes) {
            return Err(format!(
                "sizes {sizes:?} need {} parameters, got {}",
                param_count(sizes),
                params.len()
            ));
        }
        Ok(Mlp {
            sizes: sizes.to_vec(),
            params,
            activation: Activation::Tanh,
        })
    }

    pub fn sizes(&self) -> &[usize] {
        &self.sizes
    }

    pub fn inputs(&self) -> usize {
        self.sizes[0]
    }

    pub fn outputs(&self) -> usize {
        self.sizes[self.sizes.len() - 1]
    }

    pub fn params(&self) -> &[T] {
        &self.params
    }

    pub fn params_mut(&mut self) -> &mut [T] {
        &mut self.params
    }

    /// Each layer's `(W, b)`: `W` is `out x in` row-major.
    pub fn layers(&self) -> impl Iterator<Item = (&[T], &[T])> {
        self.layout().map(|(n_in, n_out, at)| {
            let (w, b) = self.params[at..at + (n_in + 1) * n_out].split_at(n_in * n_out);
            (w, b)
        })
    }

    /// Each layer's (inputs, outputs, offset of its `W` in the flat vector).
    fn layout(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        let mut at = 0;
        self.sizes.windows(2).map(move |pair| {
            let here = at;
            at += (pair[0] + 1) * pair[1];
            (pair[0], pair[1], here)
        })
    }

    /// The outputs (`batch x outputs`) for the inputs `x` (`batch x inputs`);
    /// the tape keeps what [`Mlp::backward`] needs.
    pub fn forward<'t>(&self, x: &[T], tape: &'t mut Tape<T>) -> &'t [T] {
        assert_eq!(x.len() % self.inputs(), 0, "input is not whole rows");
        let batch = x.len() / self.inputs();
        let layers = self.sizes.len() - 1;
        tape.batch = batch;
        tape.acts.resize_with(layers + 1, Vec::new);
        tape.acts[0].clear();
        tape.acts[0].extend_from_slice(x);
        for (l, (n_in, n_out, at)) in self.layout().enumerate() {
            let (done, rest) = tape.acts.split_at_mut(l + 1);
            let (input, out) = (&done[l], &mut rest[0]);
            let (w, b) = self.params[at..at + (n_in + 1) * n_out].split_at(n_in * n_out);
            out.clear();
            for _ in 0..batch {
                out.extend_from_slice(b);
            }
            let (n_in_s, n_out_s) = (n_in as isize, n_out as isize);
            T::gemm(
                (batch, n_in, n_out),
                T::of(1.0),
                (input, n_in_s, 1),
                (w, 1, n_in_s),
                T::of(1.0),
                (out, n_out_s, 1),
            );
            if l + 1 < layers {
                let f = self.activation;
                out.iter_mut().for_each(|y| *y = f.apply(*y));
            }
        }
        &tape.acts[layers]
    }

    /// The gradient of a loss with respect to the parameters, written into
    /// `grad`, given the loss's gradient `dout` with respect to the outputs of
    /// the last [`Mlp::forward`] on this tape.
    pub fn backward(&self, tape: &mut Tape<T>, dout: &[T], grad: &mut [T]) {
        self.backprop(tape, dout, grad, false);
    }

    /// As [`Mlp::backward`], and also the loss's gradient with respect to
    /// the inputs of that forward pass (`batch x inputs`), returned.
    pub fn backward_to_inputs<'t>(
        &self,
        tape: &'t mut Tape<T>,
        dout: &[T],
        grad: &mut [T],
    ) -> &'t [T] {
        self.backprop(tape, dout, grad, true);
        &tape.delta
    }

    /// Back-propagation of `dout` into `grad`; with `to_inputs`, on through
    /// the first layer's weights so that `tape.delta` ends as the inputs' gradient.
    fn backprop(&self, tape: &mut Tape<T>, dout: &[T], grad: &mut [T], to_inputs: bool) {
        let batch = tape.batch;
        assert_eq!(dout.len(), batch * self.outputs(), "dout shape");
        assert_eq!(grad.len(), self.params.len(), "grad shape");
        tape.delta.clear();
        tape.delta.extend_from_slice(dout);
        let layout: Vec<_> = self.layout().collect();
        for (l, &(n_in, n_out, at)) in layout.iter().enumerate().rev() {
            let (n_in_s, n_out_s) = (n_in as isize, n_out as isize);
            let input = &tape.acts[l];
            let (gw, gb) = grad[at..at + (n_in + 1) * n_out].split_at_mut(n_in * n_out);
            // dW = delta^T input; db = column sums of delta.
            T::gemm(
                (n_out, batch, n_in),
                T::of(1.0),
                (&tape.delta, 1, n_out_s),
                (input, n_in_s, 1),
                T::of(0.0),
                (gw, n_in_s, 1),
            );
            gb.iter_mut().for_each(|g| *g = T::default());
            for row in tape.delta.chunks_exact(n_out) {
                gb.iter_mut().zip(row).for_each(|(g, &d)| *g += d);
            }
            if l == 0 && !to_inputs {
                break;
            }
            // Back through W, then through the nonlinearity that produced `input`.
            let w = &self.params[at..at + n_in * n_out];
            tape.next.clear();
            tape.next.resize(batch * n_in, T::default());
            T::gemm(
                (batch, n_out, n_in),
                T::of(1.0),
                (&tape.delta, n_out_s, 1),
                (w, n_in_s, 1),
                T::of(0.0),
                (&mut tape.next, n_in_s, 1),
            );
            if l > 0 {
                for (d, &h) in tape.next.iter_mut().zip(input) {
                    *d *= self.activation.slope(h);
                }
            }
            std::mem::swap(&mut tape.delta, &mut tape.next);
        }
    }
}

/// One layer as the weights files store it: `w` as `out` rows of `in`
/// values, `b` with `out` values.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LayerFile {
    pub w: Vec<Vec<f32>>,
    pub b: Vec<f32>,
}

impl Mlp<f32> {
    /// The layers in their file form.
    pub fn to_files(&self) -> Vec<LayerFile> {
        self.layers()
            .map(|(w, b)| LayerFile {
                w: w.chunks_exact(w.len() / b.len())
                    .map(<[f32]>::to_vec)
                    .collect(),
                b: b.to_vec(),
            })
            .collect()
    }

    /// A network from its layers in file form, checking that they chain.
    pub fn from_files(layers: &[LayerFile]) -> Result<Mlp<f32>, String> {
        let Some(first) = layers.first() else {
            return Err("no layers".into());
        };
        let mut sizes = vec![first.w.first().map_or(0, Vec::len)];
        let mut params = vec![];
        for layer in layers {
            let n_in = *sizes.last().expect("non-empty");
            if layer.w.len() != layer.b.len() || layer.w.iter().any(|row| row.len() != n_in) {
                return Err(format!("a layer is not {} rows of {n_in}", layer.b.len()));
            }
            sizes.push(layer.b.len());
            params.extend(layer.w.iter().flatten());
            params.extend(&layer.b);
        }
        Mlp::from_params(&sizes, params)
    }
}

/// Number of parameters of a network with these layer sizes.
fn param_count(sizes: &[usize]) -> usize {
    sizes.windows(2).map(|p| (p[0] + 1) * p[1]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// A scalar loss of the outputs with a known gradient: sum of c_i y_i^2 / 2.
    fn loss(net: &Mlp<f64>, x: &[f64], c: &[f64]) -> f64 {
        let mut tape = Tape::default();
        let y = net.forward(x, &mut tape);
        y.iter().zip(c).map(|(y, c)| 0.5 * c * y * y).sum()
    }

    #[test]
    fn backward_matches_finite_differences() {
        for activation in [Activation::Tanh, Activation::Relu] {
            let mut rng = StdRng::seed_from_u64(7);
            let mut net = Mlp::<f64>::new(&[3, 5, 4, 2], 0.7, &mut rng).with_activation(activation);
            // Non-zero biases, so their gradients are exercised away from zero.
            for p in net.params_mut() {
                *p += 0.1;
            }
            let batch = 6;
            let x: Vec<f64> = (0..batch * 3).map(|i| (i as f64 * 0.37).sin()).collect();
            let c: Vec<f64> = (0..batch * 2).map(|i| 1.0 + 0.1 * i as f64).collect();
            let mut tape = Tape::default();
            let y = net.forward(&x, &mut tape).to_vec();
            let dout: Vec<f64> = y.iter().zip(&c).map(|(y, c)| c * y).collect();
            let mut grad = vec![0.0; net.params().len()];
            let dx = net.backward_to_inputs(&mut tape, &dout, &mut grad).to_vec();
            let mut only_params = vec![0.0; grad.len()];
            net.forward(&x, &mut tape);
            net.backward(&mut tape, &dout, &mut only_params);
            assert_eq!(only_params, grad);
            let h = 1e-6;
            for (i, &g) in dx.iter().enumerate() {
                let (mut plus, mut minus) = (x.clone(), x.clone());
                plus[i] += h;
                minus[i] -= h;
                let fd = (loss(&net, &plus, &c) - loss(&net, &minus, &c)) / (2.0 * h);
                assert!(
                    (fd - g).abs() < 1e-8 * (1.0 + fd.abs()),
                    "{activation:?} input {i}: fd {fd}, backward {g}"
                );
            }
            for (i, &g) in grad.iter().enumerate() {
                let mut plus = net.clone();
                plus.params_mut()[i] += h;
                let mut minus = net.clone();
                minus.params_mut()[i] -= h;
                let fd = (loss(&plus, &x, &c) - loss(&minus, &x, &c)) / (2.0 * h);
                let err = (fd - g).abs();
                assert!(
                    err < 1e-8 * (1.0 + fd.abs()),
                    "{activation:?} param {i}: fd {fd}, backward {g}"
                );
            }
        }
    }

    #[test]
    fn forward_is_per_row_and_layers_expose_the_layout() {
        let mut rng = StdRng::seed_from_u64(1);
        let net = Mlp::<f64>::new(&[2, 3, 1], 1.0, &mut rng);
        let x = [0.3, -0.2, 1.0, 0.5];
        let mut tape = Tape::default();
        let both = net.forward(&x, &mut tape).to_vec();
        let second = net.forward(&x[2..], &mut tape).to_vec();
        assert_eq!(both[1], second[0]);
        // By hand, from the (W, b) of each layer.
        let layers: Vec<_> = net.layers().collect();
        let (w1, b1) = layers[0];
        let h: Vec<f64> = (0..3)
            .map(|j| (w1[2 * j] * 0.3 + w1[2 * j + 1] * -0.2 + b1[j]).tanh())
            .collect();
        let (w2, b2) = layers[1];
        let y = w2.iter().zip(&h).map(|(w, h)| w * h).sum::<f64>() + b2[0];
        assert!((y - both[0]).abs() < 1e-14);
        assert_eq!(net.params().len(), 3 * 3 + 4);
        let rebuilt = Mlp::from_params(&[2, 3, 1], net.params().to_vec()).unwrap();
        assert_eq!(rebuilt, net);
        assert!(Mlp::from_params(&[2, 3, 1], vec![0.0; 5]).is_err());
    }
}
