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
//! - `equality/<name>/solref` (2 values) and `equality/<name>/solimp` (5
//!   values): the equality's MuJoCo eq_solref and eq_solimp, checked as
//!   MuJoCo's compiler checks them.
//! - `actuator/<name>/gain` (3 values): MuJoCo's gainprm[0..3], the
//!   constant, length and velocity coefficients of the gain (a fixed gain
//!   reads gainprm\[0] only; its other two stay 0); `actuator/<name>/bias`
//!   (3 values): biasprm[0..3], an affine bias's (an actuator without bias
//!   has no such parameter). A position servo's kp is gain\[0] = -bias\[1]
//!   and its kv is -bias\[2]; a velocity servo's kv is gain\[0] = -bias\[2]:
//!   move kp or kv through a [`ParamMap`] that writes both entries.
//!   MuJoCo's forces are linear in them, read at the actuator's length
//!   and velocity (gear times the joint's or the tendon's).
//! - `tendon/<name>/stiffness` (N/m), `damping` (N s/m), `frictionloss`
//!   (N; constraint model) and `springlength` (2 values, m: the spring's
//!   deadband lo, hi), MuJoCo's tendon_stiffness, tendon_damping,
//!   tendon_frictionloss and tendon_lengthspring. A tendon whose
//!   springlength is MuJoCo's -1 -1 (its length at qpos_spring) has no
//!   `springlength` parameter: give the deadband explicitly.
//!
//! Equality, actuator and tendon parameters resolve by name but are not listed by
//! [`Param::all`] (its list feeds the gradient checks of every shipped model).

use nalgebra::{DMatrix, DVector, Matrix3};

use super::{Bias, ContactModel, Gain, ModelError, Spec};

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
    EqualitySolref(usize),
    EqualitySolimp(usize),
    ActuatorGain(usize),
    ActuatorBias(usize),
    TendonStiffness(usize),
    TendonDamping(usize),
    TendonFrictionLoss(usize),
    TendonSpringlength(usize),
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
                        geom/<name>/<field>, equality/<name>/<field>, \
                        actuator/<name>/<field>, tendon/<name>/<field> or contact/<field>)";
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
        // The index of the element of `kind` named `object` (unnamed ones never match).
        let named = |mut names: &mut dyn Iterator<Item = &String>| {
            Iterator::position(&mut names, |n| !n.is_empty() && n == object)
                .ok_or_else(|| unknown(format!(": no {kind} named '{object}'")))
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
                let g = named(&mut spec.geoms.iter().map(|x| &x.name))?;
                match field {
                    "friction" => Ok(Param::GeomFriction(g)),
                    "solref" => Ok(Param::GeomSolref(g)),
                    "solimp" => Ok(Param::GeomSolimp(g)),
                    _ => Err(unknown(": geom fields are friction, solref, solimp".into())),
                }
            }
            "equality" => {
                let e = named(&mut spec.equalities.iter().map(|x| &x.name))?;
                match field {
                    "solref" => Ok(Param::EqualitySolref(e)),
                    "solimp" => Ok(Param::EqualitySolimp(e)),
                    _ => Err(unknown(": equality fields are solref, solimp".into())),
                }
            }
            "actuator" => {
                let a = named(&mut spec.actuators.iter().map(|x| &x.name))?;
                match field {
                    "gain" => Ok(Param::ActuatorGain(a)),
                    "bias" if spec.actuators[a].bias == Bias::None => Err(unknown(format!(
                        ": actuator '{object}' has no bias (biastype none)"
                    ))),
                    "bias" => Ok(Param::ActuatorBias(a)),
                    _ => Err(unknown(": actuator fields are gain, bias".into())),
                }
            }
            "tendon" => {
                let t = named(&mut spec.tendons.iter().map(|x| &x.name))?;
                match field {
                    "stiffness" => Ok(Param::TendonStiffness(t)),
                    "damping" => Ok(Param::TendonDamping(t)),
                    "frictionloss" => Ok(Param::TendonFrictionLoss(t)),
                    "springlength" if spec.tendons[t].springlength.is_none() => {
                        Err(unknown(format!(
                            ": tendon '{object}' has springlength -1 -1 (its length at \
                             qpos_spring); give the deadband explicitly to identify it"
                        )))
                    }
                    "springlength" => Ok(Param::TendonSpringlength(t)),
                    _ => Err(unknown(
                        ": tendon fields are stiffness, damping, frictionloss, springlength".into(),
                    )),
                }
            }
            _ => Err(unknown(expected.into())),
        }
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
                | Param::EqualitySolref(_)
                | Param::EqualitySolimp(_)
                | Param::TendonFrictionLoss(_)
        )
    }

    /// Whether it is a tendon's.
    pub fn is_tendon(&self) -> bool {
        matches!(
            self,
            Param::TendonStiffness(_)
                | Param::TendonDamping(_)
                | Param::TendonFrictionLoss(_)
                | Param::TendonSpringlength(_)
        )
    }

    /// Whether it is an actuator's gain or bias.
    pub fn is_actuator(&self) -> bool {
        matches!(self, Param::ActuatorGain(_) | Param::ActuatorBias(_))
    }

    pub fn name(&self, spec: &Spec) -> String {
        let body = |b: usize| &spec.bodies[b].name;
        let joint = |j: usize| &spec.joints[j].name;
        let geom = |g: usize| &spec.geoms[g].name;
        let equality = |e: usize| &spec.equalities[e].name;
        let actuator = |a: usize| &spec.actuators[a].name;
        let tendon = |t: usize| &spec.tendons[t].name;
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
            Param::EqualitySolref(e) => format!("equality/{}/solref", equality(e)),
            Param::EqualitySolimp(e) => format!("equality/{}/solimp", equality(e)),
            Param::ActuatorGain(a) => format!("actuator/{}/gain", actuator(a)),
            Param::ActuatorBias(a) => format!("actuator/{}/bias", actuator(a)),
            Param::TendonStiffness(t) => format!("tendon/{}/stiffness", tendon(t)),
            Param::TendonDamping(t) => format!("tendon/{}/damping", tendon(t)),
            Param::TendonFrictionLoss(t) => format!("tendon/{}/frictionloss", tendon(t)),
            Param::TendonSpringlength(t) => format!("tendon/{}/springlength", tendon(t)),
        }
    }

    /// Number of scalar values.
    pub fn size(&self) -> usize {
        match self {
            Param::Com(_) | Param::GeomFriction(_) => 3,
            Param::ActuatorGain(_) | Param::ActuatorBias(_) => 3,
            Param::Inertia(_) => 6,
            Param::GeomSolref(_) | Param::LimitSolref(_) | Param::EqualitySolref(_) => 2,
            Param::TendonSpringlength(_) => 2,
            Param::GeomSolimp(_) | Param::LimitSolimp(_) | Param::EqualitySolimp(_) => 5,
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
            Param::EqualitySolref(e) => spec.equalities[e].sol.solref.to_vec(),
            Param::EqualitySolimp(e) => spec.equalities[e].sol.solimp.to_vec(),
            Param::ActuatorGain(a) => match spec.actuators[a].gain {
                Gain::Fixed(g) => vec![g, 0.0, 0.0],
                Gain::Affine(p) => p.to_vec(),
            },
            Param::ActuatorBias(a) => match spec.actuators[a].bias {
                Bias::None => vec![0.0; 3],
                Bias::Affine(p) => p.to_vec(),
            },
            Param::TendonStiffness(t) => vec![spec.tendons[t].stiffness],
            Param::TendonDamping(t) => vec![spec.tendons[t].damping],
            Param::TendonFrictionLoss(t) => vec![spec.tendons[t].frictionloss],
            Param::TendonSpringlength(t) => {
                let [lo, hi] = spec.tendons[t].springlength.unwrap_or([-1.0; 2]);
                vec![lo, hi]
            }
        }
    }

    /// Checks a value's length and that it is finite.
    pub(crate) fn check_value(&self, spec: &Spec, value: &[f64]) -> Result<(), ParamError> {
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

impl Spec {
    pub fn param(&self, name: &str) -> Result<Param, ParamError> {
        Param::parse(self, name)
    }

    pub fn get_param(&self, name: &str) -> Result<Vec<f64>, ParamError> {
        Ok(self.param(name)?.get(self))
    }
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
    pub fn new(model: &Spec, nmu: usize, entries: &[MapEntry]) -> Result<ParamMap, ParamError> {
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
    pub fn identity<S: AsRef<str>>(model: &Spec, names: &[S]) -> Result<ParamMap, ParamError> {
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
    pub(crate) fn flat_values(&self, mu: &[f64]) -> Vec<f64> {
        let mut values = Vec::with_capacity(self.targets.iter().map(|(p, ..)| p.size()).sum());
        for (_, offset, gain) in &self.targets {
            for (r, o) in offset.iter().enumerate() {
                let moved: f64 = mu.iter().enumerate().map(|(j, m)| gain[(r, j)] * m).sum();
                values.push(o + moved);
            }
        }
        values
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
