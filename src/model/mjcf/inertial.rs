//! Bodies' inertial properties, by MuJoCo's compiler rules.
//!
//! A body's mass, centre of mass and inertia come from its geoms when
//! `inertiafromgeom` is true, or auto (the default) and the body has no
//! `<inertial>`; see [`crate::model::geom_inertia`]. Geoms count whatever their
//! contype/conaffinity, if their group is in `inertiagrouprange`. Then
//! `boundmass` and `boundinertia` bound them from below, `balanceinertia`
//! repairs principal moments that violate the triangle inequality, and
//! `settotalmass` scales all bodies to the given total.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::attributes::{value, Attrs};
use super::orientation::ALTERNATIVES;
use super::schema::{check_attributes, INERTIAL_ATTRS};
use super::tree::Tree;
use super::{Node, Reader, Result};
use crate::model::geom_inertia::{MassProperties, MJ_EPS};
use crate::model::params::inertia_from_six;
use crate::model::MINVAL;

/// A body's inertial properties in MuJoCo's form: principal `moments` along
/// the columns of `axes` (body coordinates), about `com`.
#[derive(Clone, Debug)]
pub struct Principal {
    pub mass: f64,
    pub com: Vector3<f64>,
    pub axes: Matrix3<f64>,
    pub moments: Vector3<f64>,
}

impl Principal {
    pub fn massless() -> Self {
        Principal {
            mass: 0.0,
            com: Vector3::zeros(),
            axes: Matrix3::identity(),
            moments: Vector3::zeros(),
        }
    }

    /// The principal form of a full tensor; `None` unless its moments are all
    /// at least `mjEPS` (MuJoCo's requirement).
    fn from_tensor(mass: f64, com: Vector3<f64>, tensor: Matrix3<f64>) -> Option<Self> {
        let eig = tensor.symmetric_eigen();
        (eig.eigenvalues.min() >= MJ_EPS).then_some(Principal {
            mass,
            com,
            axes: eig.eigenvectors,
            moments: eig.eigenvalues,
        })
    }

    pub fn mass_properties(&self) -> MassProperties {
        MassProperties::from_principal(self.mass, self.com, &self.axes, &self.moments)
    }

    /// The principal axes as a rotation (an axis flipped if they are
    /// left-handed).
    pub fn frame(&self) -> Rotation3<f64> {
        let mut axes = self.axes;
        if axes.determinant() < 0.0 {
            axes.set_column(2, &-axes.column(2));
        }
        Rotation3::from_matrix_unchecked(axes)
    }

    fn has_mass(&self) -> bool {
        self.mass >= MINVAL && self.moments.min() >= MINVAL
    }
}

impl<'a> Reader<'a> {
    /// An `<inertial>` element.
    pub(super) fn read_inertial(&self, node: Node<'a>) -> Result<Principal> {
        check_attributes(self.file, node, INERTIAL_ATTRS)?;
        let a = Attrs::of(self.file, node);
        let required =
            |name: &str| self.error(node, format!("required attribute missing: '{name}'"));
        let com = a.vector("pos")?.ok_or_else(|| required("pos"))?;
        let mass = a.number("mass")?.ok_or_else(|| required("mass"))?;
        let diagonal = a.vector("diaginertia")?;
        // MuJoCo would clamp these to boundmass and boundinertia (0 by default).
        if mass < 0.0 || diagonal.is_some_and(|d| d.min() < 0.0) {
            return Err(self.error(node, "mass and diaginertia cannot be negative"));
        }
        let Some(full) = a.exact::<6>("fullinertia")? else {
            let axes = *self.orientation(&a)?.matrix();
            return Ok(Principal {
                mass,
                com,
                axes,
                moments: diagonal.unwrap_or_default(),
            });
        };
        if ["quat"]
            .iter()
            .chain(&ALTERNATIVES)
            .any(|k| value(node, k).is_some())
        {
            return Err(self.error(node, "fullinertia and an orientation cannot both be given"));
        }
        if diagonal.is_some_and(|d| d != Vector3::zeros()) {
            return Err(self.error(node, "fullinertia and diaginertia cannot both be given"));
        }
        Principal::from_tensor(mass, com, inertia_from_six(&full))
            .ok_or_else(|| self.error(node, "fullinertia must have positive eigenvalues"))
    }

    /// A body's inertial properties: from its geoms (`parts`, if any), else
    /// from its `<inertial>`, then bounded and checked.
    pub(super) fn body_inertial(
        &self,
        body: Node<'a>,
        inertial: Option<Principal>,
        parts: &[Principal],
    ) -> Result<Principal> {
        let p = match (parts, inertial) {
            ([one], _) => one.clone(),
            ([], Some(explicit)) => explicit,
            ([], None) => Principal::massless(),
            (many, _) => {
                let all: Vec<MassProperties> =
                    many.iter().map(Principal::mass_properties).collect();
                let sum = MassProperties::combine(&all).expect("geom parts have positive mass");
                Principal::from_tensor(sum.mass, sum.com, sum.inertia)
                    .ok_or_else(|| self.error(body, "the geoms' inertia is degenerate"))?
            }
        };
        self.bound_and_balance(body, p)
    }

    /// `boundmass`, `boundinertia`, then the triangle inequality of the
    /// principal moments (`balanceinertia` evens out moments that violate it).
    fn bound_and_balance(&self, body: Node<'a>, mut p: Principal) -> Result<Principal> {
        let c = &self.compiler;
        p.mass = p.mass.max(c.boundmass);
        p.moments = p.moments.map(|m| m.max(c.boundinertia));
        if p.mass < 0.0 || p.moments.min() < 0.0 {
            return Err(self.error(body, "mass and inertia cannot be negative"));
        }
        let [a, b, d] = [p.moments.x, p.moments.y, p.moments.z];
        if a + b < d || a + d < b || b + d < a {
            if !c.balanceinertia {
                let msg = format!(
                    "principal moments {:?} violate A + B >= C (use balanceinertia to fix)",
                    [a, b, d]
                );
                return Err(self.error(body, msg));
            }
            p.moments = Vector3::repeat((a + b + d) / 3.0);
        }
        Ok(p)
    }

    /// MuJoCo requires each body with joints, or some body welded to it, to
    /// have mass and principal moments of at least `mjMINVAL`.
    pub(super) fn check_moving_bodies(&self, tree: &Tree<'a>) -> Result<()> {
        let welded_mass = |b: usize| -> bool {
            let mut stack = vec![b];
            while let Some(i) = stack.pop() {
                if tree.inertials[i].has_mass() {
                    return true;
                }
                let welded = (i + 1..tree.bodies.len())
                    .filter(|&c| tree.bodies[c].parent == i && tree.bodies[c].joints.is_empty());
                stack.extend(welded);
            }
            false
        };
        for (i, node) in tree.nodes.iter().enumerate().skip(1) {
            if !tree.bodies[i].joints.is_empty() && !welded_mass(i) {
                let msg = "a body with joints needs mass and inertia (>= 1e-15), \
                           itself or in a body welded to it";
                return Err(self.error(node.expect("bodies past the world have elements"), msg));
            }
        }
        Ok(())
    }

    /// `settotalmass`: scales every mass and inertia so the masses sum to it.
    pub(super) fn scale_total_mass(&self, tree: &mut Tree<'a>) {
        let target = self.compiler.settotalmass;
        if target <= 0.0 {
            return;
        }
        let total: f64 = tree.inertials.iter().skip(1).map(|p| p.mass).sum();
        let scale = (target / total.max(MINVAL)).max(MINVAL);
        for p in tree.inertials.iter_mut().skip(1) {
            p.mass *= scale;
            p.moments *= scale;
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use nalgebra::{Matrix3, Vector3};

    use super::super::test_util::*;

    #[test]
    fn explicit_inertial_and_geoms_follow_inertiafromgeom() {
        let bodies = body(r#"<inertial pos="0 0 1" mass="2" diaginertia="1 2 2"/>"#);
        let m = load(&model("", &bodies, ""));
        assert_eq!((m.bodies[1].mass, m.bodies[1].com.z), (2.0, 1.0));
        let diagonal = Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 2.0));
        assert_eq!(m.bodies[1].inertia, diagonal);
        let m = load(&model(r#"<compiler inertiafromgeom="true"/>"#, &bodies, ""));
        assert!((m.bodies[1].mass - 1000.0 * 4.0 / 3.0 * PI * 1e-3).abs() < 1e-12);
    }
}
