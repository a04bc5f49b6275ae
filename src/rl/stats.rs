//! Running mean and variance, for observation and return normalisation.

/// Per-component mean and (population) variance of every sample seen so far,
/// merged batch by batch (Chan et al.'s parallel update).
#[derive(Clone, Debug, PartialEq)]
pub struct RunningStats {
    pub mean: Vec<f64>,
    pub var: Vec<f64>,
    pub count: f64,
}

impl RunningStats {
    /// Statistics of `dim` components, starting from mean 0, variance 1 with a
    /// tiny weight (so the first batch dominates at once).
    pub fn new(dim: usize) -> RunningStats {
        RunningStats {
            mean: vec![0.0; dim],
            var: vec![1.0; dim],
            count: 1e-4,
        }
    }

    /// Merges a batch of samples, given as rows of `dim` values.
    pub fn update(&mut self, rows: &[f64]) {
        let dim = self.mean.len();
        let n = (rows.len() / dim) as f64;
        if n == 0.0 {
            return;
        }
        for i in 0..dim {
            let column = rows.iter().skip(i).step_by(dim);
            let mean = column.clone().sum::<f64>() / n;
            let var = column.map(|x| (x - mean).powi(2)).sum::<f64>() / n;
            let total = self.count + n;
            let delta = mean - self.mean[i];
            self.mean[i] += delta * n / total;
            let m2 = self.var[i] * self.count + var * n + delta * delta * self.count * n / total;
            self.var[i] = m2 / total;
        }
        self.count += n;
    }

    /// Standard deviations sqrt(var + 1e-8).
    pub fn std(&self) -> Vec<f64> {
        self.var.iter().map(|v| (v + 1e-8).sqrt()).collect()
    }
}

/// Appends clamp((raw - mean) / std, -clip, clip) to `out`, row by row.
pub fn normalize_into(mean: &[f64], std: &[f64], clip: f64, raw: &[f64], out: &mut Vec<f32>) {
    let dim = mean.len();
    for (k, x) in raw.iter().enumerate() {
        let i = k % dim;
        out.push(((x - mean[i]) / std[i]).clamp(-clip, clip) as f32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batched_updates_match_the_whole_sample() {
        let data: Vec<f64> = (0..40)
            .map(|i| ((i * 7) % 11) as f64 - 3.0 * (i % 2) as f64)
            .collect();
        let mut stats = RunningStats::new(2);
        for chunk in data.chunks(6) {
            stats.update(chunk);
        }
        for i in 0..2 {
            let col: Vec<f64> = data.iter().skip(i).step_by(2).copied().collect();
            let mean = col.iter().sum::<f64>() / 20.0;
            let var = col.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 20.0;
            assert!(
                (stats.mean[i] - mean).abs() < 1e-4,
                "{} vs {mean}",
                stats.mean[i]
            );
            assert!(
                (stats.var[i] - var).abs() < 1e-3 * var,
                "{} vs {var}",
                stats.var[i]
            );
        }
        let mut out = vec![];
        normalize_into(&[1.0, 0.0], &[2.0, 1.0], 5.0, &[3.0, -9.0], &mut out);
        assert_eq!(out, vec![1.0, -5.0]);
    }
}
