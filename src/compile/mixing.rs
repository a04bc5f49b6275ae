//! The constraint model's pair parameters from its geoms' (see the
//! conventions of [`crate::dynamics::collision`]), lifted to the tree's scalar.

use crate::model::constraint::solmix;
use crate::model::{PairParams, Param, SolParams, Spec};
use crate::spatial::{lift, Real};

/// A geom's friction, solref and solimp in scalar T, lifted as its named
/// parameters (see [`Tree::build_with`](crate::dynamics::Tree::build_with)).
fn geom_params<T: Real>(
    spec: &Spec,
    g: usize,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> ([T; 3], SolParams<T>) {
    let geom = &spec.geoms[g];
    let friction = std::array::from_fn(|k| lift_param(Param::GeomFriction(g), k, geom.friction[k]));
    let sol = geom.contact.sol.lift(
        |k, x| lift_param(Param::GeomSolref(g), k, x),
        |k, x| lift_param(Param::GeomSolimp(g), k, x),
    );
    (friction, sol)
}

/// The parameters of a pair from its geoms' (see the conventions of [`crate::dynamics::collision`]).
pub(super) fn mixed<T: Real>(
    spec: &Spec,
    [a, b]: [usize; 2],
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> PairParams<T> {
    let (ca, cb) = (&spec.geoms[a].contact, &spec.geoms[b].contact);
    let ((fa, sa), (fb, sb)) = (
        geom_params(spec, a, lift_param),
        geom_params(spec, b, lift_param),
    );
    let (condim, friction, sol) = match ca.priority.cmp(&cb.priority) {
        std::cmp::Ordering::Greater => (ca.condim, fa, sa),
        std::cmp::Ordering::Less => (cb.condim, fb, sb),
        std::cmp::Ordering::Equal => {
            let mix: T = lift(solmix(ca.solmix, cb.solmix));
            let weigh = |x: T, y: T| mix * x + (T::one() - mix) * y;
            // At a tie the value is either's; its derivative the mean of
            // the one-sided ones (what central differences give).
            let tie = |x: T, y: T| (x + y) * lift(0.5);
            let smaller = |x: T, y: T| if x == y { tie(x, y) } else { x.min(y) };
            let larger = |x: T, y: T| if x == y { tie(x, y) } else { x.max(y) };
            let (ra, rb) = (sa.solref, sb.solref);
            let solref = if ra[0] > T::zero() && rb[0] > T::zero() {
                std::array::from_fn(|i| weigh(ra[i], rb[i]))
            } else {
                std::array::from_fn(|i| smaller(ra[i], rb[i]))
            };
            let solimp = std::array::from_fn(|i| weigh(sa.solimp[i], sb.solimp[i]));
            (
                ca.condim.max(cb.condim),
                std::array::from_fn(|i| larger(fa[i], fb[i])),
                SolParams { solref, solimp },
            )
        }
    };
    let [slide, spin, roll] = friction;
    PairParams {
        condim,
        friction: [slide, slide, spin, roll, roll],
        sol,
        solreffriction: [T::zero(); 2],
        margin: ca.margin + cb.margin,
        gap: ca.gap + cb.gap,
    }
}

/// An explicit pair's parameters in scalar T (they are no named parameter).
pub(super) fn lifted<T: Real>(p: &PairParams) -> PairParams<T> {
    PairParams {
        condim: p.condim,
        friction: p.friction.map(lift),
        sol: p.sol.lift(|_, x| lift(x), |_, x| lift(x)),
        solreffriction: p.solreffriction.map(lift),
        margin: p.margin,
        gap: p.gap,
    }
}
