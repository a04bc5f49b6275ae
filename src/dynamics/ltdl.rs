//! Sparse factorization of the joint-space inertia, M = L^T D L, following the
//! tree (Featherstone, RBDA section 6.5): L is unit lower triangular with
//! L[k][i] nonzero only for i an ancestor of k, so the factorization costs
//! O(n d^2) and a solve O(n d) for tree depth d, and branches never fill in.

use nalgebra::DMatrix;

use super::Tree;
use crate::spatial::Real;

/// Factors `m` in place: afterwards its diagonal holds D and its strictly lower
/// part (on ancestor pairs) holds L. Needs parents before children.
pub fn ltdl_factor<T: Real>(tree: &Tree<T>, m: &mut DMatrix<T>) {
    for k in (0..tree.nv()).rev() {
        let mut i = tree.parent[k];
        while let Some(ii) = i {
            let a = m[(k, ii)] / m[(k, k)];
            let mut j = Some(ii);
            while let Some(jj) = j {
                let m_kj = m[(k, jj)];
                m[(ii, jj)] -= a * m_kj;
                j = tree.parent[jj];
            }
            m[(k, ii)] = a;
            i = tree.parent[ii];
        }
    }
}

/// Solves M x = b in place for one right-hand side, M factored by [`ltdl_factor`].
pub fn ltdl_solve<T: Real>(tree: &Tree<T>, m: &DMatrix<T>, b: &mut [T]) {
    let n = tree.nv();
    // Column-major storage: entry (k, j) at k + j n.
    let m = m.as_slice();
    for k in (0..n).rev() {
        let mut j = tree.parent[k];
        while let Some(jj) = j {
            b[jj] -= m[k + jj * n] * b[k];
            j = tree.parent[jj];
        }
    }
    for (k, bk) in b.iter_mut().enumerate() {
        *bk /= m[k + k * n];
    }
    for k in 0..n {
        let mut j = tree.parent[k];
        while let Some(jj) = j {
            b[k] -= m[k + jj * n] * b[jj];
            j = tree.parent[jj];
        }
    }
}

/// Solves M X = B in place, column by column.
pub fn ltdl_solve_columns(tree: &Tree<f64>, m: &DMatrix<f64>, b: &mut DMatrix<f64>) {
    let n = tree.nv();
    if n == 0 {
        return;
    }
    for column in b.as_mut_slice().chunks_exact_mut(n) {
        ltdl_solve(tree, m, column);
    }
}
