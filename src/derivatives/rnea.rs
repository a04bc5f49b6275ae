//! Analytic derivatives of inverse dynamics ID(q, v, a) = M(q) a + c(q, v)
//! with respect to q and v, and of M(q) y with respect to q for a fixed y:
//! one forward and one backward sweep over the tree, then one product per
//! pair of dofs on a common path (in the spirit of Carpentier & Mansard 2018).
//!
//! Conventions: world coordinates about the world origin; S_i the axis of
//! dof i (one dof per node), v_i, a_i node i's velocity and acceleration (a
//! with gravity as an upward acceleration of the world), I_i its inertia,
//! h_i = I_i v_i, F_i the force on i's subtree, so ID_i = S_i . F_i (+ the
//! armature's term, constant in q and v); a superscript C sums over a
//! subtree; p the parent of j (v_p = 0, a_p = (0, -g) at the root).
//!
//! A change of q_j turns j's subtree about S_j. Were the subtree's motion
//! turned with it, every S_i and F_i of the subtree would turn alike and
//! their products would not change; what does not turn is the motion the
//! subtree inherits from above j. The rest of the change, the same for every
//! body b of the subtree, is
//!   dv_b = dv = -S_j x v_p,   da_b = c + dv x v_b,   c = -S_j x a_p - dv x v_p,
//! so body b's force changes by I_b c + Phi_b(dv), with
//!   Phi_b(x) = I_b (x x v_b) + x x* h_b + v_b x* I_b x = Idot_b x + x x* h_b,
//! Idot_b the rate of I_b under b's own motion ([`Inertia::rate`]). Hence
//!   dID_i/dq_j = S_i . (I^C_i c + Phi^C_i(dv)) = sigma_i . c + rho_i . dv
//!       for i in j's subtree, sigma_i = I^C_i S_i, rho_i = Idot^C_i S_i - S_i x* h^C_i;
//!   dID_i/dq_j = S_i . G_j,  G_j = S_j x* F_j + I^C_j c + Phi^C_j(dv)
//!       for i above j (where the subtree's whole force turns).
//! A change of v_j turns nothing: dv = S_j, c = 2 v_p x S_j, and G_j has no
//! S_j x* F_j. d(M y)/dq_j is the q-derivative of ID with no velocity and
//! no gravity, accelerations y: c = -S_j x ay_p, dv = 0.
//!
//! A ball's three nodes share one frame (module `tree`): its velocity
//! w = sum_m S_m v_m adds to v_p, and its velocity-product term is
//! v_p x w, not the hinge's v_j x S_j v_j (every S_m turns with the ball,
//! dS_m/dt = (v_p + w) x S_m, so d w/dt = sum_m S_m a_m + v_p x w); p is the
//! node the ball hangs from, for all three. q_k of a ball (the tangent q (+)
//! eps e_k, a turn of the ball's frame about its axis k) turns all three
//! axes, those before k included, so for rows i of the same ball, before k
//! or not, dID_i/dq_k takes the subtree form sigma_i . c + rho_i . dv, with
//! dv and c as above (v_p, a_p entering the ball). A change of v_k changes
//! the ball's own velocity-product term by v_p x S_k, so that its body's
//! da = c + S_k x v_b: c = 2 v_p x S_k + w' x S_k, w' the ball's velocity
//! from its other two axes (w' = 0 on a hinge, and S_k x S_k = 0). Rows of
//! the ball before k take S_i . G_k there (S_i does not move with v), and
//! d(M y)/dq_k takes the subtree form on them as d ID/dq_k does.

use crate::dynamics::configuration::Coordinates;
#[cfg(doc)]
use crate::dynamics::{rnea, world_frames};
use crate::dynamics::{Data, Tree};
use crate::spatial::{Force, Inertia, Motion};

/// The sweeps' per-node scratch (world coordinates unless noted).
#[derive(Clone, Debug)]
pub struct Sweep {
    axis: Vec<Motion<f64>>,
    vel: Vec<Motion<f64>>,
    acc: Vec<Motion<f64>>,
    /// F_i: [`rnea`]'s subtree forces, in world coordinates.
    force: Vec<Force<f64>>,
    /// I_i, then I^C_i; Idot^C_i; h^C_i.
    inertia: Vec<Inertia<f64>>,
    composite: Vec<Inertia<f64>>,
    rate: Vec<Inertia<f64>>,
    momentum: Vec<Force<f64>>,
    /// sigma_i and rho_i of the module documentation.
    sigma: Vec<Force<f64>>,
    rho: Vec<Force<f64>>,
    /// Per dof j, for q_j, v_j and (M y)'s q_j: (c, dv) and G_j.
    position: Vec<(Motion<f64>, Motion<f64>, Force<f64>)>,
    velocity: Vec<(Motion<f64>, Force<f64>)>,
    mass: Vec<(Motion<f64>, Force<f64>)>,
    /// M(q) y's accelerations and subtree forces: world coordinates for
    /// [`rnea_derivatives`], node coordinates for [`Sweep::mass_product`].
    world_acc_y: Vec<Motion<f64>>,
    world_force_y: Vec<Force<f64>>,
    acc_y: Vec<Motion<f64>>,
    force_y: Vec<Force<f64>>,
}

impl Sweep {
    pub fn new(n: usize) -> Self {
        let zero = (Motion::zero(), Force::zero());
        Sweep {
            axis: vec![Motion::zero(); n],
            vel: vec![Motion::zero(); n],
            acc: vec![Motion::zero(); n],
            force: vec![Force::zero(); n],
            inertia: vec![Inertia::zero(); n],
            composite: vec![Inertia::zero(); n],
            rate: vec![Inertia::zero(); n],
            momentum: vec![Force::zero(); n],
            sigma: vec![Force::zero(); n],
            rho: vec![Force::zero(); n],
            position: vec![(Motion::zero(), Motion::zero(), Force::zero()); n],
            velocity: vec![zero; n],
            mass: vec![zero; n],
            world_acc_y: vec![Motion::zero(); n],
            world_force_y: vec![Force::zero(); n],
            acc_y: vec![Motion::zero(); n],
            force_y: vec![Force::zero(); n],
        }
    }

    /// The node accelerations and subtree forces of M(q) y (no velocity, no
    /// gravity) in node coordinates, `data.x_up` at q; the accelerations read
    /// back by [`Sweep::mass_product_accelerations`].
    pub fn mass_product(&mut self, tree: &Tree<f64>, data: &Data<f64>, y: &[f64]) {
        let n = tree.nv();
        for i in 0..n {
            let parent = tree.parent[i].map_or(Motion::zero(), |p| {
                data.x_up[i].apply_motion(&self.acc_y[p])
            });
            self.acc_y[i] = parent + tree.joint[i].s * y[i];
            self.force_y[i] = tree.inertia[i].mul_motion(&self.acc_y[i]);
        }
        for i in (0..n).rev() {
            if let Some(p) = tree.parent[i] {
                let up = data.x_up[i].inverse_apply_force(&self.force_y[i]);
                self.force_y[p] += up;
            }
        }
    }

    /// The node accelerations of the last [`Sweep::mass_product`].
    pub fn mass_product_accelerations(&self) -> &[Motion<f64>] {
        &self.acc_y
    }

    /// RNEA at (v, a) in world coordinates (axes, motions, inertias,
    /// forces) from the world frames in `data`; then the subtree sums and
    /// sigma, rho.
    fn sweep(&mut self, tree: &Tree<f64>, data: &Data<f64>, (v, a): (&[f64], &[f64])) {
        let n = tree.nv();
        let gravity = Motion::new(nalgebra::Vector3::zeros(), -tree.gravity);
        for i in 0..n {
            let (w, s) = (&data.world[i], data.world_axis[i]);
            let (v_p, a_p) =
                tree.parent[i].map_or((Motion::zero(), gravity), |p| (self.vel[p], self.acc[p]));
            let (vel, joint) = (v_p + s * v[i], s * v[i]);
            let crossed = self.crossed_velocity(tree, i, vel, v);
            let acc = a_p + s * a[i] + crossed.cross_motion(&joint);
            let inertia = tree.inertia[i].to_source(w);
            let momentum = inertia.mul_motion(&vel);
            self.axis[i] = s;
            (self.vel[i], self.acc[i]) = (vel, acc);
            self.force[i] = inertia.mul_motion(&acc) + vel.cross_force(&momentum);
            self.inertia[i] = inertia;
            self.composite[i] = inertia;
            self.rate[i] = inertia.rate(&vel);
            self.momentum[i] = momentum;
        }
        for i in (0..n).rev() {
            if let Some(p) = tree.parent[i] {
                let (composite, rate, momentum, force) = (
                    self.composite[i],
                    self.rate[i],
                    self.momentum[i],
                    self.force[i],
                );
                self.composite[p] += composite;
                self.rate[p] += rate;
                self.momentum[p] += momentum;
                self.force[p] += force;
            }
            let s = &self.axis[i];
            self.sigma[i] = self.composite[i].mul_motion(s);
            self.rho[i] = self.rate[i].mul_motion(s) - s.cross_force(&self.momentum[i]);
        }
    }

    /// [`Tree::crossed_velocity`] in world coordinates: `vel` less the
    /// motion of the axes of node i's ball before it.
    fn crossed_velocity(
        &self,
        tree: &Tree<f64>,
        i: usize,
        vel: Motion<f64>,
        v: &[f64],
    ) -> Motion<f64> {
        let before = tree.joint[i].ball_axes_before();
        (1..=before).fold(vel, |m, k| m - self.axis[i - k] * v[i - k])
    }

    /// The motion of node j's ball from its axes other than j (zero on a
    /// hinge or slide): w' of the module documentation.
    fn other_axes(&self, tree: &Tree<f64>, j: usize, v: &[f64]) -> Option<Motion<f64>> {
        let ball = ball_nodes(tree, j)?;
        let others = ball.filter(|&m| m != j);
        Some(others.fold(Motion::zero(), |w, m| w + self.axis[m] * v[m]))
    }

    /// Phi^C_j(x) of the module documentation.
    fn phi(&self, j: usize, x: &Motion<f64>) -> Force<f64> {
        self.rate[j].mul_motion(x) + x.cross_force(&self.momentum[j])
    }

    /// The per-dof terms (c, dv, G) of q_j's and v_j's columns.
    fn dof_terms(&mut self, tree: &Tree<f64>, v: &[f64]) {
        let gravity = Motion::new(nalgebra::Vector3::zeros(), -tree.gravity);
        for j in 0..tree.nv() {
            let (v_p, a_p) =
                entering(tree, j).map_or((Motion::zero(), gravity), |p| (self.vel[p], self.acc[p]));
            let s = self.axis[j];
            let dv = v_p.cross_motion(&s);
            let c = -s.cross_motion(&a_p) - dv.cross_motion(&v_p);
            let turn = s.cross_force(&self.force[j]);
            let g = turn + self.composite[j].mul_motion(&c) + self.phi(j, &dv);
            self.position[j] = (c, dv, g);
            let mut c = (v_p * 2.0).cross_motion(&s);
            if let Some(w) = self.other_axes(tree, j, v) {
                c += w.cross_motion(&s);
            }
            let g = self.composite[j].mul_motion(&c) + self.phi(j, &s);
            self.velocity[j] = (c, g);
        }
    }

    /// M(q) y's world accelerations and subtree forces, and the per-dof
    /// terms (c, G) of its q_j columns.
    fn mass_terms(&mut self, tree: &Tree<f64>, y: &[f64]) {
        let n = tree.nv();
        for i in 0..n {
            let parent = tree.parent[i].map_or(Motion::zero(), |p| self.world_acc_y[p]);
            self.world_acc_y[i] = parent + self.axis[i] * y[i];
            self.world_force_y[i] = self.inertia[i].mul_motion(&self.world_acc_y[i]);
        }
        for i in (0..n).rev() {
            if let Some(p) = tree.parent[i] {
                let up = self.world_force_y[i];
                self.world_force_y[p] += up;
            }
        }
        for j in 0..n {
            let a_p = entering(tree, j).map_or(Motion::zero(), |p| self.world_acc_y[p]);
            let s = self.axis[j];
            let c = -s.cross_motion(&a_p);
            let g = s.cross_force(&self.world_force_y[j]) + self.composite[j].mul_motion(&c);
            self.mass[j] = (c, g);
        }
    }
}

/// Fills d_dq and d_dv (n x n, column-major, column j the derivative in
/// q_j or v_j) of ID(q, v, a), and with `mass = Some((y, d_my))` d_my with
/// d(M(q) y)/dq. M includes the armature, which depends on neither. `data`
/// must hold the transforms and world frames at q (`x_up`, and `world`,
/// `world_axis` as [`world_frames`] leaves them).
pub fn rnea_derivatives(
    tree: &Tree<f64>,
    data: &Data<f64>,
    sweep: &mut Sweep,
    (v, a): (&[f64], &[f64]),
    (d_dq, d_dv): (&mut [f64], &mut [f64]),
    mass: Option<(&[f64], &mut [f64])>,
) {
    let n = tree.nv();
    sweep.sweep(tree, data, (v, a));
    sweep.dof_terms(tree, v);
    d_dq.fill(0.0);
    d_dv.fill(0.0);
    let mut mass = mass.map(|(y, d_my)| {
        sweep.mass_terms(tree, y);
        d_my.fill(0.0);
        d_my
    });
    // Entry (i, j) for every j on i's path (i in j's subtree), and (j, i)
    // for j above i: in i's ball, the subtree form for q (see the module
    // documentation).
    for i in 0..n {
        let (sigma, rho) = (&sweep.sigma[i], &sweep.rho[i]);
        let ball = ball_nodes(tree, i).map_or(i, |mut b| b.next().expect("three axes"));
        let mut k = Some(i);
        while let Some(j) = k {
            let (c, dv, _) = &sweep.position[j];
            d_dq[j * n + i] = c.dot(sigma) + dv.dot(rho);
            let (cv, _) = &sweep.velocity[j];
            d_dv[j * n + i] = cv.dot(sigma) + sweep.axis[j].dot(rho);
            if let Some(d_my) = &mut mass {
                d_my[j * n + i] = sweep.mass[j].0.dot(sigma);
            }
            if j != i {
                let s = &sweep.axis[j];
                let (sigma_j, rho_j) = (&sweep.sigma[j], &sweep.rho[j]);
                let (c, dv, g) = &sweep.position[i];
                d_dq[i * n + j] = if j >= ball {
                    c.dot(sigma_j) + dv.dot(rho_j)
                } else {
                    s.dot(g)
                };
                d_dv[i * n + j] = s.dot(&sweep.velocity[i].1);
                if let Some(d_my) = &mut mass {
                    let (c, g) = &sweep.mass[i];
                    d_my[i * n + j] = if j >= ball { c.dot(sigma_j) } else { s.dot(g) };
                }
            }
            k = tree.parent[j];
        }
    }
}

/// The nodes of node j's ball, in order (None on a hinge or slide).
fn ball_nodes(tree: &Tree<f64>, j: usize) -> Option<std::ops::Range<usize>> {
    let Coordinates::Rotation { axis, .. } = tree.joint[j].coordinates else {
        return None;
    };
    Some(j - axis..j - axis + 3)
}

/// The node whose motion enters node j's joint: j's parent, or for a ball's
/// axis the parent of its first (None: the world).
fn entering(tree: &Tree<f64>, j: usize) -> Option<usize> {
    tree.parent[j - tree.joint[j].ball_axes_before()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::configuration::integrate;
    use crate::dynamics::world_frames;
    use crate::dynamics::{crba, rnea};
    use crate::spatial::Real;
    use crate::Model;
    use nalgebra::{DMatrix, DVector};
    use num_dual::Dual64;

    /// dID/dq, dID/dv and d(M(q) y)/dq at (q, v, a) by [`rnea_derivatives`].
    fn analytic(
        model: &Model,
        (q, v, a, y): (&[f64], &[f64], &[f64], &[f64]),
    ) -> [DMatrix<f64>; 3] {
        let (tree, n) = (model.tree(), model.nv());
        let mut data = model.data();
        let mut tau = vec![0.0; n];
        rnea(tree, &mut data, q, v, a, &mut tau);
        world_frames(tree, &mut data, v);
        let [mut d_dq, mut d_dv, mut d_my] = [(); 3].map(|_| DMatrix::zeros(n, n));
        let columns = (d_dq.as_mut_slice(), d_dv.as_mut_slice());
        let mass = Some((y, d_my.as_mut_slice()));
        rnea_derivatives(tree, &data, &mut Sweep::new(n), (v, a), columns, mass);
        [d_dq, d_dv, d_my]
    }

    /// dID/dq, dID/dv and d(M(q) y)/dq equal central differences of RNEA
    /// and of the mass matrix times y, on a branched tree with slides and
    /// hinges, away from any special pose.
    #[test]
    fn derivatives_match_finite_differences() {
        let model = Model::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/half_cheetah.xml"
        ))
        .unwrap();
        let tree = model.tree();
        let n = model.nv();
        let wave = |k: f64, phase: f64| -> Vec<f64> {
            (0..n).map(|i| k * (i as f64 + phase).sin()).collect()
        };
        let (q, v, a, y) = (
            wave(0.3, 1.0),
            wave(1.5, 2.0),
            wave(4.0, 3.0),
            wave(1.0, 4.0),
        );
        let [d_dq, d_dv, d_my] = analytic(&model, (&q, &v, &a, &y));
        let mut data = model.data();
        let mut tau = vec![0.0; n];
        let mut id = |q: &[f64], v: &[f64]| {
            rnea(tree, &mut data, q, v, &a, &mut tau);
            DVector::from_column_slice(&tau)
        };
        let h = 1e-6;
        let shifted = |x: &[f64], j: usize, by: f64| {
            let mut x = x.to_vec();
            x[j] += by;
            x
        };
        for j in 0..n {
            let fd_q = (id(&shifted(&q, j, h), &v) - id(&shifted(&q, j, -h), &v)) / (2.0 * h);
            let fd_v = (id(&q, &shifted(&v, j, h)) - id(&q, &shifted(&v, j, -h))) / (2.0 * h);
            let err_q = (fd_q - d_dq.column(j)).amax();
            let err_v = (fd_v - d_dv.column(j)).amax();
            assert!(
                err_q < 1e-6 && err_v < 1e-6,
                "column {j}: {err_q:e} {err_v:e}"
            );
        }
        let mut my = |q: &[f64]| {
            crba(tree, &mut data, q);
            &data.mass_matrix * DVector::from_column_slice(&y)
        };
        for j in 0..n {
            let fd = (my(&shifted(&q, j, h)) - my(&shifted(&q, j, -h))) / (2.0 * h);
            let err = (fd - d_my.column(j)).amax();
            assert!(err < 1e-7, "column {j}: {err:e}");
        }
    }

    /// The same derivatives with ball and free joints (free_ball.xml: a
    /// free box with a ball-jointed arm and a hinge below it, and a ball
    /// pendulum from the world), q moved in the tangent space (q (+) eps e_j):
    /// equal to dual numbers through RNEA and M(q) y to rounding, and to
    /// central differences.
    #[test]
    fn ball_and_free_joints_match_dual_numbers_and_finite_differences() {
        let model = Model::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/free_ball.xml"
        ))
        .unwrap();
        let (tree, n) = (model.tree(), model.nv());
        let wave = |k: f64, phase: f64| -> Vec<f64> {
            (0..n).map(|i| k * (i as f64 + phase).sin()).collect()
        };
        let (v, a, y) = (wave(1.5, 2.0), wave(4.0, 3.0), wave(1.0, 4.0));
        let mut q = vec![0.0; model.nq()];
        integrate(tree, &model.reference_q(), &wave(0.7, 1.0), 1.0, &mut q);
        let [d_dq, d_dv, d_my] = analytic(&model, (&q, &v, &a, &y));

        // ID(q (+) dq, v + dv) and M(q (+) dq) y, in any scalar.
        fn evaluate<T: Real>(
            tree: &Tree<T>,
            (q, dq): (&[f64], &[T]),
            (v, a, y): (&[T], &[f64], &[f64]),
        ) -> (Vec<T>, Vec<T>) {
            let n = tree.nv();
            let lift = |x: &[f64]| {
                x.iter()
                    .map(|&x| crate::spatial::lift(x))
                    .collect::<Vec<T>>()
            };
            let mut at = vec![T::zero(); q.len()];
            integrate(tree, &lift(q), dq, T::one(), &mut at);
            let mut data = Data::new(tree);
            let mut tau = vec![T::zero(); n];
            rnea(tree, &mut data, &at, v, &lift(a), &mut tau);
            crba(tree, &mut data, &at);
            let my = (0..n)
                .map(|i| {
                    (0..n).fold(T::zero(), |s, k| {
                        s + data.mass_matrix[(i, k)] * lift(&y[k..=k])[0]
                    })
                })
                .collect();
            (tau, my)
        }
        let dual_tree: Tree<Dual64> = Tree::build(&model);
        let seed = |j: usize, x: &[f64], on: bool| -> Vec<Dual64> {
            x.iter()
                .enumerate()
                .map(|(i, &xi)| Dual64::new(xi, if on && i == j { 1.0 } else { 0.0 }))
                .collect()
        };
        let zero = vec![0.0; n];
        let h = 1e-6;
        let shifted = |x: &[f64], j: usize, by: f64| {
            let mut x = x.to_vec();
            x[j] += by;
            x
        };
        for j in 0..n {
            let (id_q, my_q) = evaluate(
                &dual_tree,
                (&q, &seed(j, &zero, true)),
                (&seed(j, &v, false), &a, &y),
            );
            let (id_v, _) = evaluate(
                &dual_tree,
                (&q, &seed(j, &zero, false)),
                (&seed(j, &v, true), &a, &y),
            );
            let eps = |x: &[Dual64]| DVector::from_iterator(n, x.iter().map(|d| d.eps));
            let err = [
                (eps(&id_q) - d_dq.column(j)).amax(),
                (eps(&id_v) - d_dv.column(j)).amax(),
                (eps(&my_q) - d_my.column(j)).amax(),
            ];
            assert!(err.iter().all(|&e| e < 1e-11), "column {j}: dual {err:?}");

            let at = |dq: &[f64], v: &[f64]| {
                let (tau, my) = evaluate(tree, (&q, dq), (v, &a, &y));
                (DVector::from_vec(tau), DVector::from_vec(my))
            };
            let ((tp, mp), (tm, mm)) = (
                at(&shifted(&zero, j, h), &v),
                at(&shifted(&zero, j, -h), &v),
            );
            let (vp, vm) = (
                at(&zero, &shifted(&v, j, h)).0,
                at(&zero, &shifted(&v, j, -h)).0,
            );
            let err = [
                ((tp - tm) / (2.0 * h) - d_dq.column(j)).amax(),
                ((vp - vm) / (2.0 * h) - d_dv.column(j)).amax(),
                ((mp - mm) / (2.0 * h) - d_my.column(j)).amax(),
            ];
            assert!(
                err.iter().all(|&e| e < 1e-6),
                "column {j}: differences {err:?}"
            );
        }
    }
}
