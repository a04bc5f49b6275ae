//! The algorithms are generic over the scalar: forward-mode dual numbers flow
//! through a whole step and give the same derivative as finite differences.

mod common;

use common::{random_model, random_state};
use diffosi::dynamics::{step, Data, Tree};
use diffosi::model::{Inputs, Integrator, PassiveMode, State};
use num_dual::Dual64;

#[test]
fn dual_numbers_differentiate_a_step() {
    for (seed, mode, integrator) in [
        (0, PassiveMode::Explicit, Integrator::Euler),
        (1, PassiveMode::ImplicitDamping, Integrator::Euler),
        (2, PassiveMode::ImplicitDampingStiffness, Integrator::Euler),
        (3, PassiveMode::Explicit, Integrator::Rk4),
    ] {
        let model = random_model(seed, 4, mode, integrator);
        let n = model.nv();
        let tree: Tree<Dual64> = Tree::build(&model);
        let mut data = Data::new(&tree);
        let (q, v, tau) = random_state(&model, seed);
        let (x, u) = (State::new(q.clone(), v.clone()), Inputs::tau(&tau));
        let q_plain = model.step(&mut model.data(), &x, &u).unwrap().q;
        for k in 0..n {
            // Seed dq_k = 1 and read d(q', v')/dq_k from the dual parts.
            let qd: Vec<Dual64> = (0..n)
                .map(|i| Dual64::new(q[i], if i == k { 1.0 } else { 0.0 }))
                .collect();
            let vd: Vec<Dual64> = v.iter().map(|&x| Dual64::from(x)).collect();
            let td: Vec<Dual64> = tau.iter().map(|&x| Dual64::from(x)).collect();
            let (mut q1, mut v1) = (vec![Dual64::from(0.0); n], vec![Dual64::from(0.0); n]);
            step(&tree, &mut data, (&qd, &vd, &td), (&mut q1, &mut v1)).unwrap();

            let eps = 1e-6;
            let mut f64_data = model.data();
            let mut shifted = |s: f64| {
                let mut x = x.clone();
                x.q[k] += s;
                model.step(&mut f64_data, &x, &u).unwrap()
            };
            let State { q: qp, v: vp, .. } = shifted(eps);
            let State { q: qm, v: vm, .. } = shifted(-eps);
            for i in 0..n {
                let fd_q = (qp[i] - qm[i]) / (2.0 * eps);
                let fd_v = (vp[i] - vm[i]) / (2.0 * eps);
                assert!(
                    (q1[i].eps - fd_q).abs() < 1e-6 * (1.0 + fd_q.abs()),
                    "dq'/dq {seed} {i} {k}"
                );
                assert!(
                    (v1[i].eps - fd_v).abs() < 1e-6 * (1.0 + fd_v.abs()),
                    "dv'/dq {seed} {i} {k}"
                );
                assert_eq!(q1[i].re, q_plain[i], "dual and f64 values differ");
            }
        }
    }
}
