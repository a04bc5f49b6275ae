//! Identification with the target's constraint impulses unknown
//! (`Problem::with_unknown_constraints`, src/derivatives/eliminated.rs): the
//! half cheetah on its floor, whose torso mass and leg armature come back
//! exactly from our own constrained steps under every passive mode and from
//! a target with another contact law (our smooth penalty contact); exact
//! residual Jacobians; clear errors for bad settings.

mod common;

use diffosi::derivatives::{Impulses, Transition};
use diffosi::model::{ContactModel, Inputs, Integrator, MapEntry, ParamMap, PassiveMode, State};
use diffosi::osi::{Identifier, Lm, OsiError, Problem};
use diffosi::Model;
use nalgebra::{DMatrix, DVector};

const LEGS: [&str; 6] = ["bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot"];
const MARGIN: f64 = 0.02;

fn cheetah() -> Model {
    Model::load(common::model_path("reference_models/half_cheetah.xml")).unwrap()
}

/// mu = (torso mass, the six leg joints' armature tied together).
fn mass_and_armature(model: &Model) -> ParamMap {
    let armature: Vec<String> = LEGS.iter().map(|j| format!("joint/{j}/armature")).collect();
    let mut entries = vec![MapEntry {
        name: "body/torso/mass",
        offset: &[0.0],
        gain: &[&[1.0, 0.0]],
    }];
    entries.extend(armature.iter().map(|name| MapEntry {
        name,
        offset: &[0.0],
        gain: &[&[0.0, 1.0]],
    }));
    ParamMap::new(model, 2, &entries).unwrap()
}

/// (mass, armature) in [1, 50] x [0, 0.3] from (25.5, 0.05), the paper's
/// residual (constraints modelled).
fn modelled(model: &Model) -> Problem {
    let map = mass_and_armature(model);
    let scale = vec![1e-3; 2 * model.nv()];
    Problem::new(model, map, &[1.0, 0.0], &[50.0, 0.3], &[25.5, 0.05], &scale).unwrap()
}

/// The same with the constraints unknown, impulses as `impulses` says.
fn problem(model: &Model, impulses: Impulses) -> Problem {
    modelled(model)
        .with_unknown_constraints(MARGIN, &vec![1.0; model.nv()], impulses)
        .unwrap()
}

fn with_truth(model: &Model, mass: f64, armature: f64) -> Model {
    let mut truth = model.clone();
    mass_and_armature(model)
        .apply(&mut truth, &[mass, armature])
        .unwrap();
    truth
}

#[test]
fn our_constrained_steps_leave_no_residual_under_every_passive_mode() {
    for passive in [
        PassiveMode::ImplicitDamping,
        PassiveMode::Explicit,
        PassiveMode::ImplicitDampingStiffness,
    ] {
        let model = cheetah().edited(|s| s.opt.passive = passive).unwrap();
        let truth = with_truth(&model, 20.0, 0.1);
        let window = common::cheetah_walk(&truth, 150, 1);
        let mut data = truth.data();
        let touching = window
            .iter()
            .filter(|t| {
                !truth
                    .contacts(&mut data, &t.start, &Inputs::tau(&t.tau))
                    .unwrap()
                    .is_empty()
            })
            .count();
        assert!(
            touching > 50,
            "{passive:?}: the cheetah must stand on its floor ({touching})"
        );
        let mut p = problem(&model, Impulses::Model);
        let fit = p.fit(&[20.0, 0.1], window.as_slice()).unwrap();
        assert_eq!(fit.residuals.len(), 150 * model.nv());
        let worst = fit.residuals.amax();
        assert!(
            worst < 1e-8,
            "{passive:?}: residual {worst:e} N at the truth"
        );
        // The wrong mass leaves a residual: the rows do see the torso.
        let off = p.fit(&[21.0, 0.1], window.as_slice()).unwrap();
        assert!(
            off.residuals.amax() > 1e-2,
            "{passive:?}: {:e}",
            off.residuals.amax()
        );
    }
}

#[test]
fn torso_mass_and_armature_come_back_from_our_constraint_contact() {
    let model = cheetah();
    let truth = with_truth(&model, 20.0, 0.1);
    let window = common::cheetah_walk(&truth, 60, 2);
    let est = Lm::default()
        .identify(
            &mut problem(&model, Impulses::Model),
            &window,
            &[25.5, 0.05],
        )
        .unwrap();
    assert!((est.mu[0] - 20.0).abs() < 1e-6, "{:?}", est.mu);
    assert!((est.mu[1] - 0.1).abs() < 1e-8, "{:?}", est.mu);
    assert!(!est.flags.unexcited && !est.flags.misfit, "{:?}", est.flags);
}

/// The target runs the smooth penalty contact (and soft limits): a contact
/// law the identifying model, on MuJoCo's constraints, does not share.
#[test]
fn another_contact_law_leaves_the_mass_unbiased() {
    let model = cheetah();
    let target = with_truth(&model, 20.0, 0.1)
        .edited(|s| s.opt.contact_model = ContactModel::Smooth)
        .unwrap();
    let window = common::cheetah_walk(&target, 60, 3);
    let start = [25.5, 0.05];
    let est = Lm::default()
        .identify(&mut problem(&model, Impulses::Model), &window, &start)
        .unwrap();
    assert!((est.mu[0] - 20.0).abs() < 1e-3, "{:?}", est.mu);
    assert!((est.mu[1] - 0.1).abs() < 1e-5, "{:?}", est.mu);
    // The paper's residual through our constraint contact is biased there.
    let biased = Lm::default()
        .identify(&mut modelled(&model), &window, &start)
        .unwrap();
    assert!((biased.mu[0] - 20.0).abs() > 0.5, "{:?}", biased.mu);
}

#[test]
fn residual_jacobian_is_exact() {
    for impulses in [Impulses::Model, Impulses::Mass] {
        jacobian_check(impulses);
    }
}

fn jacobian_check(impulses: Impulses) {
    let passive = PassiveMode::ImplicitDampingStiffness;
    let model = cheetah().edited(|s| s.opt.passive = passive).unwrap();
    let names = [
        "body/torso/mass",
        "body/bthigh/com",
        "joint/bshin/armature",
        "joint/fthigh/damping",
        "joint/ffoot/stiffness",
        "geom/floor/friction",
    ];
    let map = ParamMap::identity(&model, &names).unwrap();
    let nmu = map.nmu;
    let mu: Vec<f64> = [20.0, 0.1, 0.0, -0.13, 0.12, 4.0, 60.0, 0.4, 0.1, 0.1].to_vec();
    let truth = {
        let mut t = model.clone();
        map.apply(&mut t, &mu).unwrap();
        t
    };
    let window = common::cheetah_walk(&truth, 30, 4);
    let scale = vec![1e-3; 2 * model.nv()];
    let lower = vec![-100.0; nmu];
    let upper = vec![100.0; nmu];
    let mut p = Problem::new(&model, map, &lower, &upper, &mu, &scale)
        .unwrap()
        .with_unknown_constraints(MARGIN, &vec![1.0; model.nv()], impulses)
        .unwrap();
    let fit = p.fit(&mu, window.as_slice()).unwrap();
    for j in 0..nmu {
        let step = 1e-6 * mu[j].abs().max(1.0);
        let mut plus = mu.clone();
        let mut minus = mu.clone();
        plus[j] += step;
        minus[j] -= step;
        let rp = p.fit(&plus, window.as_slice()).unwrap().residuals;
        let rm = p.fit(&minus, window.as_slice()).unwrap().residuals;
        let fd = (rp - rm) / (2.0 * step);
        let err = (&fd - fit.jacobian.column(j)).amax();
        let size = fd.amax().max(1.0);
        assert!(
            err < 1e-6 * size,
            "{impulses:?}, column {j}: error {err:e} against {size:e}"
        );
    }
    // Friction acts through the eliminated impulses alone.
    assert_eq!(fit.jacobian.column(nmu - 3).amax(), 0.0);
}

/// DART's convention, made from our own steps: the free step's velocity v_f
/// plus our constraint impulse applied through M alone (DART's way, its
/// implicit springs and dampers taken before it). `Impulses::Mass` leaves no
/// residual and finds the mass; `Impulses::Model` does not.
#[test]
fn impulses_through_the_mass_matrix_alone() {
    let passive = PassiveMode::ImplicitDampingStiffness;
    let model = cheetah().edited(|s| s.opt.passive = passive).unwrap();
    let truth = with_truth(&model, 20.0, 0.1);
    let free = truth
        .edited(|s| {
            s.opt.contact = false;
            s.opt.limits = false;
        })
        .unwrap();
    let (n, h) = (model.nv(), model.opt.timestep);
    let implicit = DVector::from_iterator(
        n,
        model
            .joints
            .iter()
            .map(|j| h * j.damping + h * h * j.stiffness),
    );
    let mut data = free.data();
    let window: Vec<Transition> = common::cheetah_walk(&truth, 80, 6)
        .into_iter()
        .map(|t| {
            let State {
                q: _, v: v_free, ..
            } = free
                .step(&mut data, &t.start, &Inputs::tau(&t.tau))
                .unwrap();
            let v_free = DVector::from_vec(v_free);
            let m = common::mass_matrix(&truth, &t.start.q);
            let impulse = (&m + DMatrix::from_diagonal(&implicit))
                * (DVector::from_column_slice(&t.next.v) - &v_free);
            let v_next = v_free + m.lu().solve(&impulse).unwrap();
            let q_next = (0..n).map(|i| t.start.q[i] + h * v_next[i]).collect();
            Transition {
                next: State::new(q_next, v_next.as_slice().to_vec()),
                ..t
            }
        })
        .collect();
    let make = |impulses| problem(&model, impulses);
    let mass = make(Impulses::Mass)
        .fit(&[20.0, 0.1], window.as_slice())
        .unwrap();
    assert!(mass.residuals.amax() < 1e-8, "{:e}", mass.residuals.amax());
    let est = Lm::default()
        .identify(&mut make(Impulses::Mass), &window, &[25.5, 0.05])
        .unwrap();
    assert!((est.mu[0] - 20.0).abs() < 1e-6, "{:?}", est.mu);
    let model_way = make(Impulses::Model)
        .fit(&[20.0, 0.1], window.as_slice())
        .unwrap();
    assert!(
        model_way.residuals.amax() > 1e-2,
        "{:e}",
        model_way.residuals.amax()
    );
}

#[test]
fn bad_settings_are_refused() {
    let model = cheetah();
    let make = || modelled(&model);
    let n = model.nv();
    for margin in [-0.1, f64::NAN, f64::INFINITY] {
        let e = make()
            .with_unknown_constraints(margin, &vec![1.0; n], Impulses::Model)
            .unwrap_err();
        assert!(e.to_string().contains("margin"), "{e}");
    }
    for scale in [vec![1.0; n - 1], vec![0.0; n], vec![f64::NAN; n]] {
        let e = make()
            .with_unknown_constraints(MARGIN, &scale, Impulses::Model)
            .unwrap_err();
        assert!(e.to_string().contains("force scale"), "{e}");
    }
    let rk4 = model
        .edited(|s| s.opt.integrator = Integrator::Rk4)
        .unwrap();
    let e = modelled(&rk4)
        .with_unknown_constraints(MARGIN, &vec![1.0; n], Impulses::Model)
        .unwrap_err();
    assert!(
        matches!(e, OsiError::Window(_)) && e.to_string().contains("Euler"),
        "{e}"
    );
}

/// A problem keeps each window position's constraint directions between
/// evaluations: another window at the same positions must find its own.
#[test]
fn a_reused_problem_answers_as_a_fresh_one() {
    let model = cheetah();
    let truth = with_truth(&model, 20.0, 0.1);
    let (a, b) = (
        common::cheetah_walk(&truth, 40, 7),
        common::cheetah_walk(&truth, 40, 8),
    );
    let mut reused = problem(&model, Impulses::Model);
    reused.fit(&[25.0, 0.05], a.as_slice()).unwrap();
    let again = reused.fit(&[25.0, 0.05], b.as_slice()).unwrap();
    let fresh = problem(&model, Impulses::Model)
        .fit(&[25.0, 0.05], b.as_slice())
        .unwrap();
    assert_eq!(again, fresh);
}
