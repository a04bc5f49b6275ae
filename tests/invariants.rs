//! Physics invariants of the dynamics algorithms on random trees.

mod common;

use common::{bias, energy, mass_matrix, random_model, random_state};
use diffosi::dynamics::{aba, rnea, step, Data};
use diffosi::model::{Integrator, PassiveMode};
use diffosi::Model;
use nalgebra::DVector;

/// Random trees, and every model in reference_models/ (MJCF and URDF).
fn models() -> Vec<Model> {
    let random = (0..12).map(|seed| {
        random_model(
            seed,
            2 + seed as usize % 6,
            PassiveMode::Explicit,
            Integrator::Euler,
        )
    });
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_models");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "xml" || x == "urdf"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 8,
        "reference models missing from {}",
        dir.display()
    );
    let files = files
        .into_iter()
        .map(|p| Model::load(&p).unwrap_or_else(|e| panic!("{e}")));
    random.chain(files).collect()
}

#[test]
fn aba_equals_crba_solve_of_tau_minus_bias() {
    for model in models() {
        let tree = model.tree();
        let mut data = Data::new(tree);
        for seed in 0..5 {
            let (q, v, tau) = random_state(&model, seed);
            let mut qdd = vec![0.0; model.nv()];
            aba(tree, &mut data, &q, &v, &tau, None, &mut qdd);
            let rhs = DVector::from_column_slice(&tau) - bias(&model, &q, &v);
            let want = mass_matrix(&model, &q).cholesky().unwrap().solve(&rhs);
            let err = (DVector::from_column_slice(&qdd) - &want).amax();
            assert!(
                err < 1e-10 * (1.0 + want.amax()),
                "{}: ABA vs CRBA {err:e}",
                model.name
            );
        }
    }
}

#[test]
fn rnea_inverts_aba() {
    for model in models() {
        let tree = model.tree();
        let mut data = Data::new(tree);
        let (q, v, tau) = random_state(&model, 7);
        let mut qdd = vec![0.0; model.nv()];
        aba(tree, &mut data, &q, &v, &tau, None, &mut qdd);
        let mut back = vec![0.0; model.nv()];
        rnea(tree, &mut data, &q, &v, &qdd, &mut back);
        let err = back
            .iter()
            .zip(&tau)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            err < 1e-10,
            "{}: RNEA(ABA(tau)) - tau = {err:e}",
            model.name
        );
    }
}

#[test]
fn mass_matrix_is_symmetric_positive_definite() {
    for model in models() {
        let (q, ..) = random_state(&model, 3);
        let m = mass_matrix(&model, &q);
        assert!((&m - m.transpose()).amax() < 1e-12);
        let eig = m.symmetric_eigenvalues();
        assert!(eig.min() > 0.0, "{}: eigenvalues {eig}", model.name);
    }
}

fn rollout_energy(model: &Model, steps: usize, damped: bool) -> Vec<f64> {
    let model = model
        .edited(|spec| {
            for j in spec.joints.iter_mut().filter(|_| !damped) {
                j.damping = 0.0;
            }
        })
        .unwrap();
    let (mut q, mut v, _) = random_state(&model, 11);
    let zero = vec![0.0; model.nv()];
    let mut data = Data::new(model.tree());
    let (mut q1, mut v1) = (zero.clone(), zero.clone());
    let mut e = vec![energy(&model, &q, &v)];
    for _ in 0..steps {
        step(model.tree(), &mut data, (&q, &v, &zero), (&mut q1, &mut v1)).unwrap();
        std::mem::swap(&mut q, &mut q1);
        std::mem::swap(&mut v, &mut v1);
        e.push(energy(&model, &q, &v));
    }
    e
}

#[test]
fn rk4_conserves_energy_without_damping() {
    for seed in 0..4 {
        let model = random_model(seed, 4, PassiveMode::Explicit, Integrator::Rk4);
        let e = rollout_energy(&model, 2000, false);
        let drift = e.iter().map(|x| (x - e[0]).abs()).fold(0.0, f64::max);
        assert!(
            drift < 1e-8 * (1.0 + e[0].abs()),
            "seed {seed}: energy drift {drift:e} of {}",
            e[0]
        );
    }
}

#[test]
fn damping_only_dissipates_energy() {
    for seed in 0..4 {
        let model = random_model(seed, 4, PassiveMode::Explicit, Integrator::Rk4);
        let e = rollout_energy(&model, 2000, true);
        for w in e.windows(2) {
            assert!(
                w[1] <= w[0] + 1e-10,
                "seed {seed}: energy rose {} -> {}",
                w[0],
                w[1]
            );
        }
        assert!(
            e[e.len() - 1] < e[0] - 1e-6,
            "seed {seed}: damping removed no energy"
        );
    }
}

/// Each passive-force mode satisfies its own discrete equation, written with the
/// mass matrix and bias forces instead of ABA.
#[test]
fn passive_modes_solve_their_equations() {
    let h = 0.001;
    for mode in [
        PassiveMode::Explicit,
        PassiveMode::ImplicitDamping,
        PassiveMode::ImplicitDampingStiffness,
    ] {
        for seed in 0..6 {
            let model = random_model(seed, 4, mode, Integrator::Euler);
            let (q, v, tau) = random_state(&model, seed + 100);
            let n = model.nv();
            let mut data = Data::new(model.tree());
            let (mut q1, mut v1) = (vec![0.0; n], vec![0.0; n]);
            step(model.tree(), &mut data, (&q, &v, &tau), (&mut q1, &mut v1)).unwrap();
            let m = mass_matrix(&model, &q);
            let c = bias(&model, &q, &v);
            let acc = DVector::from_iterator(n, (0..n).map(|i| (v1[i] - v[i]) / h));
            // Velocity and position at which damping and spring act in this mode.
            let (v_d, q_k): (&[f64], Vec<f64>) = match mode {
                PassiveMode::Explicit => (&v, q.clone()),
                PassiveMode::ImplicitDamping => (&v1, q.clone()),
                PassiveMode::ImplicitDampingStiffness => (&v1, q1.clone()),
            };
            let residual = DVector::from_iterator(
                n,
                (0..n).map(|i| {
                    let j = &model.joints[i];
                    tau[i] - c[i] - j.damping * v_d[i] - j.stiffness * (q_k[i] - j.springref)
                }),
            ) - &m * acc;
            assert!(
                residual.amax() < 1e-9,
                "{mode:?} seed {seed}: residual {:e}",
                residual.amax()
            );
            for i in 0..n {
                assert!((q1[i] - q[i] - h * v1[i]).abs() < 1e-15);
            }
        }
    }
}

#[test]
fn step_rejects_bad_input() {
    let model = random_model(1, 3, PassiveMode::Explicit, Integrator::Euler);
    let n = model.nv();
    let mut data = Data::new(model.tree());
    let (q, mut v, tau) = random_state(&model, 0);
    let (mut q1, mut v1) = (vec![0.0; n], vec![0.0; n]);
    v[1] = f64::NAN;
    let err = step(model.tree(), &mut data, (&q, &v, &tau), (&mut q1, &mut v1)).unwrap_err();
    assert_eq!(err.to_string(), "v[1] is not finite");
    let err = step(
        model.tree(),
        &mut data,
        (&q, &v[..1], &tau),
        (&mut q1, &mut v1),
    )
    .unwrap_err();
    assert_eq!(err.to_string(), format!("v has length 1, expected {n}"));
}

#[test]
fn ltdl_factorization_solves_like_cholesky() {
    use diffosi::dynamics::{ltdl_factor, ltdl_solve};
    for model in models() {
        let (q, _, tau) = random_state(&model, 4);
        let m = mass_matrix(&model, &q);
        let want = m
            .clone()
            .cholesky()
            .unwrap()
            .solve(&DVector::from_column_slice(&tau));
        let mut factored = m.clone();
        ltdl_factor(model.tree(), &mut factored);
        let mut x = tau.clone();
        ltdl_solve(model.tree(), &factored, &mut x);
        let err = (DVector::from_column_slice(&x) - &want).amax();
        assert!(err < 1e-10 * (1.0 + want.amax()), "{}: {err:e}", model.name);
    }
}
