//! Dense Cholesky factors of small symmetric positive definite matrices, in
//! place and without allocation: the constraint solver's Hessian, and its
//! inverse for the derivatives.
//!
//! Storage: an n x n column-major buffer whose column j holds row j of L
//! (A = L L^T) in its first j + 1 entries, so that the factorisation's dot
//! products and the solves run over contiguous memory; the diagonal entry
//! as its reciprocal 1 / L_jj, so that the chains of dependent operations
//! multiply instead of dividing. On matrices this
//! small (tens of rows) this is several times faster than nalgebra's
//! column-by-column Cholesky, and it allocates nothing.

use crate::spatial::Real;

/// Factors the symmetric `a` (n x n, column-major; its upper triangle is
/// read) in place; false if it is not numerically positive definite.
pub fn factor<T: Real>(a: &mut [T], n: usize) -> bool {
    for j in 0..n {
        for k in 0..=j {
            let dot = (0..k).fold(T::zero(), |s, p| s + a[j * n + p] * a[k * n + p]);
            let s = a[j * n + k] - dot;
            if k < j {
                a[j * n + k] = s * a[k * n + k];
            } else if s > T::zero() {
                a[j * n + j] = T::one() / s.sqrt();
            } else {
                return false; // not positive, or NaN
            }
        }
    }
    true
}

/// Solves A x = b in place for A factored by [`factor`] into `l`.
pub fn solve<T: Real>(l: &[T], n: usize, b: &mut [T]) {
    // L y = b, row by row.
    for j in 0..n {
        let row = &l[j * n..j * n + j];
        let dot = row
            .iter()
            .zip(&b[..j])
            .fold(T::zero(), |s, (x, y)| s + *x * *y);
        b[j] = (b[j] - dot) * l[j * n + j];
    }
    // L^T x = y: x_j, then its share removed from the entries above.
    for j in (0..n).rev() {
        b[j] *= l[j * n + j];
        let x = b[j];
        for (bi, lij) in b[..j].iter_mut().zip(&l[j * n..j * n + j]) {
            *bi -= *lij * x;
        }
    }
}

/// A^-1 into `out` (n x n, column-major) from A factored by [`factor`] into
/// `l`, which it overwrites with L^-1 (row i in column i).
pub fn inverse<T: Real>(l: &mut [T], n: usize, out: &mut [T]) {
    // W = L^-1 in place: entry (i, c) reads L's (i, k >= c), not yet
    // overwritten, and the rows of W above.
    for i in 0..n {
        for c in 0..i {
            let s = (c..i).fold(T::zero(), |s, k| s + l[i * n + k] * l[k * n + c]);
            l[i * n + c] = -s * l[i * n + i];
        }
    }
    // A^-1 = W^T W = sum over k of w_k w_k^T, w_k row k of W.
    out.fill(T::zero());
    for k in 0..n {
        let w = &l[k * n..k * n + k + 1];
        for (c, &wc) in w.iter().enumerate() {
            let column = &mut out[c * n..c * n + k + 1];
            column.iter_mut().zip(w).for_each(|(o, wr)| *o += *wr * wc);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn spd(n: usize) -> DMatrix<f64> {
        let b = DMatrix::from_fn(n, n, |i, j| ((3 * i + 7 * j) % 11) as f64 / 11.0 - 0.4);
        &b * b.transpose() + DMatrix::identity(n, n)
    }

    #[test]
    fn solve_and_inverse_invert_the_matrix() {
        let n = 7;
        let a = spd(n);
        let mut l = a.clone();
        assert!(factor(l.as_mut_slice(), n));
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        solve(l.as_slice(), n, &mut x);
        let residual =
            &a * DMatrix::from_column_slice(n, 1, &x) - DMatrix::from_column_slice(n, 1, &b);
        assert!(residual.amax() < 1e-13);
        let mut inv = DMatrix::zeros(n, n);
        inverse(l.as_mut_slice(), n, inv.as_mut_slice());
        assert!((&a * inv - DMatrix::identity(n, n)).amax() < 1e-13);
    }

    #[test]
    fn indefinite_and_nan_matrices_are_refused() {
        let mut a = spd(4);
        a[(2, 2)] = -5.0;
        assert!(!factor(a.as_mut_slice(), 4));
        let mut a = spd(4);
        a[(1, 1)] = f64::NAN;
        assert!(!factor(a.as_mut_slice(), 4));
    }
}
