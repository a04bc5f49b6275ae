//! A small dense matrix product, out = alpha a b + beta out, summed in a
//! fixed order without allocating (the derivatives' n x n products, n the
//! dofs: small enough that packing for a BLAS kernel costs more than it saves).

use nalgebra::{DMatrix, DMatrixView, DMatrixViewMut};

/// out = alpha a b + beta out, column by column over a's contiguous
/// columns, skipping b's zeros (nalgebra's gemm goes through
/// matrixmultiply, whose packing allocates: slower on matrices this small).
/// Each output entry is summed from beta out over a's columns in order, in
/// blocks of `BLOCK` rows held in registers, two blocks per pass over b;
/// the last block overlaps the one before it when `BLOCK` does not divide
/// the rows (an entry's sum is the same in either), and both are formed
/// in one pass, from the entries before either is written.
pub fn gemm(
    mut out: DMatrixViewMut<f64>,
    alpha: f64,
    a: &DMatrix<f64>,
    b: DMatrixView<f64>,
    beta: f64,
) {
    let n = a.nrows();
    let a = a.as_slice();
    let terms = (alpha, a, beta);
    for (mut column, b) in out.column_iter_mut().zip(b.column_iter()) {
        let (column, b) = (column.as_mut_slice(), b.as_slice());
        if n < BLOCK {
            for (i, x) in column.iter_mut().enumerate() {
                let mut sum = scaled(*x, beta);
                for (k, &bk) in b.iter().enumerate().filter(|(_, bk)| **bk != 0.0) {
                    sum += alpha * bk * a[k * n + i];
                }
                *x = sum;
            }
            continue;
        }
        let start = |block: usize| (block * BLOCK).min(n - BLOCK);
        let mut blocks = n.div_ceil(BLOCK);
        while blocks >= 2 {
            let pair = [start(blocks - 2), start(blocks - 1)];
            let sums = block_product(column, terms, b, pair);
            for (s, sum) in pair.into_iter().zip(sums) {
                column[s..s + BLOCK].copy_from_slice(&sum);
            }
            blocks -= 2;
        }
        if blocks == 1 {
            let [sum] = block_product(column, terms, b, [0]);
            column[..BLOCK].copy_from_slice(&sum);
        }
    }
}

/// Rows per block of [`gemm`].
const BLOCK: usize = 8;

/// beta x, with beta = 0 giving 0 and beta = 1 giving x exactly.
fn scaled(x: f64, beta: f64) -> f64 {
    if beta == 0.0 {
        0.0
    } else if beta == 1.0 {
        x
    } else {
        x * beta
    }
}

/// The blocks of rows start..start + BLOCK (for each start) of
/// alpha a b + beta out, for one column b of length n and its output
/// column `out`.
#[inline(always)]
fn block_product<const BLOCKS: usize>(
    out: &[f64],
    (alpha, a, beta): (f64, &[f64], f64),
    b: &[f64],
    starts: [usize; BLOCKS],
) -> [[f64; BLOCK]; BLOCKS] {
    let n = b.len();
    let mut sums = starts.map(|s| std::array::from_fn(|r| scaled(out[s + r], beta)));
    for (k, &bk) in b.iter().enumerate() {
        if bk != 0.0 {
            let s = alpha * bk;
            for (sum, start) in sums.iter_mut().zip(starts) {
                let a = &a[k * n + start..k * n + start + BLOCK];
                for r in 0..BLOCK {
                    sum[r] += s * a[r];
                }
            }
        }
    }
    sums
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blocked gemm equals the plain sum in the same order, bit for
    /// bit, for sizes below, at and between multiples of the block, with
    /// zeros in b and every kind of beta.
    #[test]
    fn gemm_sums_in_order() {
        for n in [1, 3, 7, 8, 9, 16, 17, 20] {
            let a = DMatrix::from_fn(n, n, |i, j| ((3 * i + 5 * j) % 7) as f64 / 7.0 - 0.3);
            let b = DMatrix::from_fn(n, 3, |i, j| {
                if (i + j) % 3 == 0 {
                    0.0
                } else {
                    0.1 * (i as f64 - j as f64).sin()
                }
            });
            let start = DMatrix::from_fn(n, 3, |i, j| (i + 2 * j) as f64 / 5.0);
            for beta in [0.0, 1.0, -0.5] {
                let mut out = start.clone();
                gemm(out.columns_mut(0, 3), -1.5, &a, b.columns(0, 3), beta);
                let expected = DMatrix::from_fn(n, 3, |i, j| {
                    let mut sum = scaled(start[(i, j)], beta);
                    for k in (0..n).filter(|&k| b[(k, j)] != 0.0) {
                        sum += -1.5 * b[(k, j)] * a[(i, k)];
                    }
                    sum
                });
                assert_eq!(out, expected, "n = {n}, beta = {beta}");
            }
        }
    }
}
