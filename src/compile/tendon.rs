//! The model's tendons compiled into what the algorithms read
//! ([`crate::dynamics::tendon`]), with MuJoCo's mj_setConst constants at
//! qpos0: the length (tendon_length0; the spring's deadband where
//! `springlength` is -1 -1 is the length at qpos_spring, the joints'
//! springref) and, under the constraint model, J M^-1 J^T
//! (tendon_invweight0) for the rows' A_ii.

use crate::dynamics::constraint::Limit;
use crate::dynamics::{crba, ltdl_factor, ltdl_solve, Data, TendonConsts, Tree};
use crate::model::{ContactModel, Param, Spec};
use crate::spatial::{lift, Real};

/// The tendons of `spec` on `tree` (its nodes built), their parameters
/// lifted through `lift_param` ([`Tree::build_with`]).
pub fn tendon_consts<T: Real>(
    tree: &Tree<T>,
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> Vec<TendonConsts<T>> {
    let q0: Vec<T> = spec.reference_q().into_iter().map(lift).collect();
    let rows = spec.opt.contact_model == ContactModel::Constraint;
    let mut out: Vec<TendonConsts<T>> = spec
        .tendons
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let path = t
                .joints
                .iter()
                .map(|(j, c)| {
                    let (q_at, dof) = spec.joint_address(*j);
                    (q_at, dof, lift(*c))
                })
                .collect();
            let on = rows && spec.opt.solver.frictionloss && t.frictionloss > 0.0;
            let friction_sol = t.friction_sol.lift(|_, x| lift(x), |_, x| lift(x));
            let mut consts = TendonConsts {
                path,
                stiffness: lift_param(Param::TendonStiffness(i), 0, t.stiffness),
                damping: lift_param(Param::TendonDamping(i), 0, t.damping),
                lengthspring: [T::zero(); 2],
                length0: T::zero(),
                invweight: T::zero(),
                limit: t
                    .range
                    .filter(|_| rows && spec.opt.limits)
                    .map(|[lo, hi]| Limit {
                        range: (lo, hi),
                        margin: t.margin,
                        sol: t.limit_sol.lift(|_, x| lift(x), |_, x| lift(x)),
                    }),
                frictionloss: (
                    if on {
                        lift_param(Param::TendonFrictionLoss(i), 0, t.frictionloss)
                    } else {
                        T::zero()
                    },
                    friction_sol,
                ),
            };
            consts.length0 = consts.length(&q0);
            consts.lengthspring = match t.springlength {
                Some([lo, hi]) => [
                    lift_param(Param::TendonSpringlength(i), 0, lo),
                    lift_param(Param::TendonSpringlength(i), 1, hi),
                ],
                None => [consts.length(&tree.spring_q); 2],
            };
            consts
        })
        .collect();
    if rows && !out.is_empty() {
        set_invweight(tree, &q0, &mut out);
    }
    out
}

/// tendon_invweight0 = J M^-1 J^T at q0 (0 where not finite).
fn set_invweight<T: Real>(tree: &Tree<T>, q0: &[T], tendons: &mut [TendonConsts<T>]) {
    let n = tree.nv();
    let mut data = Data::new(tree);
    crba(tree, &mut data, q0);
    let mut factored = data.mass_matrix.clone();
    ltdl_factor(tree, &mut factored);
    for t in tendons {
        let mut j = vec![T::zero(); n];
        t.add_moment(T::one(), &mut j);
        let mut x = j.clone();
        ltdl_solve(tree, &factored, &mut x);
        let w = j.iter().zip(&x).fold(T::zero(), |s, (a, b)| s + *a * *b);
        t.invweight = if w.is_finite() { w } else { T::zero() };
    }
}
