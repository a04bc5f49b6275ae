//! Editing a compiled model's named parameters ([`crate::model::params`]):
//! values are checked before anything changes, written into the spec, and
//! the tree recompiled where the edit reaches: a body's node inertia and a
//! joint's passive values patched, the derived constants (invweight0, the
//! fluid's boxes) recomputed, or the whole tree rebuilt when contact
//! settings reach the pairs' mixed values; the result equals a fresh compile
//! bit for bit.

use nalgebra::{Matrix3, Vector3};

use super::fluid::fluid_bodies;
use super::gravcomp::gravcomp_bodies;
use super::invweight::invweight0;
use super::tree::free_bodies;
use super::{body_inertia, check_tree_inertia, Model};
use crate::dynamics::Tree;
use crate::model::constraint::check_friction;
use crate::model::params::inertia_from_six;
use crate::model::{
    check_inertial, check_passive, check_soft, Bias, ContactModel, Gain, Geom, Joint, ModelError,
    Param, ParamError, ParamMap, SoftOptions, SolParams, Spec, Tendon,
};
use crate::spatial::Inertia;

impl Param {
    /// Every identifiable parameter of a model (its compiled pairs tell which
    /// geoms and contact constants count), bodies first, in model order,
    /// then the joints', then the contact model's: the smooth model's three
    /// if it has contact pairs; the constraint model's dry friction where a
    /// joint has some (at 0 its rows vanish, and so does its derivative),
    /// each limited joint's limit settings (when limits are on), and
    /// the geoms of the pairs that mix their geoms' values, in geom order.
    pub fn all(model: &Model) -> Vec<Param> {
        let (spec, tree) = (&model.spec, &model.tree);
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
            let mut geoms: Vec<usize> = tree.constraint.pairs[spec.pairs.len()..]
                .iter()
                .flat_map(|p| p.geoms.map(|g| tree.geoms[g].geom))
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
        } else if !tree.pairs.is_empty() {
            params.extend(Param::CONTACT);
        }
        params
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
            Param::EqualitySolref(e) => edit.equality(e).1.solref.copy_from_slice(value),
            Param::EqualitySolimp(e) => edit.equality(e).1.solimp.copy_from_slice(value),
            Param::ActuatorGain(a) => edit.actuator(a).gain.copy_from_slice(value),
            Param::ActuatorBias(a) => edit.actuator(a).bias.copy_from_slice(value),
            Param::TendonStiffness(t) => edit.tendon(t).stiffness = value[0],
            Param::TendonDamping(t) => edit.tendon(t).damping = value[0],
            Param::TendonFrictionLoss(t) => edit.tendon(t).frictionloss = value[0],
            Param::TendonSpringlength(t) => {
                edit.tendon(t).springlength = Some([value[0], value[1]])
            }
        }
    }
}

impl Model {
    /// Names of every identifiable parameter (see [`Param`]).
    pub fn param_names(&self) -> Vec<String> {
        Param::all(self).iter().map(|p| p.name(self)).collect()
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
    /// the edit reaches (see `patch_tree`).
    pub fn set(&mut self, values: &[(Param, &[f64])]) -> Result<(), ParamError> {
        for (p, v) in values {
            p.check_value(self, v)?;
        }
        let mut edit = Edit {
            spec: &self.spec,
            bodies: vec![],
            joints: vec![],
            geoms: vec![],
            actuators: vec![],
            equalities: vec![],
            tendons: vec![],
            contact: None,
        };
        for (p, v) in values {
            p.put(&mut edit, v);
        }
        let Edit {
            bodies,
            joints,
            geoms,
            actuators,
            equalities,
            tendons,
            contact,
            ..
        } = edit;
        let checked = match &contact {
            Some(soft) => check_soft(soft),
            None => Ok(()),
        };
        let checked = checked.and_then(|_| self.check_laws(&actuators, &equalities));
        let checked = checked.and_then(|_| {
            let joints = &self.spec.joints;
            let bad = tendons.iter().find_map(|(_, t)| t.check(joints).err());
            bad.map_or(Ok(()), |why| Err(ModelError::NotPhysical(why)))
        });
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
            (self.spec.opt.soft, self.tree.opt.soft) = (soft, soft);
            let s = &mut self.tree.soft;
            (s.stiffness, s.damping, s.friction) = (soft.stiffness, soft.damping, soft.friction);
        }
        self.write_laws(&actuators, &equalities);
        if !tendons.is_empty() {
            for (t, tendon) in tendons {
                self.spec.tendons[t] = tendon;
            }
            self.tree = Tree::build(&self.spec);
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
        if constraint && self.tree.opt.contact_model == ContactModel::Constraint {
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

    /// Checks edited actuator and equality values (already finite): a fixed
    /// gain reads gainprm[0] alone, so its other two must stay 0; a bias
    /// with biasprm[1] = -gainprm[0] and biasprm[2] > 0 would read as a
    /// damping ratio on the next compile ([`crate::model::Bias`]); an
    /// equality's solref and solimp as MuJoCo's compiler checks them.
    fn check_laws(
        &self,
        actuators: &[ActuatorEdit],
        equalities: &[(usize, SolParams)],
    ) -> Result<(), ModelError> {
        for a in actuators {
            let name = &self.spec.actuators[a.index].name;
            let fixed = matches!(self.spec.actuators[a.index].gain, Gain::Fixed(_));
            if fixed && (a.gain[1] != 0.0 || a.gain[2] != 0.0) {
                return Err(ModelError::NotPhysical(format!(
                    "actuator '{name}': a fixed gain (gaintype fixed) reads gainprm[0] only; \
                     gain {:?} must end in two zeros",
                    a.gain
                )));
            }
            let has_bias = self.spec.actuators[a.index].bias != Bias::None;
            if has_bias && a.bias[1] == -a.gain[0] && a.bias[2] > 0.0 {
                return Err(ModelError::NotPhysical(format!(
                    "actuator '{name}': bias {:?} with bias[1] = -gain[0] and bias[2] > 0 \
                     reads as a damping ratio (dampratio); give the damping as bias[2] <= 0",
                    a.bias
                )));
            }
        }
        for (e, sol) in equalities {
            let owner = format!("equality '{}'", self.spec.equalities[*e].name);
            sol.check(&owner).map_err(ModelError::NotPhysical)?;
        }
        Ok(())
    }

    /// Writes edited actuator laws and equality settings into the
    /// description and the tree: the actuators' terms compiled again, the
    /// tree rebuilt whole for an equality (its rows' constants).
    fn write_laws(&mut self, actuators: &[ActuatorEdit], equalities: &[(usize, SolParams)]) {
        for a in actuators {
            let law = &mut self.spec.actuators[a.index];
            law.gain = match law.gain {
                Gain::Fixed(_) => Gain::Fixed(a.gain[0]),
                Gain::Affine(_) => Gain::Affine(a.gain),
            };
            if law.bias != Bias::None {
                law.bias = Bias::Affine(a.bias);
            }
        }
        for (e, sol) in equalities {
            self.spec.equalities[*e].sol = *sol;
        }
        if !equalities.is_empty() {
            self.tree = Tree::build(&self.spec);
        } else if !actuators.is_empty() {
            self.tree.actuators = super::tree::actuator_terms(&self.spec);
        }
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
            let rule = self.spec.inertia_rule;
            check_inertial(name, b.mass, &b.com, &b.inertia, rule)?;
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
    /// stiffness and armature (with its actuators', [`Spec::actuator_passive`]).
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
            let (damping, armature) = self.spec.actuator_passive(k);
            for node in (0..tree.nv()).filter(|i| tree.node_joint[*i] == k) {
                tree.damping[node] = j.damping + damping;
                tree.stiffness[node] = j.stiffness;
                tree.armature[node] = j.armature + armature;
            }
        }
        // The fluid's equivalent boxes follow the masses and inertias.
        tree.fluid = fluid_bodies(&self.spec, &tree.body_frames(), &|_, _, x| x);
        tree.gravcomp = gravcomp_bodies(&self.spec, &tree.body_frames(), &|_, _, x| x);
        tree.free_bodies = free_bodies(&self.spec, &tree.body_frames());
        if tree.opt.contact_model == ContactModel::Constraint {
            // MuJoCo's mj_setConst after an edit of inertial values.
            let constants = invweight0(tree, &self.spec, &|_, _, x| x);
            let c = &mut tree.constraint;
            (c.body_invweight, c.dof_invweight, c.mean_inertia) = constants;
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

/// The new gainprm[0..3] and biasprm[0..3] of an actuator an edit touches
/// (as [`Param::get`] reads them).
struct ActuatorEdit {
    index: usize,
    gain: [f64; 3],
    bias: [f64; 3],
}

/// The bodies, joints, geoms, actuators, equalities (index, solver
/// settings) and tendons (index, edited copy) an edit touches, each taken
/// from the model on first touch, and the soft-contact constants if it
/// touches them.
struct Edit<'a> {
    spec: &'a Spec,
    bodies: Vec<BodyEdit>,
    joints: Vec<JointEdit>,
    geoms: Vec<GeomEdit>,
    actuators: Vec<ActuatorEdit>,
    equalities: Vec<(usize, SolParams)>,
    tendons: Vec<(usize, Tendon)>,
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

    fn actuator(&mut self, a: usize) -> &mut ActuatorEdit {
        let spec = self.spec;
        let read = |p: Param| -> [f64; 3] { p.get(spec).try_into().expect("3 values") };
        touched(
            &mut self.actuators,
            |e| e.index == a,
            || ActuatorEdit {
                index: a,
                gain: read(Param::ActuatorGain(a)),
                bias: read(Param::ActuatorBias(a)),
            },
        )
    }

    fn equality(&mut self, e: usize) -> &mut (usize, SolParams) {
        let sol = self.spec.equalities[e].sol;
        touched(&mut self.equalities, |x| x.0 == e, || (e, sol))
    }

    fn tendon(&mut self, t: usize) -> &mut Tendon {
        let tendon = &self.spec.tendons[t];
        &mut touched(&mut self.tendons, |x| x.0 == t, || (t, tendon.clone())).1
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

impl ParamMap {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MapEntry;

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

    /// Actuator and equality edits reach the tree as a fresh compile of
    /// the edited description would (bit for bit), and a refused one
    /// changes nothing.
    #[test]
    fn actuator_and_equality_edits_equal_a_fresh_compile() {
        let dir = env!("CARGO_MANIFEST_DIR");
        let mut model = Model::load(format!("{dir}/tests/data/servo_arm.xml")).unwrap();
        model
            .set_param("actuator/servo/bias", &[0.2, -30.0, -2.0])
            .unwrap();
        model
            .set_param("actuator/push/gain", &[1.0, 0.5, 0.0])
            .unwrap();
        assert_eq!(model.actuators[0].bias, Bias::Affine([0.2, -30.0, -2.0]));
        let fresh = Model::from_spec((*model).clone()).unwrap();
        assert_eq!(fresh.tree(), model.tree());
        let before = model.clone();
        assert!(model
            .set_param("actuator/servo/gain", &[30.0, 0.0, 1.0])
            .is_err());
        assert_eq!(*model, *before);
        let mut model = Model::load(format!("{dir}/tests/data/equality_fourbar.xml")).unwrap();
        model
            .set_param("equality/close/solimp", &[0.8, 0.9, 0.01, 0.4, 3.0])
            .unwrap();
        model
            .set_param("equality/close/solref", &[0.01, 0.5])
            .unwrap();
        assert_eq!(model.equalities[0].sol.solref, [0.01, 0.5]);
        let fresh = Model::from_spec((*model).clone()).unwrap();
        assert_eq!(fresh.tree(), model.tree());
    }

    #[test]
    fn a_soft_contact_edit_reaches_the_tree_options() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/half_cheetah.xml"
        );
        let mut model = Model::load(path)
            .and_then(|m| m.edited(|s| s.opt.contact_model = ContactModel::Smooth))
            .unwrap();
        let stiffness = model.opt.soft.stiffness * 2.0;
        model.set_param("contact/stiffness", &[stiffness]).unwrap();
        assert_eq!(model.opt.soft.stiffness, stiffness);
        assert_eq!(model.tree().opt, model.opt);
        let fresh = Model::from_spec((*model).clone()).unwrap();
        assert_eq!(fresh.tree(), model.tree());
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
