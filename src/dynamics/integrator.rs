//! How a step integrates its acceleration: semi-implicit Euler with its
//! implicit passive term, or an explicit Runge-Kutta method given by its
//! Butcher tableau. The step ([`super::step`]) and its chain rule
//! (`crate::derivatives`) read both from here.

use super::actuation::{act_rates, add_actuator_forces, next_acts};
use super::configuration::{integrate, tangent_rate};
use super::constraint::solver::Start;
use super::{acceleration, implicit_acceleration, stretch, Data, Tree};
use crate::model::{Integrator, Options, Param, PassiveMode};
use crate::spatial::{lift, Real};

/// The options' step when it is semi-implicit Euler, one acceleration with
/// v' = v + h qdd and q' = q (+) h v': its passive mode and timestep h. The
/// one test for the Euler-only paths: the derivatives write that step's
/// Jacobians and residuals straight from d qdd, and the residual of unknown
/// constraints is that step's.
pub fn euler(opt: &Options) -> Option<(PassiveMode, f64)> {
    (opt.integrator == Integrator::Euler).then_some((opt.passive, opt.timestep))
}

/// The integrator's Runge-Kutta tableau; None for Euler and the implicit ones.
pub fn tableau(integrator: Integrator) -> Option<&'static Tableau> {
    match integrator {
        Integrator::Euler | Integrator::ImplicitFast | Integrator::Implicit => None,
        Integrator::Rk4 => Some(&RK4),
    }
}

/// A tableau entry num / den, applied to a timestep h as h * num / den
/// (h / den exactly when num = 1); zero when num = 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rational {
    pub num: u8,
    pub den: u8,
}

impl Rational {
    const ZERO: Rational = Rational::new(0, 1);

    pub const fn new(num: u8, den: u8) -> Rational {
        Rational { num, den }
    }

    /// h times the entry; None for a zero entry (its term is skipped, not
    /// added as zero).
    pub fn times<T: Real>(self, h: T) -> Option<T> {
        (self.num != 0).then(|| h * lift(f64::from(self.num)) / lift(f64::from(self.den)))
    }
}

/// The Butcher tableau of an explicit Runge-Kutta method with s stages:
/// stage i is evaluated at x_i = x + h sum_{j<i} a_ij k_j, at time
/// t + c_i h, and the step is x' = x + h sum_i b_i k_i (each sum over its
/// nonzero entries, in order of j).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tableau {
    /// Row i holds a_ij for j < i (row 0 empty).
    pub a: &'static [&'static [Rational]],
    pub b: &'static [Rational],
    /// The stages' times (the sums of a's rows); no force depends on time
    /// within a step yet (tau is held), so only the tests read them.
    pub c: &'static [Rational],
}

impl Tableau {
    pub fn stages(&self) -> usize {
        self.b.len()
    }

    /// h a_ij for the nonzero entries of row i: (j, h a_ij).
    pub fn stage_terms<T: Real>(&self, i: usize, h: T) -> impl Iterator<Item = (usize, T)> + '_ {
        let row = self.a[i].iter().enumerate();
        row.filter_map(move |(j, a)| a.times(h).map(|ha| (j, ha)))
    }
}

/// The classic fourth-order Runge-Kutta method.
pub const RK4: Tableau = {
    const HALF: Rational = Rational::new(1, 2);
    const ONE: Rational = Rational::new(1, 1);
    Tableau {
        a: &[
            &[],
            &[HALF],
            &[Rational::ZERO, HALF],
            &[Rational::ZERO, Rational::ZERO, ONE],
        ],
        b: &[
            Rational::new(1, 6),
            Rational::new(1, 3),
            Rational::new(1, 3),
            Rational::new(1, 6),
        ],
        c: &[Rational::ZERO, HALF, HALF, ONE],
    }
};

/// The implicit passive term of a semi-implicit Euler step under a
/// [`PassiveMode`]: the passive forces -D v - K s(q) taken at the next
/// state instead of the current one, damping at v' and, with an implicit
/// spring, the spring at q' = q + h v'. On the left they add
/// E = -h d(tau_passive)/dv' to the mass matrix, -h times MuJoCo's qDeriv
/// (its implicit integrators solve (M - h qDeriv) qdd = f); the implicit
/// spring also adds -K h v on the right (the stretch s(q) + h v). E is
/// diagonal, E_ii = h d_i (+ h^2 k_i), while only joint damping and
/// stiffness enter it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImplicitPassive<T> {
    /// dE_ii / d(damping d_i): h when damping acts at v'.
    damping: Option<T>,
    /// The spring's step h when the spring acts at q' (dE_ii / dk_i = h^2).
    spring: Option<T>,
}

impl<T: Real> ImplicitPassive<T> {
    pub fn new(mode: PassiveMode, h: T) -> Self {
        let (damping, spring) = match mode {
            PassiveMode::Explicit => (None, None),
            PassiveMode::ImplicitDamping => (Some(h), None),
            PassiveMode::ImplicitDampingStiffness => (Some(h), Some(h)),
        };
        ImplicitPassive { damping, spring }
    }

    /// Whether the term is there at all (the passive forces are not explicit).
    pub fn acts(&self) -> bool {
        self.damping.is_some()
    }

    /// E_ii for a dof with damping d and stiffness k.
    pub fn diagonal(&self, d: T, k: T) -> T {
        match (self.damping, self.spring) {
            (None, _) => T::zero(),
            (Some(h), None) => h * d,
            (Some(h), Some(hs)) => h * d + hs * hs * k,
        }
    }

    /// dE_ii / d d_i, None where damping is explicit.
    pub fn damping_weight(&self) -> Option<T> {
        self.damping
    }

    /// dE_ii / d k_i (h^2), None where the spring is explicit.
    pub fn stiffness_weight(&self) -> Option<T> {
        self.spring.map(|h| h * h)
    }

    /// The spring's stretch rate: h where the spring acts at q' = q + h v',
    /// so that its stretch is s(q) + h v; zero otherwise.
    pub fn spring_step(&self) -> T {
        self.spring.unwrap_or(T::zero())
    }

    /// The change of E with a parameter, (dof, dE_ii / dp) for the joint
    /// parameters it holds; None for any other.
    pub fn partial(&self, param: Param) -> Option<(usize, T)> {
        match param {
            Param::Damping(i) => self.damping_weight().map(|w| (i, w)),
            Param::Stiffness(i) => self.stiffness_weight().map(|w| (i, w)),
            _ => None,
        }
    }
}

/// For a semi-implicit Euler step: the springs' stretch where they act, and
/// the diagonal E added to M by the implicit passive terms ([`ImplicitPassive`]).
pub fn implicit_terms<T: Real>(
    tree: &Tree<T>,
    (mode, h): (PassiveMode, f64),
    (q, v): (&[T], &[T]),
    stretched: &mut [T],
    extra: &mut [T],
) {
    let implicit = ImplicitPassive::new(mode, lift::<T>(h));
    stretch(tree, q, stretched);
    for i in 0..tree.nv() {
        let (d, k) = (tree.damping[i], tree.stiffness[i]);
        extra[i] = implicit.diagonal(d, k);
        if implicit.spring.is_some() {
            stretched[i] += implicit.spring_step() * v[i];
        }
    }
}

/// Semi-implicit Euler: the acceleration at (q, v) under `mode`, then
/// [`integrate_euler`].
pub(super) fn euler_step<T: Real>(
    tree: &Tree<T>,
    (mode, h): (PassiveMode, f64),
    data: &mut Data<T>,
    (q, v, tau): (&[T], &[T], &[T]),
    (q_next, v_next): (&mut [T], &mut [T]),
) {
    let mut qdd = std::mem::take(&mut data.stage.qdd[0]);
    acceleration(tree, data, (mode, h), (q, v, tau), &mut qdd);
    integrate_euler(tree, h, (q, v, &qdd), (q_next, v_next));
    data.stage.qdd[0] = qdd;
}

/// MuJoCo's `implicitfast` or `implicit` step (the tree's integrator): the
/// acceleration of [`implicit_acceleration`], then [`integrate_euler`].
pub(super) fn implicit_step<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v, tau): (&[T], &[T], &[T]),
    (q_next, v_next): (&mut [T], &mut [T]),
) {
    let mut qdd = std::mem::take(&mut data.stage.qdd[0]);
    implicit_acceleration(tree, data, tree.opt.integrator, (q, v, tau), &mut qdd);
    integrate_euler(tree, tree.opt.timestep, (q, v, &qdd), (q_next, v_next));
    data.stage.qdd[0] = qdd;
}

/// v' = v + h qdd, q' = q (+) h v'.
pub fn integrate_euler<T: Real>(
    tree: &Tree<T>,
    h: f64,
    (q, v, qdd): (&[T], &[T], &[T]),
    (q_next, v_next): (&mut [T], &mut [T]),
) {
    let h: T = lift(h);
    for i in 0..v.len() {
        v_next[i] = v[i] + h * qdd[i];
    }
    integrate(tree, q, v_next, h, q_next);
}

/// The buffers of a Runge-Kutta step, kept in [`Data`]: per stage its
/// acceleration and tangent rate (nv each); the stage's q (nq), v, tangent
/// offset theta from q, and the weighted sum of the tangent rates (nv each).
#[derive(Clone, Debug)]
pub struct Stages<T: Real> {
    pub(super) qdd: Vec<Vec<T>>,
    rate: Vec<Vec<T>>,
    q: Vec<T>,
    v: Vec<T>,
    theta: Vec<T>,
    dq: Vec<T>,
    /// With actuators: the stage's applied forces (nv), activation (na),
    /// the activation rates per stage and their b-weighted sum (na each).
    tau: Vec<T>,
    act: Vec<T>,
    act_rate: Vec<Vec<T>>,
    act_sum: Vec<T>,
}

impl<T: Real> Stages<T> {
    /// Sized for `tree` and [`RK4`]'s stages (a tableau with more grows them
    /// on its first step).
    pub fn new(tree: &Tree<T>) -> Self {
        let n = tree.nv();
        let per_stage = || vec![vec![T::zero(); n]; RK4.stages()];
        let na = tree.na;
        Stages {
            qdd: per_stage(),
            rate: per_stage(),
            q: vec![T::zero(); tree.nq()],
            v: vec![T::zero(); n],
            theta: vec![T::zero(); n],
            dq: vec![T::zero(); n],
            tau: vec![T::zero(); n],
            act: vec![T::zero(); na],
            act_rate: vec![vec![T::zero(); na]; RK4.stages()],
            act_sum: vec![T::zero(); na],
        }
    }
}

/// No buffers, for [`std::mem::take`].
impl<T: Real> Default for Stages<T> {
    fn default() -> Self {
        Stages {
            qdd: vec![],
            rate: vec![],
            q: vec![],
            v: vec![],
            theta: vec![],
            dq: vec![],
            tau: vec![],
            act: vec![],
            act_rate: vec![],
            act_sum: vec![],
        }
    }
}

/// An explicit Runge-Kutta step on (q, v) with explicit passive forces, its
/// stages moved along the manifold as MuJoCo's mj_RungeKutta moves them:
/// stage i at (q (+) theta_i, v_i), theta_i = sum_j h a_ij r_j and
/// v_i = v + sum_j h a_ij qdd_j, r_j the tangent rate of stage j at q
/// ([`tangent_rate`]); q' = q (+) sum_i h b_i r_i, v' = v + sum_i h b_i qdd_i,
/// accumulated in (q_next, v_next) stage by stage. With actuators, each
/// stage's forces add the actuators' at the stage's (q, v, act), the
/// activation moving as [`super::step_actuated`] states; `act` is None
/// when the actuators are idle ([`super::actuation::idle_without_inputs`]).
pub(super) fn runge_kutta<T: Real>(
    tree: &Tree<T>,
    (tableau, timestep): (&Tableau, f64),
    data: &mut Data<T>,
    (q, v): (&[T], &[T]),
    (ctrl, act, tau): (&[T], Option<&[T]>, &[T]),
    (q_next, v_next): (&mut [T], &mut [T]),
    act_next: &mut [T],
) {
    let h: T = lift(timestep);
    let s = tableau.stages();
    let mut stage = std::mem::take(&mut data.stage);
    let n = tree.nv();
    stage.qdd.resize_with(s, || vec![T::zero(); n]);
    stage.rate.resize_with(s, || vec![T::zero(); n]);
    stage.act_rate.resize_with(s, || vec![T::zero(); tree.na]);
    let Stages {
        qdd,
        rate,
        q: q_stage,
        v: v_stage,
        theta,
        dq,
        tau: tau_stage,
        act: act_stage,
        act_rate,
        act_sum,
    } = &mut stage;
    q_stage.copy_from_slice(q);
    v_stage.copy_from_slice(v);
    v_next.copy_from_slice(v);
    dq.fill(T::zero());
    theta.fill(T::zero());
    // Actuators that act: act None when they are idle (no forces, no activation).
    let actuated = act.is_some();
    let act = act.unwrap_or_default();
    if actuated {
        for (a, x) in act_stage.iter_mut().enumerate() {
            *x = act.get(a).copied().unwrap_or(T::zero());
        }
        act_sum.fill(T::zero());
    }
    for k in 0..s {
        // Stages after the first start their solve from the stage before's solution.
        data.reuse.start = if k == 0 {
            Start::Unconstrained
        } else {
            Start::Previous
        };
        let forces = if actuated {
            let actuators = &tree.actuators;
            act_rates(actuators, (ctrl, &act_stage[..]), &mut act_rate[k]);
            tau_stage.copy_from_slice(tau);
            let inputs = (ctrl, &act_stage[..], &act_rate[k][..]);
            add_actuator_forces(tree, timestep, data, (q_stage, v_stage), inputs, tau_stage);
            if let Some(b) = tableau.b[k].times(T::one()) {
                for (sum, r) in act_sum.iter_mut().zip(&act_rate[k]) {
                    *sum += b * *r;
                }
            }
            &tau_stage[..]
        } else {
            tau
        };
        let stage_state = (&q_stage[..], &v_stage[..], forces);
        let explicit = (PassiveMode::Explicit, timestep);
        acceleration(tree, data, explicit, stage_state, &mut qdd[k]);
        // The stage derivative is (tangent rate, qdd).
        tangent_rate(tree, theta, v_stage, &mut rate[k]);
        if let Some(w) = tableau.b[k].times(h) {
            for i in 0..n {
                dq[i] += w * rate[k][i];
                v_next[i] += w * qdd[k][i];
            }
        }
        if k + 1 < s {
            for i in 0..n {
                theta[i] = weighted_sum(tableau.stage_terms(k + 1, h), rate, i);
                v_stage[i] = v[i] + weighted_sum(tableau.stage_terms(k + 1, h), qdd, i);
            }
            for (i, x) in act_stage.iter_mut().enumerate() {
                let start = act.get(i).copied().unwrap_or(T::zero());
                *x = start + weighted_sum(tableau.stage_terms(k + 1, h), act_rate, i);
            }
            integrate(tree, q, theta, T::one(), q_stage);
        }
    }
    integrate(tree, q, dq, T::one(), q_next);
    if !act_next.is_empty() {
        next_acts(&tree.actuators, timestep, (act, &act_sum[..]), act_next);
    }
    data.reuse.start = Start::Unconstrained;
    data.stage = stage;
}

/// sum over `terms` (j, w) of w x_j\[i\], from the first term on (zero with none).
pub fn weighted_sum<T: Real>(terms: impl Iterator<Item = (usize, T)>, x: &[Vec<T>], i: usize) -> T {
    let mut terms = terms.map(|(j, w)| w * x[j][i]);
    let first = terms.next().unwrap_or(T::zero());
    terms.fold(first, |sum, t| sum + t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RK4's entries times h are today's h / 2, h, h / 6 and h / 3 bit for
    /// bit, and its rows sum to its nodes.
    #[test]
    fn the_rk4_tableau_gives_exact_quotients() {
        for h in [0.002, 0.01, 1.0 / 3.0, 0.0123456789] {
            let b: Vec<f64> = RK4.b.iter().map(|b| b.times(h).unwrap()).collect();
            assert_eq!(b, [h / 6.0, h / 3.0, h / 3.0, h / 6.0]);
            let steps: Vec<Vec<(usize, f64)>> =
                (1..4).map(|i| RK4.stage_terms(i, h).collect()).collect();
            assert_eq!(
                steps,
                [vec![(0, h / 2.0)], vec![(1, h / 2.0)], vec![(2, h)]]
            );
        }
        for (i, row) in RK4.a.iter().enumerate() {
            let sum: f64 = row.iter().map(|a| a.times(1.0).unwrap_or(0.0)).sum();
            assert_eq!(sum, RK4.c[i].times(1.0).unwrap_or(0.0));
        }
    }

    /// E's diagonal and its partials under each mode.
    #[test]
    fn implicit_passive_diagonal() {
        let (h, d, k) = (0.01, 2.0, 30.0);
        let term = |mode| ImplicitPassive::new(mode, h);
        assert_eq!(term(PassiveMode::Explicit).diagonal(d, k), 0.0);
        assert_eq!(term(PassiveMode::ImplicitDamping).diagonal(d, k), h * d);
        let dart = term(PassiveMode::ImplicitDampingStiffness);
        assert_eq!(dart.diagonal(d, k), h * d + h * h * k);
        assert_eq!(dart.partial(Param::Stiffness(1)), Some((1, h * h)));
        assert_eq!(
            term(PassiveMode::ImplicitDamping).partial(Param::Stiffness(1)),
            None
        );
        assert_eq!(term(PassiveMode::Explicit).partial(Param::Damping(0)), None);
    }
}
