//! MuJoCo's compiler-side quaternion helpers and `mjuu_eig3`: the
//! eigen-decomposition of a symmetric 3x3 matrix by Jacobi rotations
//! accumulated in a quaternion, eigenvalues sorted decreasing (a swap turns
//! the quaternion by a quarter turn). A mesh's compiled frame (geom_quat)
//! is this quaternion, so its path matters, not only its limit.
//!
//! The stopping rule: MuJoCo 3.x stops at an absolute off-diagonal of
//! 1e-12 or a rotation cosine within 1e-12 of 1; MuJoCo 4.0.0 (whose
//! source is not at hand) does not, as its fully rotated small meshes show.
//! The rule here, off-diagonal at most 1e-7 of the largest entry, no cosine
//! test, sorting ties within the same bound, is fitted to MuJoCo 4.0.0's
//! compiled mesh_quat (30 dm_control meshes agree to 2e-10; looser or
//! tighter bounds do worse). Matrices are row-major `[f64; 9]`,
//! quaternions (w, x, y, z).

/// MuJoCo's `mjEPS`.
const EPS: f64 = 1e-14;
/// The Jacobi iteration stops when the largest off-diagonal entry is at
/// most this fraction of the largest entry (see [`eig3`]).
const REL_TOL: f64 = 1e-7;

/// `mjuu_normvec`: normalises unless the norm is below mjEPS or within
/// mjEPS of 1.
pub fn normalize<const N: usize>(v: &mut [f64; N]) {
    let norm = v.iter().map(|x| x * x).sum::<f64>();
    if norm < EPS {
        return;
    }
    let norm = norm.sqrt();
    if (norm - 1.0).abs() > EPS {
        v.iter_mut().for_each(|x| *x /= norm);
    }
}

/// `mjuu_quat2mat`: the rotation matrix of a unit quaternion.
pub fn quat_to_mat(q: &[f64; 4]) -> [f64; 9] {
    if *q == [1.0, 0.0, 0.0, 0.0] {
        return [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    }
    let [w, x, y, z] = *q;
    let (q00, q01, q02, q03) = (w * w, w * x, w * y, w * z);
    let (q11, q12, q13, q22, q23, q33) = (x * x, x * y, x * z, y * y, y * z, z * z);
    [
        q00 + q11 - q22 - q33,
        2.0 * (q12 - q03),
        2.0 * (q13 + q02),
        2.0 * (q12 + q03),
        q00 - q11 + q22 - q33,
        2.0 * (q23 - q01),
        2.0 * (q13 - q02),
        2.0 * (q23 + q01),
        q00 - q11 - q22 + q33,
    ]
}

/// `mjuu_mulquat`: the product a b, normalised.
pub fn mul_quat(a: &[f64; 4], b: &[f64; 4]) -> [f64; 4] {
    let mut q = [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ];
    normalize(&mut q);
    q
}

/// `m v` (`mjuu_mulvecmat`).
pub fn mul_mat_vec(m: &[f64; 9], v: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| m[3 * i] * v[0] + m[3 * i + 1] * v[1] + m[3 * i + 2] * v[2])
}

/// `m^T v` (`mjuu_mulvecmatT`).
pub fn mul_mat_t_vec(m: &[f64; 9], v: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| m[i] * v[0] + m[3 + i] * v[1] + m[6 + i] * v[2])
}

fn mul_mat(a: &[f64; 9], b: &[f64; 9]) -> [f64; 9] {
    std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j]
    })
}

fn transpose(m: &[f64; 9]) -> [f64; 9] {
    std::array::from_fn(|k| m[3 * (k % 3) + k / 3])
}

/// Eigenvalues (decreasing) of the symmetric `mat` and the quaternion whose
/// rotation matrix has the eigenvectors as columns.
pub fn eig3(mat: &[f64; 9]) -> ([f64; 3], [f64; 4]) {
    let scale = mat.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let tol = REL_TOL * scale;
    let mut quat = [1.0, 0.0, 0.0, 0.0];
    let mut eigval = [0.0; 3];
    for _ in 0..500 {
        let v = quat_to_mat(&quat);
        let d = mul_mat(&mul_mat(&transpose(&v), mat), &v);
        eigval = [d[0], d[4], d[8]];
        let (rk, ck, rotk) = if d[1].abs() > d[2].abs() && d[1].abs() > d[5].abs() {
            (0, 1, 2)
        } else if d[2].abs() > d[5].abs() {
            (0, 2, 1)
        } else {
            (1, 2, 0)
        };
        if d[3 * rk + ck].abs() <= tol {
            break;
        }
        let tau = (d[4 * ck] - d[4 * rk]) / (2.0 * d[3 * rk + ck]);
        let t = if tau >= 0.0 {
            1.0 / (tau + (1.0 + tau * tau).sqrt())
        } else {
            -1.0 / (-tau + (1.0 + tau * tau).sqrt())
        };
        let c = 1.0 / (1.0 + t * t).sqrt();
        let mut rot = [0.0; 4];
        let s = (0.5 - 0.5 * c).sqrt();
        rot[rotk + 1] = if tau >= 0.0 { -s } else { s };
        if rotk == 1 {
            rot[rotk + 1] = -rot[rotk + 1];
        }
        rot[0] = (1.0 - rot[rotk + 1] * rot[rotk + 1]).sqrt();
        normalize(&mut rot);
        quat = mul_quat(&quat, &rot);
        normalize(&mut quat);
    }
    for j in 0..3 {
        let j1 = j % 2;
        if eigval[j1] + tol < eigval[j1 + 1] {
            eigval.swap(j1, j1 + 1);
            // MuJoCo's rounded cos(pi/4), kept for its exact quaternions.
            #[allow(clippy::approx_constant)]
            let mut rot = [0.707106781186548, 0.0, 0.0, 0.0];
            rot[(j1 + 2) % 3 + 1] = rot[0];
            quat = mul_quat(&quat, &rot);
            normalize(&mut quat);
        }
    }
    (eigval, quat)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvectors_diagonalise_and_values_decrease() {
        let m = [2.0, 0.3, -0.1, 0.3, 1.0, 0.2, -0.1, 0.2, 3.0];
        let (val, q) = eig3(&m);
        assert!(val[0] >= val[1] && val[1] >= val[2]);
        let v = quat_to_mat(&q);
        let d = mul_mat(&mul_mat(&transpose(&v), &m), &v);
        for i in 0..3 {
            assert!((d[4 * i] - val[i]).abs() < 1e-12);
        }
        // Off-diagonals within the stopping rule's bound (of max |m| = 3).
        assert!(d[1].abs().max(d[2].abs()).max(d[5].abs()) <= REL_TOL * 3.0);
    }
}
