//! Named physical parameters, and affine maps from a task's mu onto them.
//!
//! Names and meanings (DESIGN.md):
//! - `body/<name>/mass` (kg): changing it keeps the COM and the inertia about the COM.
//! - `body/<name>/com` (3 values, m): the COM in body coordinates; changing it
//!   keeps the mass and the inertia about the (moved) COM, as editing MuJoCo's
//!   body_ipos does.
//! - `body/<name>/inertia` (6 values, kg m^2): xx yy zz xy xz yz about the COM in
//!   body axes.
//! - `joint/<name>/damping`, `joint/<name>/stiffness`, `joint/<name>/armature`.
//! - The smooth contact model's: `contact/stiffness` (N/m), `contact/damping`
//!   (N s/m), `contact/friction` (dimensionless: a scale on every pair's
//!   coefficient, the larger sliding friction of its two geoms), the model's
//!   global soft-contact constants ([`super::SoftOptions`]); listed by
//!   [`Param::all`] only when the model has contact pairs.
//! - The constraint contact model's (MuJoCo's meanings, [`super::constraint`]):
//!   `geom/<name>/friction` (sliding, torsional, rolling), `geom/<name>/solref`
//!   (2 values), `geom/<name>/solimp` (5 values), for the pairs the geom
//!   forms by itself (an explicit `<pair>` has its own); `joint/<name>/frictionloss`
//!   (N or N m), `joint/<name>/solreflimit` and `joint/<name>/solimplimit`.
//!   Setters check them as MuJoCo's compiler would ([`super::SolParams::check`]).
//!   The other contact model's parameters are an error naming the model.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::constraint::check_friction;
use super::{
    check_inertial, check_passive, check_soft, check_tree_inertia, ContactModel, Geom, Joint,
    Model, ModelError, SoftOptions, SolParams, Spec,
};
use crate::dynamics::body_inertia;
use crate::dynamics::collision::collision_pairs;
use crate::dynamics::constraint::invweight0;
use crate::dynamics::contact::contact_pairs;
use crate::dynamics::fluid::fluid_bodies;
use crate::dynamics::Tree;
use crate::spatial::Inertia;

/// One named parameter, resolved to the body or joint it belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Param {
    Mass(usize),
    Com(usize),
    Inertia(usize),
    Damping(usize),
    Stiffness(usize),
    Armature(usize),
    ContactStiffness,
    ContactDamping,
    ContactFriction,
    GeomFriction(usize),
    GeomSolref(usize),
    GeomSolimp(usize),
    FrictionLoss(usize),
    LimitSolref(usize),
    LimitSolimp(usize),
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    #[error("unknown parameter '{name}'{hint}")]
    Unknown { name: String, hint: String },
    #[error("parameter '{name}' takes {expected} values, got {got}")]
    Length {
        name: String,
        got: usize,
        expected: usize,
    },
    #[error("parameter '{name}' value {value} is not finite")]
    NotFinite { name: String, value: f64 },
    #[error("parameter '{name}' = {value:?} is not physical: {source}")]
    NotPhysical {
        name: String,
        value: Vec<f64>,
        source: Box<ModelError>,
    },
    #[error("{0}")]
    Map(String),
}

impl Param {
    /// Resolves a name such as `body/pole/com` against a model.
    pub fn parse(spec: &Spec, name: &str) -> Result<Param, ParamError> {
        let param = Param::parse_any(spec, name)?;
        let constraint = spec.opt.contact_model == ContactModel::Constraint;
        let other_model = if constraint {
            param.is_contact()
        } else {
            param.is_constraint()
        };
        if other_model {
            let (ours, theirs) = if constraint {
                ("constraint", "geom/<name>/friction|solref|solimp, joint/<name>/frictionloss|solreflimit|solimplimit")
            } else {
                ("smooth", "contact/stiffness|damping|friction")
            };
            return Err(ParamError::Unknown {
                name: name.to_string(),
                hint: format!(
                    ": the model runs the {ours} contact model, whose contact parameters are {theirs}"
                ),
            });
        }
        Ok(param)
    }

    /// Resolves a name under either contact model.
    fn parse_any(spec: &Spec, name: &str) -> Result<Param, ParamError> {
        let unknown = |hint: String| ParamError::Unknown {
            name: name.to_string(),
            hint,
        };
        let expected = " (expected body/<name>/<field>, joint/<name>/<field>, \
                        geom/<name>/<field> or contact/<field>)";
        if let Some(field) = name.strip_prefix("contact/") {
            return match field {
                "stiffness" => Ok(Param::ContactStiffness),
                "damping" => Ok(Param::ContactDamping),
                "friction" => Ok(Param::ContactFriction),
                _ => Err(unknown(
                    ": contact fields are stiffness, damping, friction".into(),
                )),
            };
        }
        // Body, joint and geom names may hold '/' themselves (MuJoCo's
        // attach prefixes do): the kind ends at the first '/', the field
        // starts after the last.
        let parts = name
            .split_once('/')
            .and_then(|(kind, rest)| rest.rsplit_once('/').map(|(o, f)| (kind, o, f)));
        let Some((kind, object, field)) = parts else {
            return Err(unknown(expected.into()));
        };
        match kind {
            "body" => {
                let Some(b) = spec.bodies.iter().skip(1).position(|b| b.name == object) else {
                    return Err(unknown(format!(": no body named '{object}'")));
                };
                let b = b + 1;
                match field {
                    "mass" => Ok(Param::Mass(b)),
                    "com" => Ok(Param::Com(b)),
                    "inertia" => Ok(Param::Inertia(b)),
                    _ => Err(unknown(": body fields are mass, com, inertia".into())),
                }
            }
            "joint" => {
                let Some(j) = spec.joints.iter().position(|j| j.name == object) else {
                    return Err(unknown(format!(": no joint named '{object}'")));
                };
                match field {
                    "damping" => Ok(Param::Damping(j)),
                    "stiffness" => Ok(Param::Stiffness(j)),
                    "armature" => Ok(Param::Armature(j)),
                    "frictionloss" => Ok(Param::FrictionLoss(j)),
                    "solreflimit" => Ok(Param::LimitSolref(j)),
                    "solimplimit" => Ok(Param::LimitSolimp(j)),
                    _ => Err(unknown(
                        ": joint fields are damping, stiffness, armature, frictionloss, \
                         solreflimit, solimplimit"
                            .into(),
                    )),
                }
            }
            "geom" => {
                let Some(g) = spec
                    .geoms
                    .iter()
                    .position(|g| !g.name.is_empty() && g.name == object)
                else {
                    return Err(unknown(format!(": no geom named '{object}'")));
                };
                match field {
                    "friction" => Ok(Param::GeomFriction(g)),
                    "solref" => Ok(Param::GeomSolref(g)),
                    "solimp" => Ok(Param::GeomSolimp(g)),
                    _ => Err(unknown(": geom fields are friction, solref, solimp".into())),
                }
            }
            _ => Err(unknown(expected.into())),
        }
    }

    /// Every identifiable parameter of a model, bodies first, in model order,
    /// then the joints', then the contact model's: the smooth model's three
    /// if it has contact pairs; the constraint model's dry friction where a
    /// joint has some (at 0 its rows vanish, and so does its derivative),
    /// each limited joint's limit settings (when limits are on), and
    /// the geoms of the pairs that mix their geoms' values, in geom order.
    pub fn all(spec: &Spec) -> Vec<Param> {
        let constraint = spec.opt.contact_model == ContactModel::Constraint;
        let bodies =
            (1..spec.bodies.len()).flat_map(|b| [Param::Mass(b), Param::Com(b), Param::Inertia(b)]);
        let mut params: Vec<Param> = bodies.collect();
        for (j, joint) in spec.joints.iter().enumerate() {
            params.extend([Param::Damping(j), Param::Stiffness(j), Param::Armature(j)]);
            if constraint && spec.opt.solver.frictionloss && joint.frictionloss > 0.0 {
                params.push(Param::FrictionLoss(j));
            }
            if constraint && spec.opt.limits && joint.range.is_some() {
                params.extend([Param::LimitSolref(j), Param::LimitSolimp(j)]);
            }
        }
        if constraint {
            let mut geoms: Vec<usize> = collision_pairs(spec, &|_, _, x| x)
                .into_iter()
                .skip(spec.pairs.len())
                .flat_map(|(g, ..)| g)
                .collect();
            geoms.sort_unstable();
            geoms.dedup();
            let named = geoms
                .into_iter()
                .filter(|g| !spec.geoms[*g].name.is_empty());
            params.extend(named.flat_map(|g| {
                [
                    Param::GeomFriction(g),
                    Param::GeomSolref(g),
                    Param::GeomSolimp(g),
                ]
            }));
        } else if !contact_pairs(spec).is_empty() {
            params.extend(Param::CONTACT);
        }
        params
    }

    /// The three contact parameters.
    pub const CONTACT: [Param; 3] = [
        Param::ContactStiffness,
        Param::ContactDamping,
        Param::ContactFriction,
    ];

    /// Whether it is one of the smooth contact model's constants.
    pub fn is_contact(&self) -> bool {
        Param::CONTACT.contains(self)
    }

    /// Whether it belongs to the constraint contact model.
    pub fn is_constraint(&self) -> bool {
        matches!(
            self,
            Param::GeomFriction(_)
                | Param::GeomSolref(_)
                | Param::GeomSolimp(_)
                | Param::FrictionLoss(_)
                | Param::LimitSolref(_)
                | Param::LimitSolimp(_)
        )
    }

    pub fn name(&self, spec: &Spec) -> String {
        let body = |b: usize| &spec.bodies[b].name;
        let joint = |j: usize| &spec.joints[j].name;
        let geom = |g: usize| &spec.geoms[g].name;
        match *self {
            Param::Mass(b) => format!("body/{}/mass", body(b)),
            Param::Com(b) => format!("body/{}/com", body(b)),
            Param::Inertia(b) => format!("body/{}/inertia", body(b)),
            Param::Damping(j) => format!("joint/{}/damping", joint(j)),
            Param::Stiffness(j) => format!("joint/{}/stiffness", joint(j)),
            Param::Armature(j) => format!("joint/{}/armature", joint(j)),
            Param::ContactStiffness => "contact/stiffness".into(),
            Param::ContactDamping => "contact/damping".into(),
            Param::ContactFriction => "contact/friction".into(),
            Param::GeomFriction(g) => format!("geom/{}/friction", geom(g)),
            Param::GeomSolref(g) => format!("geom/{}/solref", geom(g)),
            Param::GeomSolimp(g) => format!("geom/{}/solimp", geom(g)),
            Param::FrictionLoss(j) => format!("joint/{}/frictionloss", joint(j)),
            Param::LimitSolref(j) => format!("joint/{}/solreflimit", joint(j)),
            Param::LimitSolimp(j) => format!("joint/{}/solimplimit", joint(j)),
        }
    }

    /// Number of scalar values.
    pub fn size(&self) -> usize {
        match self {
            Param::Com(_) | Param::GeomFriction(_) => 3,
            Param::Inertia(_) => 6,
            Param::GeomSolref(_) | Param::LimitSolref(_) => 2,
            Param::GeomSolimp(_) | Param::LimitSolimp(_) => 5,
            _ => 1,
        }
    }

    pub fn get(&self, spec: &Spec) -> Vec<f64> {
        match *self {
            Param::Mass(b) => vec![spec.bodies[b].mass],
            Param::Com(b) => spec.bodies[b].com.iter().copied().collect(),
            Param::Inertia(b) => inertia_to_six(&spec.bodies[b].inertia).to_vec(),
            Param::Damping(j) => vec![spec.joints[j].damping],
            Param::Stiffness(j) => vec![spec.joints[j].stiffness],
            Param::Armature(j) => vec![spec.joints[j].armature],
            Param::ContactStiffness => vec![spec.opt.soft.stiffness],
            Param::ContactDamping => vec![spec.opt.soft.damping],
            Param::ContactFriction => vec![spec.opt.soft.friction],
            Param::GeomFriction(g) => spec.geoms[g].friction.to_vec(),
            Param::GeomSolref(g) => spec.geoms[g].contact.sol.solref.to_vec(),
            Param::GeomSolimp(g) => spec.geoms[g].contact.sol.solimp.to_vec(),
            Param::FrictionLoss(j) => vec![spec.joints[j].frictionloss],
            Param::LimitSolref(j) => spec.joints[j].limit_sol.solref.to_vec(),
            Param::LimitSolimp(j) => spec.joints[j].limit_sol.solimp.to_vec(),
        }
    }

    /// Writes the value into the edit of its body or joint; the caller checks it.
    fn put(&self, edit: &mut Edit, value: &[f64]) {
        match *self {
            Param::Mass(b) => edit.body(b).mass = value[0],
            Param::Com(b) => edit.body(b).com = Vector3::from_column_slice(value),
            Param::Inertia(b) => {
                let body = edit.body(b);
                body.inertia = inertia_from_six(value);
                body.tensor = true;
            }
            Param::Damping(j) => edit.joint(j).passive[0] = value[0],
            Param::Stiffness(j) => edit.joint(j).passive[1] = value[0],
            Param::Armature(j) => edit.joint(j).passive[2] = value[0],
            Param::FrictionLoss(j) => edit.joint(j).passive[3] = value[0],
            Param::LimitSolref(j) => edit.joint(j).limit_sol.solref.copy_from_slice(value),
            Param::LimitSolimp(j) => edit.joint(j).limit_sol.solimp.copy_from_slice(value),
            Param::ContactStiffness => edit.contact().stiffness = value[0],
            Param::ContactDamping => edit.contact().damping = value[0],
            Param::ContactFriction => edit.contact().friction = value[0],
            Param::GeomFriction(g) => edit.geom(g).friction.copy_from_slice(value),
            Param::GeomSolref(g) => edit.geom(g).sol.solref.copy_from_slice(value),
            Param::GeomSolimp(g) => edit.geom(g).sol.solimp.copy_from_slice(value),
        }
    }

    fn check_value(&self, spec: &Spec, value: &[f64]) -> Result<(), ParamError> {
        if value.len() != self.size() {
            return Err(ParamError::Length {
                name: self.name(spec),
                got: value.len(),
                expected: self.size(),
            });
        }
        match value.iter().find(|x| !x.is_finite()) {
            Some(&bad) => Err(ParamError::NotFinite {
                name: self.name(spec),
                value: bad,
            }),
            None => Ok(()),
        }
    }
}

/// The six numbers (xx yy zz xy xz yz) of a symmetric tensor, read from its
/// upper triangle: the order of parameters, MJCF `fullinertia` and URDF
/// `<inertia>`.
pub fn inertia_to_six(i: &Matrix3<f64>) -> [f64; 6] {
    [
        i[(0, 0)],
        i[(1, 1)],
        i[(2, 2)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 2)],
    ]
}

/// The symmetric tensor of six numbers (xx yy zz xy xz yz).
pub fn inertia_from_six(v: &[f64]) -> Matrix3<f64> {
    Matrix3::new(v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2])
}

impl Model {
    /// Names of every identifiable parameter (see [`Param`]).
    pub fn param_names(&self) -> Vec<String> {
        Param::all(self).iter().map(|p| p.name(self)).collect()
    }

    pub fn param(&self, name: &str) -> Result<Param, ParamError> {
        Param::parse(self, name)
    }

    pub fn get_param(&self, name: &str) -> Result<Vec<f64>, ParamError> {
        Ok(self.param(name)?.get(self))
    }

    /// Sets a parameter; a value that makes the model non-physical is an error
    /// and leaves the model unchanged.
    pub fn set_param(&mut self, name: &str, value: &[f64]) -> Result<(), ParamError> {
        let param = self.param(name)?;
        self.set(&[(param, value)])
    }

    /// Sets several resolved parameters at once. The new values are checked
    /// before anything changes, so a failed edit leaves the model as it was;
    /// then the description is written and the dynamics tree patched where
    /// the edit reaches (see [`Model::patch_tree`]).
    pub fn set(&mut self, values: &[(Param, &[f64])]) -> Result<(), ParamError> {
        for (p, v) in values {
            p.check_value(self, v)?;
        }
        let mut edit = Edit {
            spec: &self.spec,
            bodies: vec![],
            joints: vec![],
            geoms: vec![],
            contact: None,
        };
        for (p, v) in values {
            p.put(&mut edit, v);
        }
        let Edit {
            bodies,
            joints,
            geoms,
            contact,
            ..
        } = edit;
        let checked = match &contact {
            Some(soft) => check_soft(soft),
            None => Ok(()),
        };
        if let Err(source) = checked.and_then(|_| self.check_edit(&bodies, &joints, &geoms)) {
            return Err(not_physical(self, values, source));
        }
        let old = self.write_edit(&bodies, &joints, &geoms);
        if let Err(source) = check_tree_inertia(self, &self.tree, bodies.iter().map(|b| b.index)) {
            // Writing the old values back restores the tree bit for bit.
            self.write_edit(&old.0, &old.1, &old.2);
            return Err(not_physical(self, values, source));
        }
        if let Some(soft) = contact {
            self.spec.opt.soft = soft;
            let s = &mut self.tree.soft;
            (s.stiffness, s.damping, s.friction) = (soft.stiffness, soft.damping, soft.friction);
        }
        self.restamp();
        Ok(())
    }

    /// Writes the edited values into the description, patches the tree, and
    /// returns the values they replaced.
    fn write_edit(
        &mut self,
        bodies: &[BodyEdit],
        joints: &[JointEdit],
        geoms: &[GeomEdit],
    ) -> (Vec<BodyEdit>, Vec<JointEdit>, Vec<GeomEdit>) {
        let mut old = (vec![], vec![], vec![]);
        for b in bodies {
            let body = &mut self.spec.bodies[b.index];
            old.0.push(BodyEdit {
                index: b.index,
                mass: body.mass,
                com: body.com,
                inertia: body.inertia,
                tensor: b.tensor,
            });
            (body.mass, body.com, body.inertia) = (b.mass, b.com, b.inertia);
        }
        for j in joints {
            let joint = &mut self.spec.joints[j.index];
            old.1.push(JointEdit::of(j.index, joint));
            [
                joint.damping,
                joint.stiffness,
                joint.armature,
                joint.frictionloss,
            ] = j.passive;
            joint.limit_sol = j.limit_sol;
        }
        for g in geoms {
            let geom = &mut self.spec.geoms[g.index];
            old.2.push(GeomEdit::of(g.index, geom));
            (geom.friction, geom.contact.sol) = (g.friction, g.sol);
        }
        let constraint = !geoms.is_empty() || joints.iter().any(|j| j.constraint(&old.1));
        if constraint && self.tree.contact_model == ContactModel::Constraint {
            // Contact settings reach the pairs' mixed values: rebuilt whole.
            self.tree = Tree::build(&self.spec);
        } else {
            self.patch_tree(
                bodies.iter().map(|b| b.index),
                joints.iter().map(|j| j.index),
            );
        }
        old
    }

    /// The checks of a valid model on the edited values (already finite).
    /// The full checks run only where an edit can fail them: a body whose
    /// tensor changed or whose mass went negative (a valid tensor stays
    /// valid under any mass >= 0 and COM), a joint with a negative value or
    /// new limit settings, every edited geom.
    fn check_edit(
        &self,
        bodies: &[BodyEdit],
        joints: &[JointEdit],
        geoms: &[GeomEdit],
    ) -> Result<(), ModelError> {
        for b in bodies.iter().filter(|b| b.tensor || b.mass < 0.0) {
            let name = &self.spec.bodies[b.index].name;
            check_inertial(name, b.mass, &b.com, &b.inertia)?;
        }
        for j in joints {
            let mut joint = self.spec.joints[j.index].clone();
            if j.passive.iter().any(|x| *x < 0.0) {
                [
                    joint.damping,
                    joint.stiffness,
                    joint.armature,
                    joint.frictionloss,
                ] = j.passive;
                check_passive(&joint)?;
            }
            if j.limit_sol != joint.limit_sol {
                let owner = format!("joint '{}'", joint.name);
                j.limit_sol.check(&owner).map_err(ModelError::NotPhysical)?;
            }
        }
        for g in geoms {
            let owner = format!("geom '{}'", self.spec.geoms[g.index].name);
            check_friction(&g.friction, &owner)
                .and_then(|()| g.sol.check(&owner))
                .map_err(ModelError::NotPhysical)?;
        }
        Ok(())
    }
    /// Brings the tree up to date after edits of the inertial values of
    /// `bodies` and the passive values of `joints`: each node carrying an
    /// edited body sums its bodies' inertias again, in body order from zero
    /// as [`Tree::build`] does, so the result equals a rebuilt tree bit for
    /// bit; an edited joint's nodes (one per dof) take its damping,
    /// stiffness and armature.
    fn patch_tree(
        &mut self,
        bodies: impl Iterator<Item = usize>,
        joints: impl Iterator<Item = usize>,
    ) {
        let tree = &mut self.tree;
        let mut done: Vec<usize> = vec![];
        for node in bodies.filter_map(|b| tree.body[b].node) {
            if done.contains(&node) {
                continue;
            }
            done.push(node);
            let mut sum = Inertia::zero();
            for (k, frame) in tree.body.iter().enumerate().skip(1) {
                if frame.node == Some(node) {
                    let own = body_inertia(k, &self.spec.bodies[k], |_, _, x| x);
                    sum += own.to_source(&frame.offset);
                }
            }
            tree.inertia[node] = sum;
        }
        for k in joints {
            let j = &self.spec.joints[k];
            for node in (0..tree.nv()).filter(|i| tree.node_joint[*i] == k) {
                tree.damping[node] = j.damping;
                tree.stiffness[node] = j.stiffness;
                tree.armature[node] = j.armature;
            }
        }
        // The fluid's equivalent boxes follow the masses and inertias.
        tree.fluid = fluid_bodies(&self.spec, &tree.body_frames(), &|_, _, x| x);
        if tree.contact_model == ContactModel::Constraint {
            // MuJoCo's mj_setConst after an edit of inertial values.
            let (body, dof) = invweight0(tree, &self.spec, &|_, _, x| x);
            (
                tree.constraint.body_invweight,
                tree.constraint.dof_invweight,
            ) = (body, dof);
        }
    }
}

/// The error of an edit of `values` that `source` refused.
fn not_physical(spec: &Spec, values: &[(Param, &[f64])], source: ModelError) -> ParamError {
    ParamError::NotPhysical {
        name: values
            .iter()
            .map(|(p, _)| p.name(spec))
            .collect::<Vec<_>>()
            .join(", "),
        value: values.iter().flat_map(|(_, v)| v.iter().copied()).collect(),
        source: Box::new(source),
    }
}

/// The new inertial values of a body an edit touches, and whether its
/// inertia tensor is among them.
struct BodyEdit {
    index: usize,
    mass: f64,
    com: Vector3<f64>,
    inertia: Matrix3<f64>,
    tensor: bool,
}

/// The new damping, stiffness, armature, frictionloss and limit settings
/// of a joint an edit touches.
struct JointEdit {
    index: usize,
    passive: [f64; 4],
    limit_sol: SolParams,
}

impl JointEdit {
    fn of(index: usize, j: &Joint) -> Self {
        JointEdit {
            index,
            passive: [j.damping, j.stiffness, j.armature, j.frictionloss],
            limit_sol: j.limit_sol,
        }
    }

    /// Whether it changes the constraint model's values from `old`'s.
    fn constraint(&self, old: &[JointEdit]) -> bool {
        old.iter().any(|o| {
            o.index == self.index
                && (o.passive[3] != self.passive[3] || o.limit_sol != self.limit_sol)
        })
    }
}

/// The new contact settings of a geom an edit touches.
struct GeomEdit {
    index: usize,
    friction: [f64; 3],
    sol: SolParams,
}

impl GeomEdit {
    fn of(index: usize, g: &Geom) -> Self {
        GeomEdit {
            index,
            friction: g.friction,
            sol: g.contact.sol,
        }
    }
}

/// The bodies, joints and geoms an edit touches, each taken from the model
/// on first touch, and the soft-contact constants if it touches them.
struct Edit<'a> {
    spec: &'a Spec,
    bodies: Vec<BodyEdit>,
    joints: Vec<JointEdit>,
    geoms: Vec<GeomEdit>,
    contact: Option<SoftOptions>,
}

impl Edit<'_> {
    fn contact(&mut self) -> &mut SoftOptions {
        self.contact.get_or_insert(self.spec.opt.soft)
    }

    fn body(&mut self, b: usize) -> &mut BodyEdit {
        let body = &self.spec.bodies[b];
        touched(
            &mut self.bodies,
            |e| e.index == b,
            || BodyEdit {
                index: b,
                mass: body.mass,
                com: body.com,
                inertia: body.inertia,
                tensor: false,
            },
        )
    }

    fn joint(&mut self, j: usize) -> &mut JointEdit {
        let joint = &self.spec.joints[j];
        touched(
            &mut self.joints,
            |e| e.index == j,
            || JointEdit::of(j, joint),
        )
    }

    fn geom(&mut self, g: usize) -> &mut GeomEdit {
        let geom = &self.spec.geoms[g];
        touched(&mut self.geoms, |e| e.index == g, || GeomEdit::of(g, geom))
    }
}

/// The entry of `edits` that `is` finds, pushed from `first` on first touch.
fn touched<E>(edits: &mut Vec<E>, is: impl Fn(&E) -> bool, first: impl FnOnce() -> E) -> &mut E {
    let k = match edits.iter().position(is) {
        Some(k) => k,
        None => {
            edits.push(first());
            edits.len() - 1
        }
    };
    &mut edits[k]
}

/// One target of a [`ParamMap`]: parameter `name` = offset + gain mu, with
/// one gain row of nmu values per scalar of the parameter.
#[derive(Clone, Copy, Debug)]
pub struct MapEntry<'a> {
    pub name: &'a str,
    pub offset: &'a [f64],
    pub gain: &'a [&'a [f64]],
}

/// An affine map from a task's mu (length `nmu`) onto named parameters:
/// p_k = offset_k + gain_k mu for each target parameter k.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamMap {
    pub nmu: usize,
    pub targets: Vec<(Param, DVector<f64>, DMatrix<f64>)>,
}

impl ParamMap {
    /// Builds a map from its entries.
    pub fn new(model: &Model, nmu: usize, entries: &[MapEntry]) -> Result<ParamMap, ParamError> {
        let mut targets = vec![];
        for MapEntry { name, offset, gain } in entries {
            let p = model.param(name)?;
            p.check_value(model, offset)?;
            if gain.len() != p.size() || gain.iter().any(|row| row.len() != nmu) {
                return Err(ParamError::Map(format!(
                    "gain of '{name}' must be {} rows of {nmu} values",
                    p.size()
                )));
            }
            if let Some(bad) = gain.iter().flat_map(|r| r.iter()).find(|x| !x.is_finite()) {
                return Err(ParamError::Map(format!(
                    "gain of '{name}' holds {bad}: gains must be finite"
                )));
            }
            let rows: Vec<f64> = gain.iter().flat_map(|r| r.iter().copied()).collect();
            targets.push((
                p,
                DVector::from_column_slice(offset),
                DMatrix::from_row_slice(p.size(), nmu, &rows),
            ));
        }
        Ok(ParamMap { nmu, targets })
    }

    /// The map whose mu is the named parameters flattened in order:
    /// parameter k's scalar i is mu[offset_k + i], offset_k the sizes before it.
    pub fn identity<S: AsRef<str>>(model: &Model, names: &[S]) -> Result<ParamMap, ParamError> {
        let sizes = names
            .iter()
            .map(|n| model.param(n.as_ref()).map(|p| p.size()))
            .collect::<Result<Vec<_>, _>>()?;
        let nmu: usize = sizes.iter().sum();
        let mut targets = vec![];
        let mut k = 0;
        for (name, size) in names.iter().zip(sizes) {
            let p = model.param(name.as_ref())?;
            let gain = DMatrix::from_fn(size, nmu, |r, c| f64::from(u8::from(c == k + r)));
            targets.push((p, DVector::zeros(size), gain));
            k += size;
        }
        Ok(ParamMap { nmu, targets })
    }

    /// The parameters' values at mu, in target order.
    pub fn values(&self, mu: &[f64]) -> Vec<DVector<f64>> {
        let mu = DVector::from_column_slice(mu);
        self.targets
            .iter()
            .map(|(_, offset, gain)| offset + gain * &mu)
            .collect()
    }

    /// The same values flattened into one vector (one allocation).
    fn flat_values(&self, mu: &[f64]) -> Vec<f64> {
        let mut values = Vec::with_capacity(self.targets.iter().map(|(p, ..)| p.size()).sum());
        for (_, offset, gain) in &self.targets {
            for (r, o) in offset.iter().enumerate() {
                let moved: f64 = mu.iter().enumerate().map(|(j, m)| gain[(r, j)] * m).sum();
                values.push(o + moved);
            }
        }
        values
    }

    /// Sets the model's parameters to their values at mu.
    pub fn apply(&self, model: &mut Model, mu: &[f64]) -> Result<(), ParamError> {
        if mu.len() != self.nmu {
            return Err(ParamError::Map(format!(
                "mu has {} values, the map takes {}",
                mu.len(),
                self.nmu
            )));
        }
        if let Some(bad) = mu.iter().find(|x| !x.is_finite()) {
            return Err(ParamError::Map(format!("mu value {bad} is not finite")));
        }
        let values = self.flat_values(mu);
        let mut rest = &values[..];
        let pairs: Vec<(Param, &[f64])> = self
            .targets
            .iter()
            .map(|(p, ..)| {
                let (value, tail) = rest.split_at(p.size());
                rest = tail;
                (*p, value)
            })
            .collect();
        model.set(&pairs)
    }

    /// d(flattened parameters)/d(mu): the stacked gains.
    pub fn jacobian(&self) -> DMatrix<f64> {
        let rows: usize = self.targets.iter().map(|(p, ..)| p.size()).sum();
        let mut j = DMatrix::zeros(rows, self.nmu);
        let mut r = 0;
        for (p, _, gain) in &self.targets {
            j.rows_mut(r, p.size()).copy_from(gain);
            r += p.size();
        }
        j
    }

    pub fn params(&self) -> Vec<Param> {
        self.targets.iter().map(|(p, ..)| *p).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cartpole() -> Model {
        Model::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/cartpole.xml"
        ))
        .unwrap()
    }

    #[test]
    fn names_resolve_and_round_trip() {
        let model = cartpole();
        let names = model.param_names();
        assert_eq!(names.len(), 2 * 3 + 2 * 3);
        for name in &names {
            let p = model.param(name).unwrap();
            assert_eq!(&p.name(&model), name);
            assert_eq!(model.get_param(name).unwrap().len(), p.size());
        }
        assert_eq!(
            model.get_param("body/pole/com").unwrap(),
            vec![0.0, 0.0, 0.5]
        );
    }

    #[test]
    fn mass_and_com_edits_keep_the_inertia_about_the_com() {
        let mut model = cartpole();
        let before = model.get_param("body/pole/inertia").unwrap();
        model.set_param("body/pole/mass", &[0.3]).unwrap();
        model.set_param("body/pole/com", &[0.2, 0.0, 0.54]).unwrap();
        assert_eq!(model.get_param("body/pole/inertia").unwrap(), before);
        assert_eq!(model.get_param("body/pole/mass").unwrap(), vec![0.3]);
        // The dynamics see the edit: the tree was rebuilt.
        let fresh = Model::from_spec((*model).clone()).unwrap();
        assert_eq!(fresh.tree(), model.tree());
    }

    #[test]
    fn bad_names_and_values_are_clear_errors() {
        let mut model = cartpole();
        let err = |r: Result<(), ParamError>| r.unwrap_err().to_string();
        assert_eq!(
            err(model.set_param("body/pol/mass", &[1.0])),
            "unknown parameter 'body/pol/mass': no body named 'pol'"
        );
        assert_eq!(
            err(model.set_param("joint/hinge/friction", &[1.0])),
            "unknown parameter 'joint/hinge/friction': joint fields are damping, stiffness, \
             armature, frictionloss, solreflimit, solimplimit"
        );
        assert_eq!(
            err(model.set_param("body/pole/com", &[1.0])),
            "parameter 'body/pole/com' takes 3 values, got 1"
        );
        assert_eq!(
            err(model.set_param("joint/hinge/damping", &[f64::NAN])),
            "parameter 'joint/hinge/damping' value NaN is not finite"
        );
        let e = err(model.set_param("body/pole/mass", &[-1.0]));
        assert!(
            e.contains("'body/pole/mass' = [-1.0] is not physical") && e.contains("mass"),
            "{e}"
        );
        // Principal moments 1, 1, 3 violate the triangle inequality.
        let e = err(model.set_param("body/pole/inertia", &[1.0, 1.0, 3.0, 0.0, 0.0, 0.0]));
        assert!(e.contains("triangle inequality"), "{e}");
        let e = err(model.set_param("body/pole/inertia", &[1.0, 1.0, 1.0, 2.0, 0.0, 0.0]));
        assert!(e.contains("positive semi-definite"), "{e}");
        // A failed edit leaves the model as it was.
        assert_eq!(model.get_param("body/pole/mass").unwrap(), vec![0.1]);
    }

    #[test]
    fn contact_parameters_follow_the_contact_model() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/half_cheetah.xml"
        );
        let mut model = Model::load(path).unwrap();
        let names = model.param_names();
        for name in [
            "joint/bthigh/solreflimit",
            "joint/bthigh/solimplimit",
            "geom/floor/friction",
            "geom/floor/solref",
            "geom/ffoot/solimp",
        ] {
            assert!(names.iter().any(|n| n == name), "{name} not listed");
        }
        assert!(!names.iter().any(|n| n.starts_with("contact/")));
        model
            .set_param("geom/floor/friction", &[0.7, 0.01, 0.001])
            .unwrap();
        model.set_param("geom/floor/solref", &[0.03, 0.9]).unwrap();
        model
            .set_param("joint/bthigh/frictionloss", &[0.2])
            .unwrap();
        model
            .set_param("joint/bthigh/solimplimit", &[0.8, 0.9, 0.01, 0.4, 3.0])
            .unwrap();
        assert_eq!(model.get_param("geom/floor/solref").unwrap(), [0.03, 0.9]);
        // The tree sees the edits: it equals one built from the edited file.
        let fresh = Model::from_spec((*model).clone()).unwrap();
        assert_eq!(fresh.tree(), model.tree());
        // MuJoCo's compiler's checks; a refused edit changes nothing.
        let before = model.clone();
        let err = |m: &mut Model, name: &str, value: &[f64]| {
            m.set_param(name, value).unwrap_err().to_string()
        };
        let e = err(&mut model, "geom/floor/friction", &[-0.1, 0.0, 0.0]);
        assert!(
            e.contains("geom 'floor': friction") && e.contains(">= 0"),
            "{e}"
        );
        let e = err(&mut model, "geom/floor/solref", &[0.02, -1.0]);
        assert!(
            e.contains("solref [0.02, -1.0] must be two positive"),
            "{e}"
        );
        let e = err(
            &mut model,
            "joint/bthigh/solimplimit",
            &[1.2, 0.9, 0.01, 0.5, 2.0],
        );
        assert!(e.contains("joint 'bthigh': solimp"), "{e}");
        let e = err(&mut model, "joint/bthigh/frictionloss", &[-1.0]);
        assert!(e.contains("frictionloss must be finite and >= 0"), "{e}");
        assert_eq!(model.tree(), before.tree());
        assert_eq!(*model, *before);
        // Each model's contact parameters, and only those.
        let e = err(&mut model, "contact/stiffness", &[1.0]);
        assert!(e.contains("runs the constraint contact model"), "{e}");
        let mut smooth = model
            .edited(|s| s.opt.contact_model = ContactModel::Smooth)
            .unwrap();
        let e = err(&mut smooth, "geom/floor/friction", &[1.0, 0.0, 0.0]);
        assert!(e.contains("runs the smooth contact model"), "{e}");
        assert!(smooth.param_names().iter().all(|n| !n.starts_with("geom/")));
    }

    #[test]
    fn the_cartpole_mu_map_moves_the_pole_com() {
        let mut model = cartpole();
        let map = ParamMap::new(
            &model,
            1,
            &[MapEntry {
                name: "body/pole/com",
                offset: &[0.0, 0.0, 0.5],
                gain: &[&[1.0], &[0.0], &[0.2]],
            }],
        )
        .unwrap();
        map.apply(&mut model, &[0.3]).unwrap();
        let com = model.get_param("body/pole/com").unwrap();
        assert!((com[0] - 0.3).abs() < 1e-15 && com[1] == 0.0 && (com[2] - 0.56).abs() < 1e-15);
        assert_eq!(map.jacobian().as_slice(), &[1.0, 0.0, 0.2]);
        assert!(map.apply(&mut model, &[0.1, 0.2]).is_err());
    }
}
