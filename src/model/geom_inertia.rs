//! Mass, centre of mass and inertia of primitive geoms, as MuJoCo's compiler
//! computes them (`mjCGeom::GetVolume`, `SetInertia`, `mjCBody::InertiaFromGeom`).
//!
//! Conventions: a geom's principal axes are the axes of its own frame (capsules
//! and cylinders along z); its centre of mass is its frame origin. Solid bodies
//! only (MuJoCo's default; `shellinertia` is rejected by the loader). Planes have
//! no volume and so no mass.

use nalgebra::{Matrix3, Vector3};

use super::mesh::Mesh;
use super::Shape;

/// MuJoCo's `mjEPS`: the smallest volume an explicit mass is spread over; in
/// the MJCF compiler also the smallest squared norm it normalises, smallest
/// geom mass it counts and smallest principal moment of a full inertia tensor.
pub(crate) const MJ_EPS: f64 = 1e-14;

/// Volume of a solid primitive (zero for a plane) or of a mesh of `meshes`
/// (its area for a shell mesh); a height field's is its box's.
pub fn volume(shape: &Shape, meshes: &[Mesh]) -> f64 {
    use std::f64::consts::PI;
    match *shape {
        Shape::Mesh { mesh } => meshes[mesh].volume,
        Shape::Plane => 0.0,
        Shape::Sphere { radius: r } => 4.0 * PI * r * r * r / 3.0,
        Shape::Capsule {
            radius: r,
            half_length,
        } => PI * (r * r * (2.0 * half_length) + 4.0 * r * r * r / 3.0),
        Shape::Cylinder {
            radius: r,
            half_length,
        } => PI * r * r * (2.0 * half_length),
        Shape::Box { half } => half.x * half.y * half.z * 8.0,
        Shape::HField { .. } => volume(&hfield_box(shape), meshes),
        Shape::Ellipsoid { radii: s } => 4.0 * PI * s.x * s.y * s.z / 3.0,
    }
}

/// A geom's mass by MuJoCo's rule: an explicit `mass` wins (zero if the volume
/// is too small to hold it), else `density * volume`.
pub fn mass(shape: &Shape, meshes: &[Mesh], explicit_mass: Option<f64>, density: f64) -> f64 {
    match explicit_mass {
        Some(m) if m == 0.0 || volume(shape, meshes) <= MJ_EPS => 0.0,
        Some(m) => m,
        None if density == 0.0 => 0.0,
        None => density * volume(shape, meshes),
    }
}

/// Principal moments of inertia of a solid primitive of the given mass about
/// its centre, along the geom's axes. A capsule is a cylinder plus two
/// hemispheres, each hemisphere displaced along z with its own centre of mass.
/// A mesh's are along its mesh axes ([`Mesh::principal_moments`]).
pub fn principal_moments(shape: &Shape, meshes: &[Mesh], mass: f64) -> Vector3<f64> {
    match *shape {
        Shape::Mesh { mesh } => meshes[mesh].principal_moments(mass),
        Shape::HField { .. } => principal_moments(&hfield_box(shape), meshes, mass),
        Shape::Plane => Vector3::zeros(),
        Shape::Sphere { radius: r } => Vector3::repeat(2.0 * mass * r * r / 5.0),
        Shape::Capsule {
            radius: r,
            half_length,
        } => {
            let height = 2.0 * half_length;
            let sphere_mass = mass * 4.0 * r / (4.0 * r + 3.0 * height);
            let cylinder_mass = mass - sphere_mass;
            let sphere = 2.0 * sphere_mass * r * r / 5.0;
            let offset = sphere_mass * height * (3.0 * r + 2.0 * height) / 8.0;
            let side = cylinder_mass * (3.0 * r * r + height * height) / 12.0 + sphere + offset;
            Vector3::new(side, side, cylinder_mass * r * r / 2.0 + sphere)
        }
        Shape::Cylinder {
            radius: r,
            half_length,
        } => {
            let height = 2.0 * half_length;
            let side = mass * (3.0 * r * r + height * height) / 12.0;
            Vector3::new(side, side, mass * r * r / 2.0)
        }
        Shape::Box { half: s } => {
            let (x2, y2, z2) = (s.x * s.x, s.y * s.y, s.z * s.z);
            Vector3::new(
                mass * (y2 + z2) / 3.0,
                mass * (x2 + z2) / 3.0,
                mass * (x2 + y2) / 3.0,
            )
        }
        Shape::Ellipsoid { radii: s } => {
            let (x2, y2, z2) = (s.x * s.x, s.y * s.y, s.z * s.z);
            Vector3::new(
                mass * (y2 + z2) / 5.0,
                mass * (x2 + z2) / 5.0,
                mass * (x2 + y2) / 5.0,
            )
        }
    }
}

/// The box whose mass and inertia a height-field geom has (MuJoCo's).
fn hfield_box(shape: &Shape) -> Shape {
    Shape::Box {
        half: shape.size().into(),
    }
}

/// Mass properties of a rigid part: mass, centre of mass and the inertia tensor
/// about that centre, all in one common frame.
#[derive(Clone, Debug, PartialEq)]
pub struct MassProperties {
    pub mass: f64,
    pub com: Vector3<f64>,
    pub inertia: Matrix3<f64>,
}

impl MassProperties {
    /// A part with principal `moments` along the columns of `axes` (a rotation),
    /// centred at `com`.
    pub fn from_principal(
        mass: f64,
        com: Vector3<f64>,
        axes: &Matrix3<f64>,
        moments: &Vector3<f64>,
    ) -> Self {
        let inertia = axes * Matrix3::from_diagonal(moments) * axes.transpose();
        MassProperties { mass, com, inertia }
    }

    /// The parts as one rigid body: masses add, the centre of mass is the
    /// mass-weighted mean, and each part's inertia moves to it by the parallel
    /// axis theorem. `None` when the total mass is zero.
    pub fn combine(parts: &[MassProperties]) -> Option<MassProperties> {
        let mass: f64 = parts.iter().map(|p| p.mass).sum();
        if mass <= 0.0 {
            return None;
        }
        let com = parts.iter().map(|p| p.mass * p.com).sum::<Vector3<f64>>() / mass;
        let inertia = parts
            .iter()
            .map(|p| {
                let d = p.com - com;
                p.inertia + p.mass * (Matrix3::identity() * d.norm_squared() - d * d.transpose())
            })
            .sum();
        Some(MassProperties { mass, com, inertia })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-14 * b.abs().max(1e-300)
    }

    #[test]
    fn capsule_is_cylinder_plus_displaced_hemispheres() {
        // Direct integration: cylinder (m_c) plus two hemispheres (m_s total)
        // whose centres of mass sit 3r/8 beyond the cylinder ends.
        let (r, h) = (0.3_f64, 0.7_f64);
        let shape = Shape::Capsule {
            radius: r,
            half_length: h / 2.0,
        };
        let rho = 2.0;
        let m_c = rho * PI * r * r * h;
        let m_s = rho * 4.0 / 3.0 * PI * r * r * r;
        let m = mass(&shape, &[], None, rho);
        assert!(close(m, m_c + m_s));
        let c = 3.0 * r / 8.0;
        let hemi_own = m_s * (2.0 / 5.0 * r * r - c * c); // both halves, about own COM
        let hemi_side = hemi_own + m_s * (h / 2.0 + c).powi(2);
        let side = m_c * (3.0 * r * r + h * h) / 12.0 + hemi_side;
        let axial = m_c * r * r / 2.0 + m_s * 2.0 / 5.0 * r * r;
        let i = principal_moments(&shape, &[], m);
        assert!(
            close(i.x, side) && close(i.y, side) && close(i.z, axial),
            "{i:?}"
        );
    }

    #[test]
    fn explicit_mass_wins_and_planes_are_massless() {
        let sphere = Shape::Sphere { radius: 0.1 };
        assert_eq!(mass(&sphere, &[], Some(2.5), 1000.0), 2.5);
        assert!(close(
            mass(&sphere, &[], None, 1000.0),
            1000.0 * 4.0 / 3.0 * PI * 1e-3
        ));
        assert_eq!(mass(&Shape::Plane, &[], None, 1000.0), 0.0);
        assert_eq!(mass(&Shape::Plane, &[], Some(1.0), 1000.0), 0.0);
    }

    #[test]
    fn two_point_like_parts_combine_by_parallel_axes() {
        let a = MassProperties::from_principal(
            1.0,
            Vector3::new(1.0, 0.0, 0.0),
            &Matrix3::identity(),
            &Vector3::zeros(),
        );
        let b = MassProperties {
            com: Vector3::new(-1.0, 0.0, 0.0),
            ..a.clone()
        };
        let both = MassProperties::combine(&[a, b]).unwrap();
        assert_eq!(both.mass, 2.0);
        assert_eq!(both.com, Vector3::zeros());
        assert_eq!(
            both.inertia,
            Matrix3::from_diagonal(&Vector3::new(0.0, 2.0, 2.0))
        );
        assert!(MassProperties::combine(&[]).is_none());
    }
}
