//! The model's tendons compiled into what the algorithms read
//! ([`crate::dynamics::tendon`]), with MuJoCo's mj_setConst constants at
//! qpos0: the length (tendon_length0; the spring's deadband where
//! `springlength` is -1 -1 is the length at qpos_spring, the joints'
//! springref) and, under the constraint model, J M^-1 J^T
//! (tendon_invweight0) for the rows' A_ii.

use crate::dynamics::constraint::Limit;
use crate::dynamics::tendon::{Element, Path, Point};
use crate::dynamics::{
    crba, ltdl_factor, ltdl_solve, update_transforms, world_frames, Data, TendonConsts,
    TendonState, Tree,
};
use crate::model::{ContactModel, Param, Shape, Spec, Tendon, Wrap};
use crate::spatial::{lift, lift_matrix, lift_vector, Real};

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
            let path = path(spec, t);
            let support = support(tree, &path);
            let on = rows && spec.opt.solver.frictionloss && t.frictionloss > 0.0;
            let friction_sol = t.friction_sol.lift(|_, x| lift(x), |_, x| lift(x));
            let mut consts = TendonConsts {
                path,
                support,
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
            consts.length0 = state_at(tree, &consts, &q0).length;
            consts.lengthspring = match t.springlength {
                Some([lo, hi]) => [
                    lift_param(Param::TendonSpringlength(i), 0, lo),
                    lift_param(Param::TendonSpringlength(i), 1, hi),
                ],
                None => [state_at(tree, &consts, &tree.spring_q).length; 2],
            };
            consts
        })
        .collect();
    if rows && !out.is_empty() {
        set_invweight(tree, &q0, &mut out);
    }
    out
}

/// A tendon's path in the tree's terms.
fn path<T: Real>(spec: &Spec, t: &Tendon) -> Path<T> {
    if t.spatial.is_empty() {
        let terms = t.joints.iter().map(|(j, c)| {
            let (q_at, dof) = spec.joint_address(*j);
            (q_at, dof, lift(*c))
        });
        return Path::Fixed(terms.collect());
    }
    let site = |k: usize| {
        let s = &spec.sites[k];
        Point {
            body: s.body,
            pos: lift_vector(&s.pos),
        }
    };
    let element = |w: &Wrap| match *w {
        Wrap::Site(k) => Element::Site(site(k)),
        Wrap::Geom { geom, sidesite } => {
            let g = &spec.geoms[geom];
            let (radius, cylinder) = match g.shape {
                Shape::Cylinder { radius, .. } => (radius, true),
                Shape::Sphere { radius } => (radius, false),
                _ => unreachable!("wrap geoms are checked at load"),
            };
            Element::Geom {
                frame: Point {
                    body: g.body,
                    pos: lift_vector(&g.pos),
                },
                rot: lift_matrix(g.rot.matrix()),
                radius: lift(radius),
                cylinder,
                side: sidesite.map(site),
            }
        }
        Wrap::Pulley { divisor } => Element::Pulley(lift(divisor)),
    };
    Path::Spatial(t.spatial.iter().map(element).collect())
}

/// The dofs a path can move, descending and distinct: a fixed tendon's
/// joints', a spatial one's paths to the root of its sites' and geoms' bodies.
fn support<T: Real>(tree: &Tree<T>, path: &Path<T>) -> Vec<usize> {
    let mut dofs: Vec<usize> = match path {
        Path::Fixed(terms) => terms.iter().map(|(_, d, _)| *d).collect(),
        Path::Spatial(elements) => elements
            .iter()
            .filter_map(|e| match e {
                Element::Site(p) | Element::Geom { frame: p, .. } => Some(p.body),
                Element::Pulley(_) => None,
            })
            .flat_map(|b| std::iter::successors(tree.body[b].node, |&i| tree.parent[i]))
            .collect(),
    };
    dofs.sort_unstable_by(|a, b| b.cmp(a));
    dofs.dedup();
    dofs
}

/// A tendon's kinematics at q (at rest).
fn state_at<T: Real>(tree: &Tree<T>, t: &TendonConsts<T>, q: &[T]) -> TendonState<T> {
    let mut data = Data::new(tree);
    let v = vec![T::zero(); tree.nv()];
    update_transforms(tree, &mut data, q);
    world_frames(tree, &mut data, &v);
    t.state(tree, &data, (q, &v))
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
        state_at(tree, t, q0).add_moment(T::one(), &t.support, &mut j);
        let mut x = j.clone();
        ltdl_solve(tree, &factored, &mut x);
        let w = j.iter().zip(&x).fold(T::zero(), |s, (a, b)| s + *a * *b);
        t.invweight = if w.is_finite() { w } else { T::zero() };
    }
}
