//! Equality constraints as a model file gives them (MJCF `<equality>`,
//! MuJoCo's mjsEquality), each solved as soft constraint rows
//! ([`crate::dynamics::constraint::equality`]).
//!
//! Conventions, MuJoCo 4's:
//! - Body 1 and body 2 (body 2 the world when the file names none); a site
//!   form names two sites and acts on their bodies.
//! - `connect`: a point of body 1 (`anchor`, body 1 coordinates) held on
//!   the point of body 2 that coincides with it at the reference
//!   configuration (qpos0); with sites, the two sites' origins held together.
//! - `weld`: body 2's frame held at the pose relative to body 1 it has at
//!   qpos0, `anchor` (body 2 coordinates) the point held; or, with
//!   `relpose` (its quaternion not zero), at that pose of body 2 in body 1
//!   (position, unit quaternion w x y z). With sites, the sites' frames
//!   held together. `torquescale` scales the rotational rows.
//! - `joint`: q1 - q1_0 = c0 + c1 d + c2 d^2 + c3 d^3 + c4 d^4 with d =
//!   q2 - q2_0 (`polycoef`, the _0 at qpos0); with one joint, q1 - q1_0 =
//!   c0. Hinges and slides only.
//! - `tendon`: the same law on two tendons' lengths (L1 - L1_0 = c0 + c1 d
//!   + ... with d = L2 - L2_0, the _0 at qpos0).

use nalgebra::{Quaternion, Vector3};

use super::SolParams;

/// One equality constraint.
#[derive(Clone, Debug, PartialEq)]
pub struct Equality {
    pub name: String,
    pub kind: EqualityKind,
    /// Whether it acts (MJCF `active`).
    pub active: bool,
    pub sol: SolParams,
}

/// What an equality holds together; see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub enum EqualityKind {
    Connect {
        objects: Objects,
        anchor: Vector3<f64>,
    },
    Weld {
        objects: Objects,
        anchor: Vector3<f64>,
        /// Body 2's pose in body 1 (position, quaternion as written, not
        /// zero; normalised when compiled); None: its pose at qpos0.
        relpose: Option<(Vector3<f64>, Quaternion<f64>)>,
        torquescale: f64,
    },
    Joint {
        joints: [Option<usize>; 2],
        polycoef: [f64; 5],
    },
    /// Indices into [`super::Spec::tendons`].
    Tendon {
        tendons: [Option<usize>; 2],
        polycoef: [f64; 5],
    },
}

/// The two objects of a connect or weld: bodies, or sites (indices into
/// [`super::Spec::sites`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Objects {
    Bodies([usize; 2]),
    Sites([usize; 2]),
}

impl Equality {
    /// Checks what MuJoCo would replace silently or what has no meaning
    /// (errors name the equality): its solver parameters, finite numbers,
    /// two different objects that exist, joints that are hinges or slides.
    pub fn check(&self, spec: &super::Spec) -> Result<(), String> {
        let counts = [spec.bodies.len(), spec.sites.len(), spec.tendons.len()];
        self.check_parts(counts, &spec.joints)
    }

    /// [`Equality::check`] in a model of `nbody` bodies, `nsite` sites,
    /// `ntendon` tendons and `joints`.
    pub fn check_parts(
        &self,
        [nbody, nsite, ntendon]: [usize; 3],
        joints: &[super::Joint],
    ) -> Result<(), String> {
        let owner = format!("equality '{}'", self.name);
        let exists = match &self.kind {
            EqualityKind::Connect { objects, .. } | EqualityKind::Weld { objects, .. } => {
                match objects {
                    Objects::Bodies(b) => b.iter().all(|b| *b < nbody),
                    Objects::Sites(s) => s.iter().all(|s| *s < nsite),
                }
            }
            EqualityKind::Joint { joints: ids, .. } => {
                ids[0].is_some() && ids.iter().flatten().all(|j| *j < joints.len())
            }
            EqualityKind::Tendon { tendons, .. } => {
                tendons[0].is_some() && tendons.iter().flatten().all(|t| *t < ntendon)
            }
        };
        if !exists {
            return Err(format!("{owner}: names an object that does not exist"));
        }
        self.sol.check(&owner)?;
        let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
        let (numbers, same) = match &self.kind {
            EqualityKind::Connect { objects, anchor } => {
                (anchor.as_slice().to_vec(), objects.same())
            }
            EqualityKind::Weld {
                objects,
                anchor,
                relpose,
                torquescale,
            } => {
                let mut x = anchor.as_slice().to_vec();
                x.push(*torquescale);
                if let Some((p, q)) = relpose {
                    x.extend(p.iter().chain(q.coords.iter()));
                }
                (x, objects.same())
            }
            EqualityKind::Joint {
                joints: ids,
                polycoef,
            } => {
                for j in ids.iter().flatten() {
                    if !matches!(
                        joints[*j].kind,
                        super::JointKind::Hinge | super::JointKind::Slide
                    ) {
                        let name = &joints[*j].name;
                        return Err(format!(
                            "{owner}: joint '{name}' must be a hinge or a slide"
                        ));
                    }
                }
                (polycoef.to_vec(), ids[0] == ids[1])
            }
            EqualityKind::Tendon { tendons, polycoef } => {
                (polycoef.to_vec(), tendons[0] == tendons[1])
            }
        };
        if !finite(&numbers) {
            return Err(format!("{owner}: numbers must be finite, got {numbers:?}"));
        }
        if same {
            return Err(format!("{owner}: needs two different objects"));
        }
        Ok(())
    }
}

impl Objects {
    fn same(&self) -> bool {
        match self {
            Objects::Bodies([a, b]) | Objects::Sites([a, b]) => a == b,
        }
    }
}
