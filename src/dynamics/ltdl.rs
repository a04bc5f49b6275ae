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

/// M^-1 into `out` (n x n, column-major) for M factored by [`ltdl_factor`]
/// into `m`, as the sum over k of v_k v_k^T / D_k, v_k column k of L^-1
/// (M^-1 = L^-1 D^-1 L^-T); `column` is scratch of length n. Dense: L's
/// zeros between branches are read as zeros (on matrices this small a dense
/// sweep beats walking the tree). False, `out` unspecified, if a pivot of D
/// is not positive (M not numerically positive definite, or NaN).
pub fn ltdl_inverse(m: &DMatrix<f64>, column: &mut [f64], out: &mut [f64]) -> bool {
    let n = m.nrows();
    let m = m.as_slice();
    if !(0..n).all(|k| m[k + k * n] > 0.0) {
        return false;
    }
    out.fill(0.0);
    for k in 0..n {
        // v = L^-1 e_k: zero above k, one at k, then forward substitution.
        let v = &mut column[k..];
        v[0] = 1.0;
        for r in 1..v.len() {
            let row = (0..r).map(|j| m[k + r + (k + j) * n]);
            v[r] = -row.zip(&v[..r]).fold(0.0, |s, (l, x)| s + l * x);
        }
        let inverse_d = 1.0 / m[k + k * n];
        for (c, &vc) in v.iter().enumerate() {
            let scale = vc * inverse_d;
            let target = &mut out[(k + c) * n + k..(k + c + 1) * n];
            target
                .iter_mut()
                .zip(v.iter())
                .for_each(|(o, x)| *o += scale * x);
        }
    }
    true
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::crba;
    use crate::Model;

    /// The inverse from the factor inverts the half cheetah's branched mass
    /// matrix; a matrix with a non-positive pivot is refused.
    #[test]
    fn inverse_inverts_the_mass_matrix() {
        let model = Model::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/half_cheetah.xml"
        ))
        .unwrap();
        let (tree, n) = (model.tree(), model.nv());
        let mut data = model.data();
        let q: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
        crba(tree, &mut data, &q);
        let mass = data.mass_matrix.clone();
        let mut factor = mass.clone();
        ltdl_factor(tree, &mut factor);
        let (mut column, mut inverse) = (vec![0.0; n], DMatrix::zeros(n, n));
        assert!(ltdl_inverse(&factor, &mut column, inverse.as_mut_slice()));
        let error = (&mass * &inverse - DMatrix::identity(n, n)).amax();
        assert!(error < 1e-12, "{error:e}");
        factor[(4, 4)] = -1.0;
        assert!(!ltdl_inverse(&factor, &mut column, inverse.as_mut_slice()));
    }
}
