//! Least-squares regression of an [`Mlp`]: Adam on shuffled minibatches of
//! the mean squared error, its step size annealed linearly to zero over the
//! run, the held-out error reported after every epoch.

use rand::rngs::StdRng;
use rand::seq::SliceRandom;

use super::{Adam, Mlp, Tape};

/// How long and how fast to train.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    pub epochs: usize,
    pub batch: usize,
    /// Adam's initial step size.
    pub lr: f64,
}

/// Rows of standardised inputs and their targets, both row-major.
pub type Rows<'a> = (&'a [f32], &'a [f64]);

/// Fits `net` to (inputs, targets) rows of `train`; returns the mean squared
/// error on `held_out` before training and after every epoch, which
/// `progress(epoch, error)` also sees. Inputs are the network's (already
/// standardised), targets as the output layer should produce them.
pub fn fit_least_squares(
    net: &mut Mlp<f32>,
    (train, held_out): (Rows, Rows),
    schedule: Schedule,
    rng: &mut StdRng,
    mut progress: impl FnMut(usize, f64),
) -> Vec<f64> {
    let (dim, nout) = (net.inputs(), net.outputs());
    let (z_train, t_train) = train;
    let mut adam = Adam::new(net.params().len(), schedule.lr);
    let mut order: Vec<usize> = (0..t_train.len() / nout).collect();
    let steps_per_epoch = order.len().div_ceil(schedule.batch.max(1));
    let total_steps = (steps_per_epoch * schedule.epochs).max(1);
    let (mut tape, mut grad) = (Tape::default(), vec![0.0f32; net.params().len()]);
    let (mut zb, mut tb, mut dout) = (vec![], vec![], vec![]);
    let mut validation = vec![mse(net, held_out)];
    let mut step = 0;
    for epoch in 0..schedule.epochs {
        order.shuffle(rng);
        for batch in order.chunks(schedule.batch.max(1)) {
            adam.lr = schedule.lr * (1.0 - step as f64 / total_steps as f64);
            step += 1;
            zb.clear();
            tb.clear();
            for &i in batch {
                zb.extend_from_slice(&z_train[i * dim..(i + 1) * dim]);
                tb.extend_from_slice(&t_train[i * nout..(i + 1) * nout]);
            }
            let y = net.forward(&zb, &mut tape);
            let scale = 2.0 / tb.len() as f64;
            dout.clear();
            dout.extend(
                y.iter()
                    .zip(&tb)
                    .map(|(y, t)| (scale * (*y as f64 - t)) as f32),
            );
            net.backward(&mut tape, &dout, &mut grad);
            adam.step(net.params_mut(), &grad);
        }
        let loss = mse(net, held_out);
        progress(epoch + 1, loss);
        validation.push(loss);
    }
    validation
}

/// Mean squared error of the network on (inputs, targets) rows.
pub fn mse(net: &Mlp<f32>, (z, targets): Rows) -> f64 {
    let mut tape = Tape::default();
    let chunk = 4096 * net.inputs();
    let mut total = 0.0;
    for (zc, tc) in z.chunks(chunk).zip(targets.chunks(4096 * net.outputs())) {
        let y = net.forward(zc, &mut tape);
        total += y
            .iter()
            .zip(tc)
            .map(|(y, t)| (*y as f64 - t).powi(2))
            .sum::<f64>();
    }
    total / targets.len().max(1) as f64
}
