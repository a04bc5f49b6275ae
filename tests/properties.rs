//! Property tests (proptest) of the dynamics invariants on random trees
//! (`common::random_model`: 1-7 bodies, 0-3 hinges or slides each, random
//! inertias, damping, stiffness, armature) at random states:
//! - the mass matrix is symmetric positive definite;
//! - ABA agrees with a Cholesky solve of CRBA's mass matrix (with the implicit
//!   passive diagonal too), and RNEA inverts it;
//! - energy balance: without forces, kinetic + potential + spring energy
//!   never rises, and what it loses is the damping work sum h v^T D v;
//! - step Jacobians (state, control, every parameter) against central finite
//!   differences along a random direction, under every integrator and
//!   passive mode.
//!
//! The runner's seed is fixed and no failure file is written: every run
//! checks the same cases; a failure prints its shrunk case.

mod common;

use common::{bias, energy, mass_matrix, random_model};
use diffosi::derivatives::{step_jacobians, Workspace, Wrt};
use diffosi::dynamics::{aba, rnea, Data};
use diffosi::model::{Inputs, Integrator, Param, PassiveMode, State};
use diffosi::Model;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

const SETTINGS: [(Integrator, PassiveMode); 4] = [
    (Integrator::Euler, PassiveMode::Explicit),
    (Integrator::Euler, PassiveMode::ImplicitDamping),
    (Integrator::Euler, PassiveMode::ImplicitDampingStiffness),
    (Integrator::Rk4, PassiveMode::Explicit),
];

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(10),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A random tree (seed, bodies, settings) and a state (q offsets from the
/// reference, v, tau), each long enough for any tree (at most 20 dofs).
fn tree_and_state() -> impl Strategy<Value = (Model, Vec<f64>, Vec<f64>, Vec<f64>)> {
    let x = |r: f64| prop::collection::vec(-r..r, 20);
    (any::<u64>(), 1..8usize, 0..4usize, x(3.0), x(3.0), x(5.0)).prop_map(
        |(seed, n, s, dq, v, tau)| {
            let (integrator, passive) = SETTINGS[s];
            let model = random_model(seed, n, passive, integrator);
            let nv = model.nv();
            let q = model
                .reference_q()
                .iter()
                .zip(&dq)
                .map(|(a, b)| a + b)
                .collect();
            (model, q, v[..nv].to_vec(), tau[..nv].to_vec())
        },
    )
}

proptest! {
    #![proptest_config(config(64))]

    #[test]
    fn mass_matrix_is_symmetric_positive_definite((model, q, _, _) in tree_and_state()) {
        let m = mass_matrix(&model, &q);
        let scale = m.amax();
        prop_assert!((&m - m.transpose()).amax() <= 1e-14 * scale);
        let eig = m.symmetric_eigenvalues();
        prop_assert!(eig.min() > 1e-12 * scale, "eigenvalues {}", eig);
    }

    #[test]
    fn aba_agrees_with_crba_and_rnea_inverts_it(
        (model, q, v, tau) in tree_and_state(),
        extra in prop::collection::vec(0.0..1.0f64, 20),
    ) {
        let n = model.nv();
        let tree = model.tree();
        let mut data = Data::new(tree);
        let (mut qdd, mut plain) = (vec![0.0; n], vec![0.0; n]);
        aba(tree, &mut data, &q, &v, &tau, Some(&extra[..n]), &mut qdd);
        let m = mass_matrix(&model, &q) + DMatrix::from_diagonal(&DVector::from_column_slice(&extra[..n]));
        let rhs = DVector::from_column_slice(&tau) - bias(&model, &q, &v);
        let want = m.cholesky().unwrap().solve(&rhs);
        let err = (DVector::from_column_slice(&qdd) - &want).amax();
        prop_assert!(err < 1e-9 * (1.0 + want.amax()), "ABA vs CRBA {:e}", err);
        aba(tree, &mut data, &q, &v, &tau, None, &mut plain);
        let mut back = vec![0.0; n];
        rnea(tree, &mut data, &q, &v, &plain, &mut back);
        let err = back.iter().zip(&tau).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        prop_assert!(err < 1e-9 * (1.0 + rhs.amax()), "RNEA(ABA(tau)) - tau = {:e}", err);
    }
}

proptest! {
    #![proptest_config(config(24))]

    /// RK4 (explicit passive forces) at h = 1 ms for 0.2 s from the random
    /// state: no step raises the energy, and the energy lost is the damping
    /// work, the integral of v^T D v (trapezoid rule, O(h^2)).
    #[test]
    fn energy_balance_with_damping((model, q, v, _) in tree_and_state()) {
        let model = model.edited(|s| s.opt.integrator = Integrator::Rk4).unwrap();
        let h = model.opt.timestep;
        let power = |v: &[f64]| -> f64 {
            model.joints.iter().zip(v).map(|(j, v)| j.damping * v * v).sum()
        };
        let zero = vec![0.0; model.nv()];
        let rest = std::iter::repeat_n(Inputs::tau(&zero), 200);
        let states = model.rollout(&State::new(q.clone(), v.clone()), rest).unwrap();
        let e0 = energy(&model, &q, &v).abs() + 1.0;
        let mut work = 0.0;
        for w in states.windows(2) {
            let (x0, x1) = (&w[0], &w[1]);
            let loss = energy(&model, &x0.q, &x0.v) - energy(&model, &x1.q, &x1.v);
            prop_assert!(loss > -1e-10 * e0, "energy rose by {:e}", -loss);
            work += 0.5 * h * (power(&x0.v) + power(&x1.v));
        }
        let last = states.last().unwrap();
        let loss = energy(&model, &q, &v) - energy(&model, &last.q, &last.v);
        prop_assert!((loss - work).abs() < 2e-4 * work + 1e-10 * e0,
            "energy lost {:e}, damping work {:e}", loss, work);
    }

    /// J d against (step(x + e d) - step(x - e d)) / 2e for a random
    /// direction d of (q, v, tau, every parameter), each parameter scalar
    /// scaled by its size. Joint parameters at or near their lower bound 0
    /// are left out of d.
    #[test]
    fn jacobians_match_finite_differences_along_a_direction(
        (model, q, v, tau) in tree_and_state(),
        dir in prop::collection::vec(-1.0..1.0f64, 60 + 20 * 12),
    ) {
        let n = model.nv();
        let params: Vec<Param> = Param::all(&model)
            .into_iter()
            .filter(|p| p.size() > 1 || p.get(&model)[0] > 1e-3)
            .collect();
        let wrt = Wrt { state: true, control: true, params: &params };
        let j = step_jacobians(&model, &mut Workspace::new(&model), (&q, &v, &tau), &wrt).unwrap();
        let (dq, dv, dtau) = (&dir[..n], &dir[20..20 + n], &dir[40..40 + n]);
        let mut dp = vec![];
        let mut rest = &dir[60..];
        for p in &params {
            let value = p.get(&model);
            dp.extend(value.iter().zip(rest).map(|(x, d)| d * x.abs().max(0.01)));
            rest = &rest[p.size()..];
        }
        let column = |x: &[f64]| DVector::from_column_slice(x);
        let (dq, dv, dtau, dp) = (column(dq), column(dv), column(dtau), column(&dp));
        let jd_q = j.dq_dq() * &dq + j.dq_dv() * &dv + j.dq_dtau() * &dtau + j.dq_dp() * &dp;
        let jd_v = j.dv_dq() * &dq + j.dv_dv() * &dv + j.dv_dtau() * &dtau + j.dv_dp() * &dp;
        let eps = 1e-6;
        let shifted = |e: f64| {
            let moved = |x: &[f64], d: &DVector<f64>| -> Vec<f64> {
                x.iter().zip(d.iter()).map(|(x, d)| x + e * d).collect()
            };
            let mut m = model.clone();
            let mut at = 0;
            for p in &params {
                let value = moved(&p.get(&model), &dp.rows(at, p.size()).into_owned());
                m.set(&[(*p, &value)]).unwrap();
                at += p.size();
            }
            let x = State::new(moved(&q, &dq), moved(&v, &dv));
            m.step(&mut m.data(), &x, &Inputs::tau(&moved(&tau, &dtau))).unwrap()
        };
        let (a, b) = (shifted(eps), shifted(-eps));
        let fd = |a: &[f64], b: &[f64]| (column(a) - column(b)) / (2.0 * eps);
        for (name, exact, approx) in [("q'", jd_q, fd(&a.q, &b.q)), ("v'", jd_v, fd(&a.v, &b.v))] {
            let err = (&exact - &approx).amax() / (1.0 + approx.amax());
            prop_assert!(err < 1e-6, "{}: J d differs from FD by {:e}", name, err);
        }
    }
}
