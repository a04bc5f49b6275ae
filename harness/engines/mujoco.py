"""MuJoCo adapter: an MJCF file run as MuJoCo runs it, minus what our smooth dynamics
do not model (contacts, limits, frictionloss, fluid forces).

Forces go through qfrc_applied with ctrl 0. Under Euler, MuJoCo integrates joint
damping implicitly ("eulerdamp", our implicit_damping) and stiffness explicitly;
eulerdamp=False (mjDSBL_EULERDAMP) makes damping explicit; RK4 is explicit.
Parameters are edited in the MjModel: body_mass, body_ipos, dof_damping, jnt_stiffness.

native=True keeps the file's frictionloss and fluid forces (MuJoCo's passive-force
treatment is its own either way). friction={joint: f} sets dof_frictionloss = f:
MuJoCo's joint friction, a soft constraint row solved with the dynamics each step.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from harness.engines.base import Engine, label_of, nonzero_by_joint

# Every MuJoCo warning (mju_warning: the compiler's, a step's first NaN) is kept here, never
# written to ./MUJOCO_LOG.TXT nor printed: the harness loads files that warn on purpose
# (gymnasium's half cheetah sets the deprecated compiler attribute settotalmass, which
# HalfCheetah-v5 runs), and a report lists the warnings of the file it ran (`configure`).
MJ_WARNINGS: list = []
mujoco.set_mju_user_warning(MJ_WARNINGS.append)


def converge(option) -> None:
    """MuJoCo's solver run to convergence: tolerance 0 (its 1e-15 still stops early on
    elliptic cones), 1000 iterations, line-search tolerance 1e-15. Its default tolerance
    1e-8 leaves that much in a step in contact."""
    option.tolerance, option.ls_tolerance, option.iterations, option.ls_iterations = 0.0, 1e-15, 1000, 100


def load_mjcf(path: Path):
    """Compile an MJCF file; MJ_WARNINGS then holds its warnings (nothing printed or logged)."""
    MJ_WARNINGS.clear()
    return mujoco.MjModel.from_xml_path(str(path))


def mjcf_facts(path: Path) -> dict:
    """Timestep, gravity and per-joint passive parameters of an MJCF file, as MuJoCo compiles it
    (a joint's first dof and coordinate stand for a ball or free joint's)."""
    m = load_mjcf(path)
    names = [m.joint(i).name for i in range(m.njnt)]
    dof, qpos = m.jnt_dofadr, m.jnt_qposadr
    return {
        "timestep": float(m.opt.timestep),
        "gravity": [float(g) for g in m.opt.gravity],
        "joint_names": names,
        "stiffness": dict(zip(names, map(float, m.jnt_stiffness))),
        "springref": dict(zip(names, map(float, m.qpos_spring[qpos]))),
        "armature": dict(zip(names, map(float, m.dof_armature[dof]))),
        "damping": dict(zip(names, map(float, m.dof_damping[dof]))),
    }


def check_model(m, label: str) -> None:
    """Only hinge and slide joints in joint order, and nothing beyond linear passive forces."""
    assert m.neq == 0 and m.ntendon == 0, f"{label}: equality constraints or tendons"
    one_dof = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    assert all(int(t) in one_dof for t in m.jnt_type), f"{label}: free or ball joints"
    assert m.nq == m.nv == m.njnt and all(m.jnt_qposadr == np.arange(m.njnt)) \
        and all(m.jnt_dofadr == np.arange(m.njnt)), f"{label}: dof order is not joint order"
    # MuJoCo 4 has nonlinear passive terms; our linear passive model must be all there is.
    assert not np.any(m.dof_dampingpoly) and not np.any(m.jnt_stiffnesspoly), f"{label}: polynomial passive"
    assert not np.any(m.body_gravcomp), f"{label}: gravity compensation"


def configure(m, label: str, eulerdamp: bool, rk4: bool, native: bool = False) -> tuple[dict, str, str]:
    """Switch off what our smooth dynamics do not model (native: only contacts and limits);
    returns (settings, passive, integrator)."""
    settings: dict = {"tau_applied_via": "qfrc_applied (ctrl = 0)"}
    if MJ_WARNINGS:
        settings["compiler_warnings"] = list(MJ_WARNINGS)
    bit = mujoco.mjtDisableBit
    disabled = ["contact", "limit"]
    m.opt.disableflags |= bit.mjDSBL_CONTACT | bit.mjDSBL_LIMIT
    if native:
        settings["native"] = "the file's frictionloss and fluid forces kept"
    elif np.any(m.dof_frictionloss):  # frictionloss is a constraint in MuJoCo, not smooth dynamics
        m.opt.disableflags |= bit.mjDSBL_FRICTIONLOSS
        disabled.append("frictionloss")
    if not native and (m.opt.density or m.opt.viscosity):  # fluid forces (swimmer): ours has none
        settings["fluid_off"] = {"density": float(m.opt.density), "viscosity": float(m.opt.viscosity)}
        m.opt.density, m.opt.viscosity = 0.0, 0.0
    spelled = {"EULER": "Euler", "RK4": "RK4", "IMPLICIT": "implicit", "IMPLICITFAST": "implicitfast"}
    file_integrator = spelled.get(mujoco.mjtIntegrator(m.opt.integrator).name.removeprefix("mjINT_"), "other")
    settings["file_integrator"] = file_integrator
    if rk4:
        m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        settings["integrator_override"] = "RK4"
    if m.opt.integrator not in (mujoco.mjtIntegrator.mjINT_EULER, mujoco.mjtIntegrator.mjINT_RK4):
        # implicit linearises Coriolis (O(h) off semi-implicit Euler): none of our models use it
        raise NotImplementedError(f"{label}: integrator {file_integrator}")
    is_rk4 = m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    if not eulerdamp:
        m.opt.disableflags |= bit.mjDSBL_EULERDAMP  # Euler damping explicit (default: implicit)
        disabled.append("eulerdamp")
    settings["disableflags"] = disabled
    if is_rk4:
        return settings, "explicit", "RK4"  # RK4 integrates passive forces explicitly
    # Euler: the "eulerdamp" trap, damping implicit unless disabled; stiffness always explicit
    return settings, "implicit_damping" if eulerdamp else "explicit", "Euler"


class MujocoEngine(Engine):
    name = "mujoco"
    version = mujoco.__version__

    def __init__(self, path: Path, eulerdamp: bool = True, rk4: bool = False, native: bool = False,
                 friction: dict | None = None):
        super().__init__()
        self.model_path, self.label = Path(path), label_of(Path(path))
        m = self.m = load_mjcf(path)
        check_model(m, self.label)
        self.settings, self.passive, self.integrator = configure(m, self.label, eulerdamp, rk4, native)
        names = [m.joint(i).name for i in range(m.njnt)]
        self._constrained = native and bool(np.any(m.dof_frictionloss))
        if friction := self.check_friction(friction, names):
            for joint, value in friction.items():
                m.dof_frictionloss[names.index(joint)] = value
            m.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
            self.settings["joint_friction"] = {j: f"dof_frictionloss {f}" for j, f in friction.items()}
            self._constrained = True
        self.d, self._probe = mujoco.MjData(m), mujoco.MjData(m)
        self.timestep = float(m.opt.timestep)
        gravity_off = bool(m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY)  # <flag gravity="disable"/>
        self.gravity = [0.0, 0.0, 0.0] if gravity_off else [float(g) for g in m.opt.gravity]
        self.joint_names = [m.joint(i).name for i in range(m.njnt)]
        self.body_names = [m.body(i).name for i in range(1, m.nbody)]
        self.ranges = [tuple(map(float, m.jnt_range[i])) if m.jnt_limited[i] else None for i in range(m.njnt)]
        self.damping, self.stiffness = m.dof_damping.copy(), m.jnt_stiffness.copy()
        self.springref, self.q_ref = m.qpos_spring.copy(), m.qpos0.copy()
        self.settings["armature_in_mass_matrix"] = nonzero_by_joint(self.joint_names, m.dof_armature)
        # MuJoCo simulates every parameter our engine reads from an MJCF file; frictionloss (a
        # constraint row) is switched off above unless native or friction asks for it
        off = "frictionloss" in self.settings["disableflags"] and not self._constrained
        self.ignored = {"frictionloss": nonzero_by_joint(self.joint_names, m.dof_frictionloss)} if off else {}

    def _set_timestep(self, h):
        self.m.opt.timestep = h

    def set_state(self, q, v):
        self.d.qpos[:], self.d.qvel[:] = q, v

    def get_state(self):
        return self.d.qpos.copy(), self.d.qvel.copy()

    def reset(self):
        mujoco.mj_resetData(self.m, self.d)  # clear time, warmstart and applied forces

    def step(self, tau):
        d = self.d
        d.ctrl[:] = 0.0
        d.qfrc_applied[:] = tau
        mujoco.mj_step(self.m, d)
        assert self._constrained or d.nefc == 0, f"{self.label}: constraint rows appeared"
        assert not np.any(d.qfrc_actuator), f"{self.label}: actuator force with ctrl 0"

    def dynamics(self, q, v):
        m, probe = self.m, self._probe
        probe.qpos[:], probe.qvel[:] = q, v
        mujoco.mj_forward(m, probe)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, probe, M)  # MuJoCo 4: d.qM is gone; M includes armature
        expected = -self.damping * v - self.stiffness * (q - self.springref)
        assert np.allclose(probe.qfrc_passive, expected, rtol=0, atol=1e-13 * (1 + np.abs(expected).max())), \
            f"{self.label}: passive forces beyond joint damping and stiffness"
        return M, probe.qfrc_bias.copy()  # M qacc = tau - qfrc_bias + qfrc_passive

    def _field(self, kind, owner, field):
        """(array, index) of a parameter in the MjModel; body_mass and body_ipos mean what ours
        do (body_inertia, about the COM, stays)."""
        if kind == "body":
            array = {"mass": self.m.body_mass, "com": self.m.body_ipos}[field]
            return array, self.m.body(owner).id
        array = {"damping": self.m.dof_damping, "stiffness": self.m.jnt_stiffness}[field]
        return array, self.joint_names.index(owner)

    def _set(self, kind, owner, field, value):
        array, i = self._field(kind, owner, field)
        array[i] = value if field == "com" else value[0]
        mujoco.mj_setConst(self.m, self.d)  # body_subtreemass and the other derived constants

    def _get(self, kind, owner, field):
        array, i = self._field(kind, owner, field)
        return np.atleast_1d(array[i]).astype(float)


def contact_normal_forces(m, d) -> np.ndarray:
    """The normal force (N, >= 0) of each of d's contacts, by mj_contactForce: the force in
    the contact frame, whose first axis is the normal. After mj_step these are the forces of
    that step (computed at the state it started from)."""
    f = np.zeros(6)
    out = np.zeros(d.ncon)
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, f)
        out[i] = f[0]
    return out


class GymMujocoEngine(MujocoEngine):
    """An MJCF file run as gymnasium's MuJoCo environments (MujocoEnv) run it: nothing
    switched off (contacts, joint limits and MuJoCo's passive forces on, the file's
    solver), the action written to d.ctrl of the file's motors. set_state is gymnasium's
    reset (mj_resetData, then qpos, qvel and mj_forward); one `step` is one mj_step (a gym
    env step is frame_skip of them under the same ctrl). `step(tau)` takes generalized
    forces like every adapter and writes ctrl = tau / gear on each motor's dof (the other
    dofs' tau must be zero); set_param as MujocoEngine (body_mass keeps body_inertia)."""

    def __init__(self, path: Path):
        super().__init__(path, native=True)
        m = self.m
        m.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT)
        assert all(m.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT) and m.na == 0, f"{self.label}: joint motors"
        self.gear, self.actuated = m.actuator_gear[:, 0].copy(), m.jnt_dofadr[m.actuator_trnid[:, 0]]
        self.free = np.setdiff1d(np.arange(m.nv), self.actuated)
        self.settings.update(disableflags=[], tau_applied_via="d.ctrl = tau / gear (the file's motors)",
                             native="as gymnasium's MujocoEnv: contacts, limits and the file's options on",
                             cone=mujoco.mjtCone(m.opt.cone).name, solver=mujoco.mjtSolver(m.opt.solver).name,
                             solref=m.geom_solref[0].tolist(), solimp=m.geom_solimp[0, :3].tolist(),
                             friction=m.geom_friction[0].tolist(), gear=self.gear.tolist())

    def set_state(self, q, v):
        mujoco.mj_resetData(self.m, self.d)
        self.d.qpos[:], self.d.qvel[:] = q, v
        mujoco.mj_forward(self.m, self.d)

    def step(self, tau):
        tau = np.asarray(tau, float)
        assert not np.any(tau[self.free]), f"{self.label}: force on a dof without a motor"
        self.d.ctrl[:] = tau[self.actuated] / self.gear
        mujoco.mj_step(self.m, self.d)

    @property
    def constrained(self) -> bool:
        """Whether the last step had constraint rows (contacts or joint limits)."""
        return int(self.d.nefc) > 0
