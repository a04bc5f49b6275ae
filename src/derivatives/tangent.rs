//! The step's chain rule where q lives on a manifold: the rotation of a
//! ball or free joint, whose tangent is the body-frame rotation vector d of
//! q (+) d = q exp(d) ([`crate::dynamics::configuration`]). Rows and
//! columns of q are in the tangent space (mjd_transitionFD's layout).
//!
//! - Semi-implicit Euler's q' = q (+) h v' on a rotation, w = h v' (its
//!   three dofs): q exp(d) exp(w) = q exp(w) exp(R(w)^T d) and
//!   q exp(w + dw) = q exp(w) exp(J_r(w) dw), so
//!   d q' = R(w)^T d q + h J_r(w) d v', with the right Jacobian
//!   J_r(w) = I - (1 - cos t) / t^2 [w]x + (t - sin t) / t^3 [w]x^2, t = |w|.
//! - A rotation's spring force -k r, r = log(q_ref^-1 q) (MuJoCo's
//!   mju_subQuat): dr / d(q (+) d) = J_r(r)^-1 = I + [r]x / 2 + c(t) [r]x^2,
//!   c as in [`crate::dynamics::configuration::tangent_rate`].

use nalgebra::{Matrix3, Vector3};

use crate::dynamics::configuration::{second_order, Coordinates};
use crate::dynamics::Tree;
use crate::spatial::skew;

/// One rotation's blocks of the Euler step's chain rule (module documentation).
#[derive(Clone, Copy, Debug)]
pub(super) struct Rotation {
    /// Its first dof.
    pub at: usize,
    /// R(w)^T: d q' / d q.
    pub turn: Matrix3<f64>,
    /// h J_r(w): d q' / d v'.
    pub slope: Matrix3<f64>,
}

/// The first dof of each rotation (a ball's, or a free joint's last three).
fn rotation_starts(tree: &Tree<f64>) -> impl Iterator<Item = usize> + '_ {
    (0..tree.nv()).filter(|&i| {
        matches!(
            tree.joint[i].coordinates,
            Coordinates::Rotation { axis: 0, .. }
        )
    })
}

/// The three entries of `x` from `at`.
fn block(x: &[f64], at: usize) -> Vector3<f64> {
    Vector3::new(x[at], x[at + 1], x[at + 2])
}

/// The rotations' blocks of q' = q (+) h v' (none without ball or free joints).
pub(super) fn rotations(tree: &Tree<f64>, h: f64, v_next: &[f64]) -> Vec<Rotation> {
    rotation_starts(tree)
        .map(|at| {
            let w = block(v_next, at) * h;
            let turn = nalgebra::Rotation3::new(w).into_inner().transpose();
            Rotation {
                at,
                turn,
                slope: right_jacobian(&w) * h,
            }
        })
        .collect()
}

/// J_r(w), by its series below t = 1e-4.
fn right_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    let squared = w.norm_squared();
    let (first, second) = if squared < 1e-8 {
        (0.5 - squared / 24.0, 1.0 / 6.0 - squared / 120.0)
    } else {
        let t = squared.sqrt();
        ((1.0 - t.cos()) / squared, (t - t.sin()) / (squared * t))
    };
    let k = skew(w);
    Matrix3::identity() - k * first + k * k * second
}

/// The d q' rows of one column of the Euler step's Jacobian on each
/// rotation: h J_r(w) d v' (`dv` the column's d v' rows), plus R(w)^T e_k
/// for the column of its q's tangent entry k (`q_column`, when the state's
/// columns are in).
pub(super) fn rotate_rows(
    rotations: &[Rotation],
    q_column: Option<usize>,
    (dq, dv): (&mut [f64], &[f64]),
) {
    for r in rotations {
        let mut rows = r.slope * block(dv, r.at);
        if let Some(k) = q_column.filter(|k| (r.at..r.at + 3).contains(k)) {
            rows += r.turn.column(k - r.at);
        }
        dq[r.at..r.at + 3].copy_from_slice(rows.as_slice());
    }
}

/// Adds to dR/dq (n x n, column-major) the rotations' spring terms
/// k J_r(r)^-1, `stretch` the springs' r (a rotation's entries in `r_q`
/// are left to this function).
pub(super) fn add_rotation_springs(tree: &Tree<f64>, stretch: &[f64], r_q: &mut [f64]) {
    let n = tree.nv();
    for at in rotation_starts(tree) {
        let r = block(stretch, at);
        let k = skew(&r);
        let inverse = Matrix3::identity() + k * 0.5 + k * k * second_order(r.norm_squared());
        for (row, col) in (0..3).flat_map(|a| (0..3).map(move |b| (a, b))) {
            r_q[(at + col) * n + at + row] += tree.stiffness[at + row] * inverse[(row, col)];
        }
    }
}

/// Whether node i is one of a rotation's three dofs.
pub(super) fn is_rotation(tree: &Tree<f64>, i: usize) -> bool {
    matches!(tree.joint[i].coordinates, Coordinates::Rotation { .. })
}

#[cfg(test)]
mod tests {
    use super::super::constrained::{dual_columns, DualTrees};
    use super::super::step::{step_jacobians, Workspace, Wrt};
    use crate::dynamics::configuration::integrate;
    use crate::model::{PassiveMode, Spec};
    use crate::Model;

    /// With ball and free joints under semi-implicit Euler the step's
    /// Jacobian is analytic (not [`super::super::dual_step`]) and equals
    /// dual numbers through the whole step to rounding: free_ball.xml (a
    /// free box, a sprung ball-jointed arm with a hinge below it, a ball
    /// pendulum; MuJoCo's implicit damping, and explicit), the body and
    /// joint parameters' columns included (the joint ones dual).
    #[test]
    fn ball_and_free_columns_equal_dual_numbers() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/free_ball.xml"
        );
        let loaded = Model::load(path).unwrap();
        let explicit = loaded
            .edited(|s: &mut Spec| s.opt.passive = PassiveMode::Explicit)
            .unwrap();
        for model in [loaded, explicit] {
            assert!(!super::super::dual_step(&model));
            let n = model.nv();
            let tangent: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
            let mut q = vec![0.0; model.nq()];
            integrate(model.tree(), &model.reference_q(), &tangent, 1.0, &mut q);
            let v: Vec<f64> = (0..n).map(|i| (i as f64 + 2.0).cos()).collect();
            let tau: Vec<f64> = (0..n).map(|i| 0.5 * (i as f64 + 3.0).sin()).collect();
            let names = ["body/box/mass", "body/arm/com", "joint/shoulder/stiffness"];
            let params: Vec<_> = names.iter().map(|p| model.param(p).unwrap()).collect();
            let wrt = Wrt {
                state: true,
                control: true,
                params: &params,
            };
            let j =
                step_jacobians(&model, &mut Workspace::new(&model), (&q, &v, &tau), &wrt).unwrap();
            let (dq, dv) =
                dual_columns(&model, &mut DualTrees::default(), (&q, &v, &tau), &wrt).unwrap();
            let rows = |r: usize| j.jacobian.rows(r, n).clone_owned();
            let err = (rows(0) - dq).amax().max((rows(n) - dv).amax());
            assert!(err < 1e-10, "{err:e}");
        }
    }
}
