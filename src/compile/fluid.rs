//! What the fluid acts on (see [`crate::dynamics::fluid`]), computed when
//! the model is compiled: per body with mass, either its geoms under the
//! ellipsoid model, each with its semi-axes and added mass and inertia, or
//! its principal axes and the sides of the box with its mass and principal
//! moments.

use nalgebra::{Matrix3, Vector3};

use super::tree::mass_properties;
use crate::dynamics::fluid::{FluidBody, FluidEllipsoid, FluidTerms};
use crate::model::geom_inertia::MJ_EPS;
use crate::model::{Geom, Param, Shape, Spec};
use crate::spatial::{lift, lift_matrix, lift_vector, Real, Transform};

/// MuJoCo's mjMINVAL: lighter bodies feel no fluid.
const MIN_MASS: f64 = crate::model::MINVAL;

/// The bodies and geoms of `spec` the fluid acts on (none without a
/// medium), each carried by node `frames[b]` at the offset given (the
/// tree's body frames), their mass, COM and inertia lifted by `lift_param`
/// (see [`crate::dynamics::Tree::build_with`]).
pub fn fluid_bodies<T: Real>(
    spec: &Spec,
    frames: &[(Option<usize>, Transform<T>)],
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> FluidTerms<T> {
    let mut out = FluidTerms::none();
    if !spec.opt.fluid.acts() {
        return out;
    }
    for (b, body) in spec.bodies.iter().enumerate().skip(1) {
        let (Some(node), offset) = frames[b] else {
            continue;
        };
        if body.mass < MIN_MASS {
            continue;
        }
        let geoms = spec
            .geoms
            .iter()
            .filter(|g| g.body == b && g.fluid.is_some());
        let ellipsoids: Vec<_> = geoms.map(|g| fluid_ellipsoid(g, node, &offset)).collect();
        if !ellipsoids.is_empty() {
            out.ellipsoids.extend(ellipsoids);
            continue;
        }
        let (mass, com, inertia) = mass_properties(b, body, lift_param);
        let axes: Matrix3<T> = lift_matrix(body.inertia_frame.matrix());
        let moments = (axes.transpose() * inertia * axes).diagonal();
        let side = |k: usize| {
            let (j, l) = ((k + 1) % 3, (k + 2) % 3);
            let excess = (moments[j] + moments[l] - moments[k]).max(lift(MIN_MASS));
            (excess / mass * lift(6.0)).sqrt()
        };
        out.boxes.push(FluidBody {
            node,
            offset,
            com,
            axes,
            sides: Vector3::new(side(0), side(1), side(2)),
        });
    }
    out
}

/// A geom under the ellipsoid model, carried by `node` (`offset` from its
/// frame to the body's).
fn fluid_ellipsoid<T: Real>(geom: &Geom, node: usize, offset: &Transform<T>) -> FluidEllipsoid<T> {
    let s = semiaxes(&geom.shape);
    let coefs = geom
        .fluid
        .expect("a geom under the ellipsoid model")
        .to_array();
    let (virtual_mass, virtual_inertia) = added_inertia(&s);
    FluidEllipsoid {
        node,
        offset: Transform::from_pose_f64(&geom.rot, &geom.pos).compose(offset),
        semiaxes: lift_vector(&s),
        coefs: coefs.map(lift),
        virtual_mass: lift_vector(&virtual_mass),
        virtual_inertia: lift_vector(&virtual_inertia),
    }
}

/// A primitive solid's semi-axes as MuJoCo's mju_geomSemiAxes gives them
/// (see [`FluidEllipsoid`]).
fn semiaxes(shape: &Shape) -> Vector3<f64> {
    match *shape {
        Shape::Sphere { radius } => Vector3::repeat(radius),
        Shape::Capsule {
            radius,
            half_length,
        } => Vector3::new(radius, radius, half_length + radius),
        Shape::Cylinder {
            radius,
            half_length,
        } => Vector3::new(radius, radius, half_length),
        Shape::Box { half } => half,
        Shape::Ellipsoid { radii } => radii,
        _ => unreachable!("Spec::check refuses the ellipsoid fluid model on other shapes"),
    }
}

/// The added mass and moments of inertia per unit density of the ellipsoid
/// with semi-axes `s` (MuJoCo's mjCGeom::SetFluidCoefs): with kappa_k the
/// ellipsoid's shape integrals ([`kappa`]), V its volume,
/// m_k = V kappa_k / (2 - kappa_k) and I_x = V / 5 (b^2 - c^2)^2
/// |kappa_z - kappa_y| / |2 (b^2 - c^2) + (b^2 + c^2) (kappa_y - kappa_z)|,
/// the others by cycling the axes; denominators at least mjEPS.
fn added_inertia(s: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let volume = 4.0 / 3.0 * std::f64::consts::PI * s.x * s.y * s.z;
    let k = Vector3::from_fn(|i, _| kappa(s[i], s[(i + 1) % 3], s[(i + 2) % 3]));
    let mass = k.map(|k| volume * k / (2.0 - k).max(MJ_EPS));
    let inertia = Vector3::from_fn(|i, _| {
        let (j, l) = ((i + 1) % 3, (i + 2) % 3);
        let (bb, cc) = (s[j] * s[j], s[l] * s[l]);
        let num = (bb - cc) * (bb - cc) * (k[l] - k[j]).abs();
        let den = (2.0 * (bb - cc) + (bb + cc) * (k[j] - k[l])).abs();
        volume * num / den.max(MJ_EPS) / 5.0
    });
    (mass, inertia)
}

/// The ellipsoid's shape integral along its first semi-axis dx,
/// kappa = dx dy dz int_0^inf dl / sqrt((dx^2 + l)^3 (dy^2 + l) (dz^2 + l)),
/// by MuJoCo's 15-point Gauss-Kronrod rule after the change of variables
/// l = scale x^3 / (1 - x)^2, scale = (dx^3 dy dz)^(2/5) (its nodes L, the
/// slopes dl/dx D and weights W at x in [0, 1], as MuJoCo rounds them).
fn kappa(dx: f64, dy: f64, dz: f64) -> f64 {
    #[rustfmt::skip]
    const W: [f64; 15] = [
        0.01146766, 0.03154605, 0.05239501, 0.07032663, 0.08450236,
        0.09517529, 0.10221647, 0.10474107, 0.10221647, 0.09517529,
        0.08450236, 0.07032663, 0.05239501, 0.03154605, 0.01146766,
    ];
    #[rustfmt::skip]
    const L: [f64; 15] = [
        7.865151709349917e-08, 1.7347976913907274e-05, 0.0003548008144506193,
        0.002846636252924549, 0.014094260903596077, 0.053063261727396636,
        0.17041978741317773, 0.5, 1.4036301548686991, 3.9353484827022642,
        11.644841677041734, 39.53187807410903, 177.5711362220801,
        1429.4772912937397, 54087.416549217705,
    ];
    #[rustfmt::skip]
    const D: [f64; 15] = [
        5.538677720489877e-05, 0.002080868285293228, 0.016514126520723166,
        0.07261900344370877, 0.23985243401862602, 0.6868318249020725,
        1.8551129519182894, 5.0, 14.060031152313941, 43.28941239611009,
        156.58546376397112, 747.9826085305024, 5827.4042950027115,
        116754.0197944512, 25482945.327264845,
    ];
    let inv = [dx, dy, dz].map(|d| 1.0 / (d * d));
    let scale = (dx * dx * dx * dy * dz).powf(0.4);
    let sum: f64 = (0..15)
        .map(|i| {
            let l = scale * L[i];
            let [x, y, z] = inv.map(|v| 1.0 + l * v);
            scale * D[i] / (x * (x * y * z).sqrt()) * W[i]
        })
        .sum();
    sum * inv[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere's added mass is half its displaced volume (kappa = 2/3) and
    /// it has no added inertia; a prolate spheroid's kappa along its axis
    /// is Lamb's alpha_0 = 2 (1 - e^2) / e^3 (atanh(e) - e), across it
    /// (2 - alpha_0) / 2; all to the quadrature's rounded weights, 1e-6.
    #[test]
    fn added_inertia_has_its_classical_limits() {
        let r = 0.3;
        let (mass, inertia) = added_inertia(&Vector3::repeat(r));
        let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        for k in 0..3 {
            assert!((mass[k] / volume - 0.5).abs() < 1e-6, "{mass}");
            assert_eq!(inertia[k], 0.0);
        }
        for a in [1.5f64, 2.0, 3.0] {
            let e = (1.0 - 1.0 / (a * a)).sqrt();
            let alpha = 2.0 * (1.0 - e * e) / (e * e * e) * (e.atanh() - e);
            assert!((kappa(a, 1.0, 1.0) - alpha).abs() < 1e-6);
            assert!((kappa(1.0, 1.0, a) - (2.0 - alpha) / 2.0).abs() < 1e-6);
        }
    }
}
