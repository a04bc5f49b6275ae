//! Small dense networks for the controllers: an [`Mlp`] with tanh (or ReLU)
//! hidden layers and a linear output, trained by [`Adam`].
//!
//! Conventions: a batch is a row-major `batch x width` slice (one sample per
//! row). A layer's weight matrix is `out x in`, row-major, so a layer computes
//! `y = x W^T + b`. The parameters of a network live in one flat vector, layer
//! after layer, each layer's `W` then `b`; gradients use the same layout.
//!
//! Training runs in f32: matrixmultiply's sgemm has twice the SIMD width of
//! dgemm, PPO's noisy gradients need no more precision, and the weights files
//! are half the size. The code is generic over [`Float`] so that the same
//! backward pass is checked against finite differences in f64.

mod adam;
mod mlp;
mod regression;

pub use adam::Adam;
pub use mlp::{Activation, LayerFile, Mlp, Tape};
pub use regression::{fit_least_squares, mse, Schedule};

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub};

/// The scalar of a network: f32 (training) or f64 (gradient checks).
pub trait Float:
    Copy
    + Default
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + MulAssign
    + Send
    + Sync
    + 'static
{
    fn of(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    /// The hidden layers' activation, tanh.
    fn tanh(self) -> Self;
    /// `c = alpha a b + beta c` for an `m x k` matrix `a` and a `k x n` matrix
    /// `b`; each matrix is a slice with its (row, column) strides.
    #[allow(clippy::too_many_arguments)]
    fn gemm(
        dims: (usize, usize, usize),
        alpha: Self,
        a: (&[Self], isize, isize),
        b: (&[Self], isize, isize),
        beta: Self,
        c: (&mut [Self], isize, isize),
    );
}

/// Checks that an `rows x cols` matrix with strides (rs, cs) fits in `len`.
fn check_fits(len: usize, rows: usize, cols: usize, rs: isize, cs: isize) {
    assert!(rs >= 0 && cs >= 0, "negative strides are not used");
    if rows > 0 && cols > 0 {
        let last = (rows - 1) * rs as usize + (cols - 1) * cs as usize;
        assert!(
            last < len,
            "matrix {rows}x{cols} does not fit in {len} values"
        );
    }
}

macro_rules! gemm_impl {
    ($t:ty, $gemm:path) => {
        fn gemm(
            (m, k, n): (usize, usize, usize),
            alpha: $t,
            (a, rsa, csa): (&[$t], isize, isize),
            (b, rsb, csb): (&[$t], isize, isize),
            beta: $t,
            (c, rsc, csc): (&mut [$t], isize, isize),
        ) {
            check_fits(a.len(), m, k, rsa, csa);
            check_fits(b.len(), k, n, rsb, csb);
            check_fits(c.len(), m, n, rsc, csc);
            // SAFETY: the three matrices fit in their slices (checked above),
            // and `c` is a unique borrow, so it aliases neither `a` nor `b`.
            unsafe {
                $gemm(
                    m,
                    k,
                    n,
                    alpha,
                    a.as_ptr(),
                    rsa,
                    csa,
                    b.as_ptr(),
                    rsb,
                    csb,
                    beta,
                    c.as_mut_ptr(),
                    rsc,
                    csc,
                )
            }
        }
    };
}

impl Float for f32 {
    fn of(x: f64) -> f32 {
        x as f32
    }
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    fn tanh(self) -> f32 {
        fast_tanh(self)
    }
    gemm_impl!(f32, matrixmultiply::sgemm);
}

impl Float for f64 {
    fn of(x: f64) -> f64 {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    fn tanh(self) -> f64 {
        f64::tanh(self)
    }
    gemm_impl!(f64, matrixmultiply::dgemm);
}

/// tanh to within 1e-6 in f32, without a libm call, so that loops over it
/// vectorise: the [11/10] Pade approximant x P(x^2) / Q(x^2) (the fifth
/// convergent of Lambert's continued fraction), with |x| clamped to 7.63
/// where it meets tanh's own rounding to 1.
pub fn fast_tanh(x: f32) -> f32 {
    const P: [f32; 6] = [
        13749310575.0,
        1964187225.0,
        64324260.0,
        675675.0,
        2145.0,
        1.0,
    ];
    const Q: [f32; 6] = [
        13749310575.0,
        6547290750.0,
        413513100.0,
        7567560.0,
        45045.0,
        66.0,
    ];
    let x = x.clamp(-7.63, 7.63);
    let t = x * x;
    let horner = |c: &[f32; 6]| c.iter().rev().fold(0.0, |acc, &ci| acc * t + ci);
    x * horner(&P) / horner(&Q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_tanh_matches_tanh() {
        let worst = (-100_000..=100_000)
            .map(|i| i as f32 * 1e-4)
            .map(|x| (fast_tanh(x) as f64 - (x as f64).tanh()).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "max error {worst}");
        assert_eq!(fast_tanh(0.0), 0.0);
        assert_eq!(fast_tanh(-50.0), -fast_tanh(50.0));
        assert!((fast_tanh(50.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn gemm_multiplies_with_strides() {
        // a = [[1, 2], [3, 4]], b = a^T read through its strides.
        let a = [1.0, 2.0, 3.0, 4.0];
        let mut c = [1.0f64; 4];
        f64::gemm((2, 2, 2), 1.0, (&a, 2, 1), (&a, 1, 2), 2.0, (&mut c, 2, 1));
        assert_eq!(c, [7.0, 13.0, 13.0, 27.0]);
    }
}
