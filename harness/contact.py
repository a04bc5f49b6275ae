"""Contact: our constraint model (MuJoCo's soft constraints, src/dynamics/constraint.rs)
against MuJoCo model by model, and against the other engines' contact laws.

1. MuJoCo, model by model (harness/agreement.py): the half cheetah, the box, the wiping arm
   pressing its tool on the table, gymnasium's hopper and walker2d, and two models of every
   collider and contact setting (tests/data/contact_features_{pyramidal,elliptic}.xml). One step from MuJoCo's
   own states (in contact, at joint limits, free) against MuJoCo with its solver converged
   and at the file's own tolerance, the normal forces, and a replay. Ours must equal the
   converged MuJoCo to <= 1e-9 (relative) at one step: the exit status says whether it did.
2. The half cheetah dropped on its floor in ours, MuJoCo and PyBullet, under the same
   generalized torques at dt = 0.01 s from q = v = 0 (the torso 0.7 m up):
   - MuJoCo: gymnasium's half_cheetah.xml as the gym runs it, torques through qfrc_applied;
   - ours: reference_models/half_cheetah.xml (the same model) under the constraint model;
   - PyBullet: the URDF twin reference_models/half_cheetah.urdf on a plane of its own
     (loadMJCF of the gym file puts every link's COM at its body frame and ignores
     settotalmass). PyBullet has no armature and no joint springs: springs are explicit
     torques -K (q - q_spring) at every substep, the armature (0.1 on each leg joint)
     stays missing; 5 substeps of 0.002 s per 0.01 s step (explicit damping without
     armature is unstable at 0.01 s); rolling and spinning friction zeroed (condim 3).
   Torque sequences "random" (seeded ctrl uniform in [-1, 1]) and "gait" (ctrl 0.8 sin(2 pi
   t / 0.5 s + phase), legs in antiphase); tau = gear * ctrl. Per step: the state error of
   ours and of PyBullet against MuJoCo, max(|dq| / max(1, |q|), |dv| / max(1, |v|)), and each
   engine's total normal force during the step (MuJoCo: mj_contactForce; ours:
   Model.contacts under the step's torques; PyBullet: getContactPoints normalForce averaged
   over the substeps); then one step from states along MuJoCo's trajectories.
3. The resting box (reference_models/box.*) in ours, MuJoCo, PyBullet and DART: each
   engine's normal force against m g.

Writes <out>/contact-half_cheetah.md, .json and .png.

    python -m harness contact --steps 500 --samples 200 --seed 0
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from harness.engines.base import MODELS, gym_assets_dir, label_of, quiet_stdio
from harness.engines.numpy_step import step_error
from harness.golden import case_seed
from harness.report import REPORTS, markdown_table, write_json, write_markdown

GYM_CHEETAH = gym_assets_dir() / "half_cheetah.xml"
OUR_CHEETAH = MODELS / "half_cheetah.xml"
CHEETAH_URDF = MODELS / "half_cheetah.urdf"
BOX = MODELS / "box"
GAIT_PERIOD = 0.5  # s
GAIT_AMPLITUDE = 0.8  # of the control range
FREE_TOL = 1e-9  # ours vs MuJoCo, one step from a state neither constrains


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--model", type=Path, help="an MJCF file: only its row of the model-by-model table "
                    "(harness/agreement.py), written to contact-<stem>.{md,json}")
    ap.add_argument("--steps", type=int, default=500, help="replay length, 0.01 s steps (default %(default)s)")
    ap.add_argument("--samples", type=int, default=200,
                    help="one-step states per torque sequence (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


# ---------------------------------------------------------------- engines with contacts on


class OursContact:
    """Our engine with contacts and limits on, under the file's contact model (the
    constraint model unless the file names the smooth one); `normal_force` is the total
    normal force of the last step, read with Model.contacts at the state it started from
    under the step's torques."""

    name = "ours"

    def __init__(self, path: Path):
        import diffosi

        self.m = diffosi.Model.load(str(path))
        self.off = self.m.with_options(contact=False, limits=False)
        self.timestep = self.m.timestep
        self.settings = {"model": label_of(path), "contact_model": self.m.contact_model}

    def set_state(self, q, v):
        self.q, self.v = np.array(q, float), np.array(v, float)

    def get_state(self):
        return self.q.copy(), self.v.copy()

    def step(self, tau):
        self.normal_force = float(sum(c["normal_force"] for c in self.m.contacts(self.q, self.v, tau)))
        self.q, self.v = self.m.step(self.q, self.v, tau)

    def unconstrained(self, q, v, tau) -> bool:
        """True when no constraint row acts at (q, v): the step equals, bit for bit, the
        step with contacts and limits switched off."""
        (q1, v1), (p1, w1) = self.m.step(q, v, tau), self.off.step(q, v, tau)
        return bool(np.array_equal(q1, p1) and np.array_equal(v1, w1))

    def close(self):
        pass


class MujocoContact:
    """An MJCF file as MuJoCo runs it, contacts and limits on; torques via qfrc_applied."""

    name = "mujoco"

    def __init__(self, path: Path):
        import mujoco

        from harness.engines.mujoco import load_mjcf

        self.mujoco = mujoco
        self.m = load_mjcf(path)
        self.d = mujoco.MjData(self.m)
        self.timestep = float(self.m.opt.timestep)
        self.joint_names = [self.m.joint(i).name for i in range(self.m.njnt)]
        o = self.m.opt
        self.settings = {"model": label_of(path), "version": mujoco.__version__,
                         "solver": mujoco.mjtSolver(o.solver).name, "iterations": int(o.iterations),
                         "tolerance": float(o.tolerance), "cone": mujoco.mjtCone(o.cone).name,
                         "integrator": mujoco.mjtIntegrator(o.integrator).name,
                         "tau_applied_via": "qfrc_applied (ctrl = 0)",
                         "total_mass": float(mujoco.mj_getTotalmass(self.m))}
        if self.m.ngeom:  # the first geom's contact softness and friction (the floor's)
            self.settings.update(solref=self.m.geom_solref[0].tolist(), solimp=self.m.geom_solimp[0, :3].tolist(),
                                 friction=self.m.geom_friction[0].tolist())

    def set_param(self, name: str, value) -> None:
        """`joint/<name>/stiffness|damping` (jnt_stiffness, dof_damping: no derived constant
        depends on them)."""
        kind, owner, field = name.split("/")
        if kind != "joint" or field not in ("stiffness", "damping") or owner not in self.joint_names:
            raise ValueError(f"{self.settings['model']}: cannot set {name} (joint/<name>/stiffness|damping)")
        j = self.m.joint(owner).id
        x = float(np.ravel(value)[0])
        if field == "stiffness":
            self.m.jnt_stiffness[j] = x
        else:
            self.m.dof_damping[self.m.jnt_dofadr[j]] = x

    def set_state(self, q, v):
        self.mujoco.mj_resetData(self.m, self.d)
        self.d.qpos[:], self.d.qvel[:] = q, v

    def get_state(self):
        return self.d.qpos.copy(), self.d.qvel.copy()

    def step(self, tau):
        from harness.engines.mujoco import contact_normal_forces

        self.d.ctrl[:] = 0.0
        self.d.qfrc_applied[:] = tau
        self.mujoco.mj_step(self.m, self.d)
        self.normal_force = float(contact_normal_forces(self.m, self.d).sum())
        self.ncon, self.nefc = int(self.d.ncon), int(self.d.nefc)

    def close(self):
        pass


class PybulletContact:
    """A URDF twin in PyBullet on a plane of its own (the twin's floor, on the world link,
    would be a self-collision, which PyBullet skips). See the module docstring for what is
    switched off and how springs are added."""

    name = "pybullet"
    passive, integrator = "explicit", "Euler"

    def __init__(self, urdf: Path, timestep: float):
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        from harness.engines.pybullet import PybulletEngine, stable_explicit_timestep
        from harness.engines.urdf import read_urdf, timestep_gravity

        facts = read_urdf(urdf)
        _, gravity, _ = timestep_gravity(urdf, facts)
        self.pybullet, self.timestep, self.gravity = pybullet, timestep, list(gravity)
        self.label, self.version = label_of(urdf), PybulletEngine.version
        with quiet_stdio():
            p = self.p = BulletClient(connection_mode=pybullet.DIRECT)
            body = self.body = p.loadURDF(str(urdf), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        p.setGravity(*gravity)
        links = list(range(p.getNumJoints(body)))
        self.movable = [i for i in links if p.getJointInfo(body, i)[2] != pybullet.JOINT_FIXED]
        self.joint_names = [p.getJointInfo(body, i)[1].decode() for i in self.movable]
        self.links = {p.getJointInfo(body, i)[12].decode(): i for i in links}
        # the file's principal moments: changeDynamics(mass=) alone would recompute them from the
        # collision shapes
        self.inertia = {name: p.getDynamicsInfo(body, i)[2] for name, i in self.links.items()}
        assert self.joint_names == [j.name for j in facts["joints"]], f"{urdf}: PyBullet dof order"
        p.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, maxJointVelocity=1e6)
        for i in links:
            p.changeDynamics(body, i, rollingFriction=0.0, spinningFriction=0.0)
        p.setCollisionFilterGroupMask(body, -1, 0, 0)  # the twin's floor box: the plane replaces it
        self.plane = p.createMultiBody(0.0, p.createCollisionShape(pybullet.GEOM_PLANE))
        p.changeDynamics(self.plane, -1, lateralFriction=1.0, rollingFriction=0.0, spinningFriction=0.0)
        n = len(self.movable)
        p.setJointMotorControlArray(body, self.movable, pybullet.VELOCITY_CONTROL, forces=[0.0] * n)
        self.stiffness = np.array([j.extensions.get("stiffness", 0.0) for j in facts["joints"]])
        self.springref = np.array([j.extensions.get("springref", 0.0) for j in facts["joints"]])
        damping = np.array([j.damping for j in facts["joints"]])
        self.settings = {"model": label_of(urdf), "version": PybulletEngine.version,
                         "ground": "GEOM_PLANE z = 0, lateral friction 1 (Bullet multiplies the two bodies')",
                         "rolling_spinning_friction": 0.0,
                         "link_damping": "0 (default 0.04)", "joint_limits": "the URDF's, PyBullet's constraints"}
        mass = np.array(p.calculateMassMatrix(body, [0.0] * n))
        h = stable_explicit_timestep(timestep, damping, mass, self.settings) if damping.any() else timestep
        self.substeps = int(round(timestep / h))
        p.setTimeStep(h)
        p.setPhysicsEngineParameter(numSubSteps=0)
        params = p.getPhysicsEngineParameters()
        self.settings.update(substeps=self.substeps, substep=h,
                             numSolverIterations=params["numSolverIterations"])
        if self.stiffness.any():
            self.settings["springs"] = "explicit torques -K (q - q_spring) every substep (PyBullet has none)"
        if armature := {j.name: j.extensions["armature"] for j in facts["joints"] if j.extensions.get("armature")}:
            self.settings["missing_armature"] = armature

    def set_param(self, name: str, value) -> None:
        """`body/<link>/mass` (changeDynamics with the file's principal moments passed back: the
        COM and the inertia about it kept, as our body/<name>/mass), `joint/<name>/stiffness`
        (the explicit spring torque) and
        `joint/<name>/damping` (changeDynamics jointDamping)."""
        kind, owner, field = name.split("/")
        x = float(np.ravel(value)[0])
        if (kind, field) == ("body", "mass") and owner in self.links:
            self.p.changeDynamics(self.body, self.links[owner], mass=x, localInertiaDiagonal=self.inertia[owner])
        elif kind == "joint" and field == "stiffness" and owner in self.joint_names:
            self.stiffness[self.joint_names.index(owner)] = x
        elif kind == "joint" and field == "damping" and owner in self.joint_names:
            self.p.changeDynamics(self.body, self.movable[self.joint_names.index(owner)], jointDamping=x)
        else:
            raise ValueError(f"{self.label}: cannot set {name} (body/<link>/mass, joint/<name>/stiffness|damping)")

    @property
    def constrained(self) -> bool:
        """Whether the last step ended with a contact point (PyBullet's joint limits are not counted)."""
        return bool(self.p.getContactPoints(self.body))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def set_state(self, q, v):
        for k, i in enumerate(self.movable):
            self.p.resetJointState(self.body, i, q[k], v[k])

    def get_state(self):
        s = self.p.getJointStates(self.body, self.movable)
        return np.array([x[0] for x in s]), np.array([x[1] for x in s])

    def step(self, tau):
        from harness.engines.pybullet import contact_normal_forces

        force = 0.0
        for _ in range(self.substeps):
            q, _ = self.get_state()
            total = np.asarray(tau, float) - self.stiffness * (q - self.springref)
            self.p.setJointMotorControlArray(self.body, self.movable, self.pybullet.TORQUE_CONTROL,
                                             forces=list(map(float, total)))
            self.p.stepSimulation()
            force += contact_normal_forces(self.p, self.body).sum()
        self.normal_force = float(force / self.substeps)

    def close(self):
        self.p.disconnect()


class DartContact:
    """A URDF twin in DART (dartpy, its own LCP contact and FCL collision) on a ground box of
    its own whose top face is z = 0 (DART drops the world link and its floor). The URDF's
    joint limits are enforced (DART's limit constraints; lower = upper means none), damping
    and springs are DART's own (implicit), friction is each link's <contact>
    lateral_friction against a ground of 1 (DART takes the smaller); DART has no armature,
    listed as missing."""

    name = "dart"
    passive, integrator = "implicit_damping_stiffness", "Euler"

    def __init__(self, urdf: Path, timestep: float):
        import xml.etree.ElementTree as ET

        import dartpy as dart

        from harness.engines.dart import DartEngine, load_world, set_passive
        from harness.engines.urdf import read_urdf, timestep_gravity

        facts = read_urdf(urdf)
        _, gravity, _ = timestep_gravity(urdf, facts)
        self.timestep, self.gravity = timestep, list(gravity)
        self.label, self.version = label_of(urdf), DartEngine.version
        self.world, self.skel = load_world(Path(urdf).resolve(), timestep, self.gravity)
        skel = self.skel
        self.joint_names = [skel.getDof(i).getName() for i in range(skel.getNumDofs())]
        assert self.joint_names == [j.name for j in facts["joints"]], f"{urdf}: DART dof order"
        set_passive(skel, facts, urdf)
        for k, j in enumerate(facts["joints"]):
            dof = skel.getDof(k)
            lo, hi = j.limit or (-np.inf, np.inf)
            dof.setPositionLimits(lo, hi)
            dof.setVelocityLimits(-np.inf, np.inf)
            dof.setForceLimits(-np.inf, np.inf)
            skel.getJoint(j.name).setLimitEnforcement(j.limit is not None)
        friction = {link.get("name"): float(f.get("value"))
                    for link in ET.parse(urdf).getroot().findall("link")
                    if (f := link.find("contact/lateral_friction")) is not None}
        for i in range(skel.getNumBodyNodes()):
            node = skel.getBodyNode(i)
            for shape in node.getShapeNodes():
                if shape.hasDynamicsAspect():
                    shape.getDynamicsAspect().setFrictionCoeff(friction.get(node.getName(), 1.0))
        ground = dart.dynamics.Skeleton("ground")
        joint, body = ground.createWeldJointAndBodyNodePair()
        node = body.createShapeNode(dart.dynamics.BoxShape([100.0, 100.0, 1.0]))
        node.createCollisionAspect()
        node.createDynamicsAspect().setFrictionCoeff(1.0)
        top = dart.math.Isometry3()
        top.set_translation([0.0, 0.0, -0.5])  # top face z = 0
        joint.setTransformFromParentBodyNode(top)
        self.world.addSkeleton(ground)
        self.normal_force = 0.0
        self.settings = {"model": self.label, "version": self.version,
                         "ground": "a 100 x 100 x 1 m box, top face z = 0, friction 1 (DART takes the smaller)",
                         "contact": "DART's LCP (boxed, Dantzig), FCL collision",
                         "joint_limits": "the URDF's, DART's limit constraints", "passive": "DART's implicit"}
        if armature := {j.name: j.extensions["armature"] for j in facts["joints"] if j.extensions.get("armature")}:
            self.settings["missing_armature"] = armature

    def set_param(self, name: str, value) -> None:
        """`body/<link>/mass` (BodyNode.setMass: COM and inertia about it kept, as ours) and
        `joint/<name>/stiffness|damping` (DART's own springs and dampers)."""
        kind, owner, field = name.split("/")
        x = float(np.ravel(value)[0])
        if (kind, field) == ("body", "mass") and self.skel.getBodyNode(owner) is not None:
            self.skel.getBodyNode(owner).setMass(x)
        elif kind == "joint" and field in ("stiffness", "damping") and owner in self.joint_names:
            dof = self.skel.getDof(self.joint_names.index(owner))
            (dof.setSpringStiffness if field == "stiffness" else dof.setDampingCoefficient)(x)
        else:
            raise ValueError(f"{self.label}: cannot set {name} (body/<link>/mass, joint/<name>/stiffness|damping)")

    @property
    def constrained(self) -> bool:
        """Whether the last step had a contact (DART's joint limits are not counted)."""
        return self.world.getLastCollisionResult().getNumContacts() > 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def set_state(self, q, v):
        self.skel.setPositions(np.asarray(q, float))
        self.skel.setVelocities(np.asarray(v, float))

    def get_state(self):
        return np.array(self.skel.getPositions()), np.array(self.skel.getVelocities())

    def step(self, tau):
        from harness.engines.dart import contact_normal_forces

        self.skel.setForces(np.asarray(tau, float))  # cleared by the step
        self.world.step()
        self.normal_force = float(contact_normal_forces(self.world).sum())

    def close(self):
        pass


# ---------------------------------------------------------------- the resting box

BOX_MASS = 2.0
BOX_ENGINES = ("ours", "mujoco", "pybullet", "dart")
BOX_TILT, BOX_PUSH = 0.05, 0.3  # rad about x, m/s along x: the box must settle from them


def resting_box(engine: str, steps: int = 5000) -> dict:
    """The box (reference_models/box.*) dropped with a slight tilt and push, after `steps`
    steps of 0.002 s: the total normal contact force as the engine reports it, against the
    weight m g. Each engine's own reading: ours Model.contacts normal_force; MuJoCo
    mj_contactForce; PyBullet getContactPoints normalForce; DART the last collision
    result's contact forces along their normals. DART loads the URDF twin on a ground box
    of its own (it drops the world link's floor) with its default collision detector (FCL)."""
    q0 = np.zeros(6)
    q0[3] = BOX_TILT
    v0 = np.zeros(6)
    v0[0] = BOX_PUSH
    tau = np.zeros(6)
    if engine == "dart":
        forces, v, reading = _dart_box(q0, v0, steps)
    else:
        e = {"ours": lambda: OursContact(BOX.with_suffix(".xml")),
             "mujoco": lambda: MujocoContact(BOX.with_suffix(".xml")),
             "pybullet": lambda: PybulletContact(BOX.with_suffix(".urdf"), 0.002)}[engine]()
        e.set_state(q0, v0)
        for _ in range(steps):
            e.step(tau)
        _, v = e.get_state()
        forces = e.normal_force
        e.close()
        reading = {"ours": "Model.contacts normal_force", "mujoco": "mj_contactForce",
                   "pybullet": "getContactPoints normalForce"}[engine]
    weight = BOX_MASS * 9.81
    return {"engine": engine, "normal_force": float(forces), "weight": weight,
            "relative_error": abs(float(forces) - weight) / weight, "max_speed": float(np.abs(v).max()),
            "steps": steps, "read_with": reading}


def _dart_box(q0, v0, steps: int) -> tuple[float, np.ndarray, str]:
    import dartpy as dart

    from harness.engines.dart import contact_normal_forces, load_world

    world, skel = load_world(BOX.with_suffix(".urdf").resolve(), 0.002, [0.0, 0.0, -9.81])
    ground = dart.dynamics.Skeleton("ground")
    joint, body = ground.createWeldJointAndBodyNodePair()
    node = body.createShapeNode(dart.dynamics.BoxShape([10.0, 10.0, 0.2]))
    node.createCollisionAspect()
    node.createDynamicsAspect()
    top = dart.math.Isometry3()
    top.set_translation([0.0, 0.0, -0.1])  # top face z = 0
    joint.setTransformFromParentBodyNode(top)
    world.addSkeleton(ground)
    skel.setPositions(q0)
    skel.setVelocities(v0)
    for _ in range(steps):
        world.step()
    return float(contact_normal_forces(world).sum()), np.array(skel.getVelocities()), \
        "getLastCollisionResult() contact force . normal"


# ---------------------------------------------------------------- the half cheetah


def torque_sequences(steps: int, seed: int) -> dict:
    """{"random": taus, "gait": taus}, each (steps, nv): gear * ctrl on the actuated joints."""
    from harness.engines.mujoco import load_mjcf

    m = load_mjcf(GYM_CHEETAH)
    gear, dof = m.actuator_gear[:, 0], m.jnt_dofadr[m.actuator_trnid[:, 0]]
    rng = case_seed(seed, "contact_half_cheetah")
    ctrl = {"random": rng.uniform(-1.0, 1.0, (steps, m.nu))}
    t = np.arange(steps)[:, None] * float(m.opt.timestep)
    phase = np.array([0.0, 0.5, 1.0, 1.0, 1.5, 0.0]) * np.pi  # back thigh, shin, foot; front: antiphase
    ctrl["gait"] = GAIT_AMPLITUDE * np.sin(2 * np.pi * t / GAIT_PERIOD + phase[: m.nu])
    out = {}
    for name, c in ctrl.items():
        tau = np.zeros((steps, m.nv))
        tau[:, dof] = c * gear
        out[name] = tau
    return out


def open_cheetahs() -> list:
    mj = MujocoContact(GYM_CHEETAH)
    ours = OursContact(OUR_CHEETAH)
    pb = PybulletContact(CHEETAH_URDF, mj.timestep)
    assert ours.timestep == mj.timestep and pb.joint_names == mj.joint_names
    return [mj, ours, pb]


def replay(engines: list, taus: np.ndarray) -> dict:
    """Each engine alone from q = v = 0 under taus; state error vs MuJoCo (engines[0]) and
    total normal force per step; MuJoCo's trajectory and contact counts for the one-step part."""
    n = taus.shape[1]
    runs = {}
    for e in engines:
        e.set_state(np.zeros(n), np.zeros(n))
        states, forces, ncon, nefc = [e.get_state()], [], [], []
        for tau in taus:
            e.step(tau)
            states.append(e.get_state())
            forces.append(e.normal_force)
            if e.name == "mujoco":
                ncon.append(e.ncon)
                nefc.append(e.nefc)
        runs[e.name] = {"states": states, "force": forces, "ncon": ncon, "nefc": nefc}
    ref = runs["mujoco"]["states"]
    out = {"mujoco": {"force": runs["mujoco"]["force"], "ncon": runs["mujoco"]["ncon"]}}
    for name, r in runs.items():
        if name != "mujoco":
            error = [step_error(q, v, *qv) for (q, v), qv in zip(r["states"], ref)]
            out[name] = {"force": r["force"], "error": error, "max_error": max(error),
                         "first_above_1e-3": next((t for t, x in enumerate(error) if x > 1e-3), None)}
    out["_trajectory"] = (ref, runs["mujoco"]["ncon"], runs["mujoco"]["nefc"])
    return out


def one_step(engines: list, trajectory: tuple, taus: np.ndarray, samples: int) -> dict:
    """One step of ours and PyBullet from states along MuJoCo's trajectory, against MuJoCo's
    own next state; errors split by MuJoCo's contacts in that step."""
    states, ncon, nefc = trajectory
    ours = next(e for e in engines if e.name == "ours")
    picks = np.unique(np.linspace(0, len(taus) - 1, min(samples, len(taus))).astype(int))
    classes: dict = {"contact": {}, "no_contact": {}, "free": {}}
    for t in picks:
        (q, v), ref, tau = states[t], states[t + 1], taus[t]
        kinds = ["contact" if ncon[t] else "no_contact"]
        if nefc[t] == 0 and ours.unconstrained(q, v, tau):
            kinds.append("free")
        for e in engines:
            if e.name == "mujoco":
                continue
            e.set_state(q, v)
            e.step(tau)
            err = step_error(*e.get_state(), *ref)
            for k in kinds:
                classes[k].setdefault(e.name, []).append(err)
    return {k: {name: {"states": len(x), "max_error": max(x), "median_error": float(np.median(x))}
                for name, x in c.items()} for k, c in classes.items()}


def agreements(samples: int, seed: int) -> list:
    """harness/agreement.py on every model (the wiping arm: a wiping episode at mu =
    (50, 50))."""
    import tempfile

    from harness import agreement, wiping_replay

    out = []
    for name, (path, steps) in agreement.models().items():
        if name != "wiping_arm":
            out.append(agreement.one_model(name, path, steps, samples, seed))
            continue
        with tempfile.TemporaryDirectory() as tmp:
            rec, xml = wiping_replay.record("50,50", steps, Path(tmp))
            episode = (rec["q"][0], rec["v"][0], rec["tau"])
            out.append(agreement.one_model(name, xml, steps, samples, seed, episode=episode))
        out[-1]["file"] = "reference_models/wiping_arm.xml (tool at mu = 50, 50)"
    return out


def cheetah_report(steps: int, samples: int, seed: int) -> dict:
    """Every number of the report, as a JSON-ready dict."""
    agreement = agreements(samples, seed)
    engines = open_cheetahs()
    try:
        sequences = {}
        for name, taus in torque_sequences(steps, seed).items():
            run = replay(engines, taus)
            trajectory = run.pop("_trajectory")
            run["one_step"] = one_step(engines, trajectory, taus, samples)
            sequences[name] = run
        settings = {e.name: e.settings for e in engines}
    finally:
        for e in engines:
            e.close()
    box = [resting_box(name) for name in BOX_ENGINES]
    free = [r["one_step"]["free"].get("ours", {"max_error": 0.0})["max_error"] for r in sequences.values()]
    from harness.agreement import AGREEMENT_TOL

    passed = max(free) <= FREE_TOL and all(a["pass"] for a in agreement)
    return {"model": "half_cheetah", "steps": steps, "samples": samples, "seed": seed,
            "timestep": engines[0].timestep, "free_tol": FREE_TOL, "pass": passed,
            "agreement_tol": AGREEMENT_TOL, "agreement": agreement,
            "error": "max(|dq| / max(1, |q|), |dv| / max(1, |v|)) against MuJoCo, max norms",
            "normal_force": "total normal contact force during a step, N", "settings": settings,
            "sequences": sequences, "resting_box": box}


def plot(path: Path, doc: dict) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seqs = doc["sequences"]
    fig, axes = plt.subplots(len(seqs), 2, figsize=(11, 3.6 * len(seqs)), dpi=100, squeeze=False)
    h = doc["timestep"]
    for row, (name, run) in zip(axes, seqs.items()):
        for engine in ("ours", "pybullet"):
            e = np.maximum(run[engine]["error"], 1e-18)
            row[0].plot(np.arange(len(e)) * h, e, lw=1.1, label=f"{engine} vs mujoco")
        row[0].set(yscale="log", title=f"{name} torques: state error", xlabel="t (s)",
                   ylabel="relative state error")
        for engine in ("mujoco", "ours", "pybullet"):
            f = run[engine]["force"]
            row[1].plot(np.arange(len(f)) * h, f, lw=1.0, label=engine)
        row[1].set(title=f"{name} torques: total normal contact force", xlabel="t (s)", ylabel="N")
        for ax in row:
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path


def force_stats(f: list, h: float) -> tuple:
    """Mean, min, max and impulse (sum f h) of a force series."""
    f = np.asarray(f)
    return float(f.mean()), float(f.min()), float(f.max()), float(f.sum() * h)


def fmt(x) -> str:
    return "-" if x is None else f"{x:.1e}"


def agreement_lines(doc: dict) -> list[str]:
    """The model-by-model table against MuJoCo."""
    lines = ["## Ours against MuJoCo, model by model", "",
             "One step from MuJoCo's own states along a trajectory under seeded controls (the wiping arm: "
             "a wiping episode's torques, its tool on the table), against MuJoCo with its solver converged "
             "(tolerance 0, 1000 iterations), split by what MuJoCo had in that step: contact rows, joint-limit "
             "rows only, nothing. 'file tol.' is MuJoCo at the file's own tolerance against the converged "
             "MuJoCo: the gap that tolerance leaves. Normal force: the largest gap of the total normal force "
             "per state, relative to max(1 N, MuJoCo's). Replay: ours alone under the same forces against "
             "MuJoCo at the file's settings; 'parted' is the first step more than 1e-6 apart.", ""]
    rows = []
    for a in doc["agreement"]:
        o = a["one_step"]
        cell = lambda k: f"{fmt(o[k]['max'])} ({o[k]['states']})"
        rows.append([a["model"], f"{a['integrator']}, {a['cone']}, h {a['timestep']:g}", a["steps"],
                     cell("contact"), cell("limit"), cell("free"), fmt(a["file_tolerance_gap"]["max"]),
                     fmt(a["normal_force"]["max_relative_gap"]), a["replay"]["first_parted"] or "never",
                     fmt(a["replay"]["max_gap"]), "PASS" if a["pass"] else "**FAIL**"])
    lines += markdown_table(["model", "MuJoCo settings", "steps", "contact: max error (states)",
                             "limit only", "free", "file tol.", "normal force", "replay parted",
                             "replay max gap", f"<= {doc['agreement_tol']:.0e}"], rows)
    return lines + [""]


def markdown(doc: dict, png: str) -> list[str]:
    h, seqs = doc["timestep"], doc["sequences"]
    lines = [
        "# Contact: ours (MuJoCo's soft constraints) against MuJoCo, PyBullet and DART",
        "",
        f"`python -m harness contact --steps {doc['steps']} --samples {doc['samples']} --seed {doc['seed']}`",
        "",
        f"Result: {'PASS' if doc['pass'] else '**FAIL**'}: one step of ours equals the converged MuJoCo's to "
        f"<= {doc['agreement_tol']:.0e} on every model below, in contact and at limits.",
        "",
    ]
    lines += agreement_lines(doc)
    lines += [
        "## The half cheetah dropped on its floor: ours and PyBullet against MuJoCo",
        "",
        f"Same initial state (q = v = 0, torso 0.7 m up), same generalized torques, {doc['steps']} steps of "
        f"{h:g} s; contacts and joint limits on in every engine. MuJoCo runs gymnasium's half_cheetah.xml at "
        "its own solver settings, ours reference_models/half_cheetah.xml (the same model), PyBullet the URDF "
        "twin on its own plane (settings below). Error = max(|dq| / max(1, |q|), |dv| / max(1, |v|)) against "
        "MuJoCo.",
        "",
        "### Replay",
        "",
    ]
    rows = []
    for name, run in seqs.items():
        for engine in ("ours", "pybullet"):
            r = run[engine]
            rows.append([name, engine, f"{r['error'][1]:.1e}", f"{r['error'][10]:.1e}" if len(r["error"]) > 10
                         else "-", r["first_above_1e-3"], f"{r['max_error']:.2g}"])
    lines += markdown_table(["torques", "engine vs mujoco", "error after 1 step", "after 10 steps",
                             "first step with error > 1e-3", "max error"], rows)
    mj = doc["settings"]["mujoco"]
    lines += ["", "Total normal contact force (N) over the replay: mean, min, max, and impulse (N s; "
              "the weight alone over the replay would give "
              f"{mj['total_mass'] * 9.81 * h * doc['steps']:.0f}).", ""]
    rows = []
    for name, run in seqs.items():
        for engine in ("mujoco", "ours", "pybullet"):
            mean, low, peak, impulse = force_stats(run[engine]["force"], h)
            rows.append([name, engine, f"{mean:.1f}", f"{low:.1f}", f"{peak:.1f}", f"{impulse:.1f}"])
    lines += markdown_table(["torques", "engine", "mean", "min", "max", "impulse"], rows)
    lines += ["", f"![state error and normal force vs time]({png})", "", "### One step from MuJoCo's states", "",
              "From states along MuJoCo's trajectories, one step of each engine under the same torque, "
              "against MuJoCo's own next state. contact: MuJoCo had a contact in that step; no_contact: it "
              "had none; free: no constraint row in MuJoCo (no contact, no limit) and our contact and limit "
              f"forces exactly zero (our threshold there: {doc['free_tol']:.0e}).", ""]
    rows = []
    for name, run in seqs.items():
        for kind, res in run["one_step"].items():
            for engine, r in res.items():
                rows.append([name, kind, engine, r["states"], f"{r['median_error']:.1e}", f"{r['max_error']:.1e}"])
    lines += markdown_table(["torques", "states", "engine", "count", "median error", "max error"], rows)
    lines += ["", "### Where the gaps come from", "",
              "- Ours is MuJoCo's contact model (soft constraints: solref, solimp, pyramidal or elliptic "
              "cones, impratio, the regulariser from invweight0) solved by Newton's method to convergence, so "
              "it follows MuJoCo step for step; a replay parts only where MuJoCo's own solver, at the "
              f"file's tolerance ({mj['tolerance']:g}), stops short of convergence and the difference grows "
              "through the contacts' sensitivity.",
              "- PyBullet solves hard contacts (an LCP with ERP position correction) and hard limits, has no "
              "armature (0.1 on each leg joint, a large share of the feet's inertia: its error is of order 1 "
              "from the first step, even in free fall) and steps 5 substeps of 0.002 s. It runs the URDF twin "
              "because its loadMJCF of the gym file puts each link's COM at the body frame and skips "
              "settotalmass. Once trajectories separate, contact timing differs and the error saturates at "
              "the size of the state itself: compare the early steps and the forces' statistics.",
              "", "## Resting box", "",
              "reference_models/box.xml (ours, MuJoCo) and box.urdf (PyBullet, DART, each on a ground of "
              f"its own): a {BOX_MASS:g} kg box dropped with a {BOX_TILT} rad tilt and a {BOX_PUSH} m/s push, "
              "after the steps below of 0.002 s. Each engine's own contact-force reading against m g:", ""]
    rows = [[r["engine"], r["read_with"], r["steps"], repr(r["normal_force"]), f"{r['relative_error']:.1e}",
             f"{r['max_speed']:.1e}"] for r in doc["resting_box"]]
    lines += markdown_table(["engine", "read with", "steps", "normal force (N)", "relative error vs m g",
                             "max abs v"], rows)
    lines += ["", "## Settings", ""]
    for name, s in doc["settings"].items():
        lines.append(f"- {name}: " + "; ".join(f"{k} {v}" for k, v in s.items()))
    return lines


def run_file(args) -> int:
    """`--model FILE`: the file's agreement with MuJoCo alone (the model-by-model table's row)."""
    from harness.agreement import AGREEMENT_TOL, one_model

    row = one_model(args.model.stem, args.model, args.steps, args.samples, args.seed)
    doc = {"agreement_tol": AGREEMENT_TOL, "agreement": [row]}
    stem = f"contact-{args.model.stem}"
    write_json(args.out / f"{stem}.json", doc)
    md = write_markdown(args.out / f"{stem}.md", [f"# Contact: `{args.model}`", "", *agreement_lines(doc)])
    print(f"{row['model']}: one step vs converged MuJoCo max {row['worst']:.1e} ({row['contact_states']} of "
          f"{row['steps']} states in contact); wrote {md}, {md.with_suffix('.json')}")
    return 0 if row["pass"] else 1


def run(args) -> int:
    if args.model is not None:
        return run_file(args)
    doc = cheetah_report(args.steps, args.samples, args.seed)
    stem = "contact-half_cheetah"
    png = plot(args.out / f"{stem}.png", doc)
    write_json(args.out / f"{stem}.json", doc)
    md = write_markdown(args.out / f"{stem}.md", markdown(doc, png.name))
    for a in doc["agreement"]:
        print(f"{a['model']:12s} one step vs converged MuJoCo: max {a['worst']:.1e} "
              f"({a['contact_states']} of {a['steps']} states in contact); replay max gap {a['replay']['max_gap']:.1e}")
    for name, run_ in doc["sequences"].items():
        print(f"half cheetah {name:6s} replay max error: ours {run_['ours']['max_error']:.2e}, "
              f"pybullet {run_['pybullet']['max_error']:.2e}")
    print(f"wrote {md}, {md.with_suffix('.json')}, {png}")
    return 0 if doc["pass"] else 1


def dart_cheetah_contact(urdf: Path = CHEETAH_URDF, h: float = 0.001) -> dict:
    """What DartContact gives DART for the half cheetah: each body's collision shapes (type and
    size, m), their friction and restitution coefficients, the collision detector, and the
    friction DART applies, measured: the cheetah settled on its floor (1000 steps, no torque),
    then pushed to 2 m/s along x; over the next 100 steps the horizontal force on it (total mass
    times its COM's acceleration) over the total normal force, the median."""
    d = DartContact(urdf, h)
    shapes, coefficients = {}, {}
    sizes = {"SphereShape": lambda s: [s.getRadius()], "CylinderShape": lambda s: [s.getRadius(), s.getHeight()],
             "BoxShape": lambda s: list(s.getSize())}
    for w in range(d.world.getNumSkeletons()):
        skel = d.world.getSkeleton(w)
        for i in range(skel.getNumBodyNodes()):
            node = skel.getBodyNode(i)
            name = node.getName() if skel is d.skel else skel.getName()
            for shape_node in node.getShapeNodes():
                shape, dyn = shape_node.getShape(), shape_node.getDynamicsAspect()
                size = np.round(sizes[shape.getType()](shape), 4).tolist()
                shapes.setdefault(name, []).append(f"{shape.getType()} {size}")
                coefficients.setdefault(skel.getName(), set()).add((dyn.getFrictionCoeff(), dyn.getRestitutionCoeff()))
    zero = np.zeros(len(d.joint_names))
    d.set_state(zero, zero)
    for _ in range(1000):
        d.step(zero)
    q, v = d.get_state()
    v[0] += 2.0
    d.set_state(q, v)
    mass, ratios = d.skel.getMass(), []
    for _ in range(100):
        before = d.skel.getCOMLinearVelocity()[0]
        d.step(zero)
        ratios.append(-mass * (d.skel.getCOMLinearVelocity()[0] - before) / h / d.normal_force)
    detector = d.world.getConstraintSolver().getCollisionDetector()
    return {"shapes": {name: ", ".join(s) for name, s in shapes.items()},
            "friction_restitution": {skel: sorted(pairs) for skel, pairs in coefficients.items()},
            "detector": f"{detector.getType()} ({detector.getPrimitiveShapeType().name} shapes)",
            "sliding_friction": float(np.median(ratios)),
            "sliding_speed_after": float(d.skel.getCOMLinearVelocity()[0])}
