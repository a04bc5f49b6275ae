//! MuJoCo's invweight0 constants (mj_setConst): per body the mean of the
//! diagonal of J M^-1 J^T over its COM's translational and rotational
//! Jacobians (body_invweight0), per dof the diagonal of M^-1
//! (dof_invweight0), at the reference configuration; 1 / mass for MuJoCo's
//! "simple" bodies (`slides_only`). They stand for A_ii in the rows' R
//! ([`crate::dynamics::constraint::impedance`]). With them, MuJoCo's
//! stat.meaninertia: the mean of M's diagonal there, which scales the noslip
//! sweeps' cost improvement ([`crate::dynamics::constraint::noslip`]).

use nalgebra::{Matrix3, Vector3};

use crate::dynamics::{crba, ltdl_factor, ltdl_solve, point_jacobian, world_frames, Data, Tree};
use crate::model::{JointKind, Param, Spec, MINVAL};
use crate::spatial::{lift, Real};

/// MuJoCo's body_invweight0 and dof_invweight0 of a tree built from `spec`,
/// at the reference configuration (mj_setConst), with the body masses and
/// COMs lifted as the tree's were (`lift_param`, see [`Tree::build_with`]).
/// A value that is not finite (inertia so large the mass matrix overflows) is 0.
/// Third, the mean inertia (1 without dofs, MuJoCo's default).
pub fn invweight0<T: Real>(
    tree: &Tree<T>,
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> (Vec<[T; 2]>, Vec<T>, T) {
    let (bodies, dofs, mean_inertia) = invweight0_raw(tree, spec, lift_param);
    let finite = |x: T| if x.is_finite() { x } else { T::zero() };
    (
        bodies.into_iter().map(|b| b.map(finite)).collect(),
        dofs.into_iter().map(finite).collect(),
        mean_inertia,
    )
}

fn invweight0_raw<T: Real>(
    tree: &Tree<T>,
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> (Vec<[T; 2]>, Vec<T>, T) {
    let n = tree.nv();
    let mut data = Data::new(tree);
    let q: Vec<T> = spec.reference_q().into_iter().map(lift).collect();
    crba(tree, &mut data, &q);
    let mean_inertia = if n == 0 {
        T::one()
    } else {
        data.mass_matrix.diagonal().sum() / lift(n as f64)
    };
    let mut factored = data.mass_matrix.clone();
    ltdl_factor(tree, &mut factored);
    world_frames(tree, &mut data, &vec![T::zero(); n]);
    let three: T = lift(3.0);
    let simple: Vec<bool> = (0..spec.bodies.len())
        .map(|b| slides_only(spec, b))
        .collect();
    let mut bodies = vec![[T::zero(); 2]; spec.bodies.len()];
    for (b, body) in spec.bodies.iter().enumerate().skip(1) {
        let frame = tree.body[b];
        let Some(node) = frame.node else { continue };
        let mass = lift_param(Param::Mass(b), 0, body.mass);
        if simple[b] {
            bodies[b] = [T::one() / mass.max(lift(MINVAL)), T::zero()];
            continue;
        }
        let x = frame.offset.compose(&data.world[node]);
        let com = Vector3::from_fn(|r, _| lift_param(Param::Com(b), r, body.com[r]));
        let com = x.trans + x.axes() * com;
        let (jp, jr) = point_jacobian(tree, &data, node, &com);
        let mut trace = [T::zero(); 2];
        for (k, jac) in [jp, jr].iter().enumerate() {
            for row in jac.row_iter() {
                let mut x: Vec<T> = row.iter().copied().collect();
                ltdl_solve(tree, &factored, &mut x);
                trace[k] += row.iter().zip(&x).fold(T::zero(), |s, (a, b)| s + *a * *b);
            }
        }
        bodies[b] = trace.map(|t| t / three);
    }
    let dofs = (0..n)
        .map(|i| {
            let body = spec.joints[tree.node_joint[i]].body;
            if simple[body] {
                let mass = lift_param(Param::Mass(body), 0, spec.bodies[body].mass);
                return T::one() / mass.max(lift(MINVAL));
            }
            let mut e = vec![T::zero(); n];
            e[i] = T::one();
            ltdl_solve(tree, &factored, &mut e);
            e[i]
        })
        .collect();
    (bodies, dofs, mean_inertia)
}

/// MuJoCo's "simple" bodies of level 2, whose invweight0 is 1 / mass: only
/// slide joints along coordinate axes through the body origin, the COM at
/// the origin with principal axes along the body's, a child of the world or
/// of a static child of the world, and no children.
fn slides_only(spec: &Spec, b: usize) -> bool {
    let body = &spec.bodies[b];
    let parent = &spec.bodies[body.parent];
    let root = body.parent == 0 || (parent.parent == 0 && parent.joints.is_empty());
    let joints = &spec.joints[body.joints.clone()];
    let aligned = |a: &Vector3<f64>| a.iter().filter(|x| x.abs() > 1e-14).count() == 1;
    let inertia = body.inertia;
    let diagonal = inertia == Matrix3::from_diagonal(&inertia.diagonal());
    b > 0
        && !joints.is_empty()
        && root
        && body.com == Vector3::zeros()
        && diagonal
        && !spec.bodies.iter().any(|c| c.parent == b)
        && joints
            .iter()
            .all(|j| j.kind == JointKind::Slide && j.anchor == Vector3::zeros() && aligned(&j.axis))
}
