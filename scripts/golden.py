#!/usr/bin/env python3
"""Golden dynamics data: one-step transitions and rollouts from MuJoCo, PyBullet and DART.

Each case loads one model into one reference engine, strips what our smooth
dynamics do not model (contacts, joint limits, link damping, ...), and records
20 random one-step transitions (with the engine's own mass matrix and bias force)
and a 200-step rollout under random generalized forces. Before a case is written
it is checked against a numpy integrator built from that engine's own M(q) and
c(q, v) with that engine's passive-force convention; a case that disagrees by
more than --tol is not written.

The file format is a contract with the Rust tests: reference_models/golden/README.md.

    .venv/bin/python scripts/golden.py --all --seed 0
    .venv/bin/python scripts/golden.py --only cartpole --seed 0 --dry-run
    .venv/bin/python scripts/golden.py --all --seed 0 --twins   # also URDF twin vs MJCF twin
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import importlib.metadata
import json
import os
import sys
import xml.etree.ElementTree as ET
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[1]
OUT_DIR = REPO / "reference_models" / "golden" / "dynamics"
OUR_MODELS = REPO / "reference_models"  # --models changes it (for trying the script elsewhere)

N_ONE_STEP = 20
T_ROLLOUT = 200
TAU_ACCEL = 10.0  # one-step tau_i = U(-1, 1) * TAU_ACCEL * M_ii(q_ref): accelerations of order 10
ROLLOUT_TAU_FRACTION = 0.2  # rollout torques are this fraction of the one-step scale
ROLLOUT_MAX_SPEED = 100.0  # a rollout faster than this is not "well-behaved": fail loudly
TOLERANCE = 1e-12

# Gymnasium's planar and fixed-base MuJoCo assets (no free/ball joints, tendons, equalities).
GYM_ASSETS = [
    "half_cheetah", "hopper", "walker2d", "walker2d_v5", "inverted_pendulum",
    "inverted_double_pendulum", "reacher", "pusher", "pusher_v5",
    "swimmer", "point",  # also planar: swimmer needs its fluid forces off (see mujoco_engine)
]
# Not generated: ant (free joint), humanoid and humanoidstandup (free joint, tendons).
RK4_EXTRA = {"double_pendulum"}  # our models that get a third MuJoCo case with RK4


def gym_assets_dir() -> Path:
    import gymnasium

    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"


# --------------------------------------------------------------------------------------
# What an engine adapter provides
# --------------------------------------------------------------------------------------


@dataclass
class Engine:
    """One model loaded into one engine, ready to step. The numeric fields are per dof,
    in the engine's dof order (asserted equal to the model's joint order)."""

    engine: str
    engine_version: str
    model: str
    passive: str  # explicit | implicit_damping | implicit_damping_stiffness
    integrator: str  # euler | rk4
    timestep: float
    gravity: list
    joint_names: list
    settings: dict
    damping: np.ndarray
    stiffness: np.ndarray
    springref: np.ndarray
    q_ref: np.ndarray
    ranges: list  # (lo, hi) for a limited joint, else None
    set_state: Callable[[np.ndarray, np.ndarray], None]
    get_state: Callable[[], tuple]
    step: Callable[[np.ndarray], None]  # apply generalized forces tau for one step
    dynamics: Callable[[np.ndarray, np.ndarray], tuple]  # (q, v) -> (M, c); may move the state
    reset: Callable[[], None] = lambda: None  # clear history before a one-step sample
    close: Callable[[], None] = lambda: None


# --------------------------------------------------------------------------------------
# The numpy reference step built from an engine's own M and c
# --------------------------------------------------------------------------------------


def passive_force(e: Engine, q, v):
    return -e.damping * v - e.stiffness * (q - e.springref)


def euler_step(e: Engine, q, v, tau):
    """Semi-implicit Euler with the engine's passive convention:
    (M + h D [+ h^2 K]) a = tau - c - D v - K (q [+ h v] - q_spring); v' = v + h a; q' = q + h v'."""
    h = e.timestep
    M, c = e.dynamics(q, v)
    D, K = np.diag(e.damping), np.diag(e.stiffness)
    if e.passive == "explicit":
        lhs, rhs = M, tau - c + passive_force(e, q, v)
    elif e.passive == "implicit_damping":  # MuJoCo Euler: damping at v', stiffness at q
        lhs, rhs = M + h * D, tau - c + passive_force(e, q, v)
    elif e.passive == "implicit_damping_stiffness":  # DART: damping at v', stiffness at q'
        lhs, rhs = M + h * D + h * h * K, tau - c + passive_force(e, q + h * v, v)
    else:
        raise ValueError(e.passive)
    v1 = v + h * np.linalg.solve(lhs, rhs)
    return q + h * v1, v1


def rk4_step(e: Engine, q, v, tau):
    """Classic RK4 on (q, v), passive forces explicit (MuJoCo's mj_RungeKutta)."""
    h = e.timestep

    def acc(q, v):
        M, c = e.dynamics(q, v)
        return np.linalg.solve(M, tau - c + passive_force(e, q, v))

    k1q, k1v = v, acc(q, v)
    k2q, k2v = v + h / 2 * k1v, acc(q + h / 2 * k1q, v + h / 2 * k1v)
    k3q, k3v = v + h / 2 * k2v, acc(q + h / 2 * k2q, v + h / 2 * k2v)
    k4q, k4v = v + h * k3v, acc(q + h * k3q, v + h * k3v)
    q1 = q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
    v1 = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return q1, v1


def reference_step(e: Engine, q, v, tau):
    return rk4_step(e, q, v, tau) if e.integrator == "rk4" else euler_step(e, q, v, tau)


def step_error(q1, v1, q1_ref, v1_ref) -> float:
    """Max-norm error, relative to max(1, |x|) so fast rollouts are judged fairly."""
    eq = np.abs(q1 - q1_ref).max() / max(1.0, np.abs(q1_ref).max())
    ev = np.abs(v1 - v1_ref).max() / max(1.0, np.abs(v1_ref).max())
    return float(max(eq, ev))


# --------------------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------------------


def version(dist: str) -> str:
    return importlib.metadata.version(dist)


@contextlib.contextmanager
def quiet_stdio():
    """Silence C-level stdout/stderr (PyBullet and DART print warnings from C++)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        os.dup2(null.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def rel(path: Path) -> str:
    path = path.resolve()
    return str(path.relative_to(REPO)) if path.is_relative_to(REPO) else str(path)


def nonzero_by_joint(names, values) -> dict:
    return {n: float(x) for n, x in zip(names, values) if x != 0.0}


# --------------------------------------------------------------------------------------
# URDF facts the engines need (read with the standard library, not by any engine)
# --------------------------------------------------------------------------------------

MOVABLE = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slide"}
DIFFOSI_NS = "{urn:diffosi:urdf}"  # our URDF extensions: <diffosi:options>, diffosi:stiffness, ...
DEFAULT_GRAVITY = [0.0, 0.0, -9.81]


@dataclass
class UrdfJoint:
    name: str
    kind: str  # hinge | slide
    limit: tuple | None
    damping: float
    friction: float
    extensions: dict  # other <dynamics> attributes: diffosi:stiffness, diffosi:springref, ...


def local_name(key: str) -> str:
    return key.split("}")[-1]


def read_urdf(path: Path):
    """Movable joints in document order (asserted parent-first), links without <inertial>,
    and the attributes of <diffosi:options>."""
    root = ET.parse(path).getroot()
    links = [l.get("name") for l in root.findall("link")]
    children = {j.find("child").get("link") for j in root.findall("joint")}
    roots = [l for l in links if l not in children]
    assert len(roots) == 1, f"{path}: expected one root link, got {roots}"
    placed, joints = {roots[0]}, []
    for j in root.findall("joint"):
        parent, child = j.find("parent").get("link"), j.find("child").get("link")
        assert parent in placed, f"{path}: joint {j.get('name')} comes before its parent link"
        placed.add(child)
        kind = j.get("type")
        if kind == "fixed":
            continue
        assert kind in MOVABLE, f"{path}: joint type {kind} is not supported"
        lim = j.find("limit")
        limit = None
        if kind != "continuous" and lim is not None:
            lo, hi = float(lim.get("lower", 0)), float(lim.get("upper", 0))
            limit = (lo, hi) if lo < hi else None  # lower = upper (= 0 by default): no limit
        dyn = j.find("dynamics")
        attrs = {local_name(k): float(v) for k, v in (dyn.attrib if dyn is not None else {}).items()}
        joints.append(UrdfJoint(
            name=j.get("name"), kind=MOVABLE[kind], limit=limit,
            damping=attrs.pop("damping", 0.0), friction=attrs.pop("friction", 0.0), extensions=attrs,
        ))
    massless = [l.get("name") for l in root.findall("link")
                if l.find("inertial") is None and l.get("name") != roots[0]]
    options = root.find(f"{DIFFOSI_NS}options")
    return {"root": roots[0], "joints": joints, "massless_links": massless,
            "options": dict(options.attrib) if options is not None else {}}


def timestep_gravity(urdf: Path, facts: dict) -> tuple[float, list, dict]:
    """From the URDF's <diffosi:options> (gravity default -9.81 z), else from the MJCF twin;
    when both exist they must agree."""
    twin = urdf.with_suffix(".xml")
    from_twin = mjcf_facts(twin) if twin.exists() else None
    opts = facts["options"]
    if "timestep" in opts:
        h = float(opts["timestep"])
        g = [float(x) for x in opts["gravity"].split()] if "gravity" in opts else DEFAULT_GRAVITY
        source = {"timestep_gravity_from": f"<diffosi:options> of {rel(urdf)}"}
        if from_twin:
            assert (h, g) == (from_twin["timestep"], from_twin["gravity"]), \
                f"{urdf}: timestep/gravity {h} {g} differ from the MJCF twin's"
            source["mjcf_twin_agrees"] = rel(twin)
        return h, g, source
    assert from_twin, f"{urdf}: no <diffosi:options timestep> and no MJCF twin"
    return from_twin["timestep"], from_twin["gravity"], {"timestep_gravity_from": rel(twin)}


def mjcf_twin_facts(urdf: Path) -> dict | None:
    twin = urdf.with_suffix(".xml")
    return mjcf_facts(twin) if twin.exists() else None


def mjcf_facts(path: Path) -> dict:
    """Timestep, gravity and per-joint passive parameters of an MJCF file, as MuJoCo compiles it."""
    m = load_mjcf(path)
    names = [m.joint(i).name for i in range(m.njnt)]
    return {
        "timestep": float(m.opt.timestep),
        "gravity": [float(g) for g in m.opt.gravity],
        "joint_names": names,
        "stiffness": dict(zip(names, map(float, m.jnt_stiffness))),
        "springref": dict(zip(names, map(float, m.qpos_spring))),
        "armature": dict(zip(names, map(float, m.dof_armature))),
        "damping": dict(zip(names, map(float, m.dof_damping))),
    }


# --------------------------------------------------------------------------------------
# MuJoCo
# --------------------------------------------------------------------------------------

MJ_WARNINGS: list = []


def load_mjcf(path: Path):
    """Compile an MJCF file; its warnings go to MJ_WARNINGS instead of ./MUJOCO_LOG.TXT."""
    import mujoco

    mujoco.set_mju_user_warning(MJ_WARNINGS.append)
    MJ_WARNINGS.clear()
    return mujoco.MjModel.from_xml_path(str(path))


def check_mujoco_model(m, label: str) -> None:
    """Only hinge and slide joints in joint order, and nothing beyond linear passive forces."""
    import mujoco

    assert m.neq == 0 and m.ntendon == 0, f"{label}: equality constraints or tendons"
    one_dof = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    assert all(int(t) in one_dof for t in m.jnt_type), f"{label}: free or ball joints"
    assert m.nq == m.nv == m.njnt and all(m.jnt_qposadr == np.arange(m.njnt)) \
        and all(m.jnt_dofadr == np.arange(m.njnt)), f"{label}: dof order is not joint order"
    # MuJoCo 4 has nonlinear passive terms; our linear passive model must be all there is.
    assert not np.any(m.dof_dampingpoly) and not np.any(m.jnt_stiffnesspoly), f"{label}: polynomial passive"
    assert not np.any(m.body_gravcomp), f"{label}: gravity compensation"


def configure_mujoco(m, label: str, eulerdamp: bool, rk4: bool) -> tuple[dict, str, bool]:
    """Switch off what our smooth dynamics do not model; returns (settings, passive, is_rk4)."""
    import mujoco

    settings: dict = {"tau_applied_via": "qfrc_applied (ctrl = 0)"}
    if MJ_WARNINGS:
        settings["compiler_warnings"] = list(MJ_WARNINGS)
    bit = mujoco.mjtDisableBit
    disabled = ["contact", "limit"]
    m.opt.disableflags |= bit.mjDSBL_CONTACT | bit.mjDSBL_LIMIT
    if np.any(m.dof_frictionloss):  # frictionloss is a constraint in MuJoCo, not smooth dynamics
        m.opt.disableflags |= bit.mjDSBL_FRICTIONLOSS
        disabled.append("frictionloss")
    if m.opt.density or m.opt.viscosity:  # fluid forces (swimmer): our engine has none, so off
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
        passive = "explicit"  # RK4 integrates passive forces explicitly
    else:
        passive = "implicit_damping" if eulerdamp else "explicit"  # Euler: "eulerdamp" trap
    return settings, passive, is_rk4


def mujoco_engine(path: Path, label: str, eulerdamp: bool = True, rk4: bool = False) -> Engine:
    import mujoco

    m = load_mjcf(path)
    check_mujoco_model(m, label)
    settings, passive, is_rk4 = configure_mujoco(m, label, eulerdamp, rk4)
    d, probe = mujoco.MjData(m), mujoco.MjData(m)
    names = [m.joint(i).name for i in range(m.njnt)]
    ranges = [tuple(map(float, m.jnt_range[i])) if m.jnt_limited[i] else None for i in range(m.njnt)]
    damping, stiffness, springref = m.dof_damping.copy(), m.jnt_stiffness.copy(), m.qpos_spring.copy()
    settings["armature_in_mass_matrix"] = nonzero_by_joint(names, m.dof_armature)

    def set_state(q, v):
        d.qpos[:], d.qvel[:] = q, v

    def reset():
        mujoco.mj_resetData(m, d)  # clear time, warmstart and applied forces

    def step(tau):
        d.ctrl[:] = 0.0
        d.qfrc_applied[:] = tau
        mujoco.mj_step(m, d)
        assert d.nefc == 0, f"{label}: constraint rows appeared"
        assert not np.any(d.qfrc_actuator), f"{label}: actuator force with ctrl 0"

    def dynamics(q, v):
        probe.qpos[:], probe.qvel[:] = q, v
        mujoco.mj_forward(m, probe)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, probe, M)  # MuJoCo 4: d.qM is gone; M includes armature
        expected = -damping * v - stiffness * (q - springref)
        assert np.allclose(probe.qfrc_passive, expected, rtol=0, atol=1e-13 * (1 + np.abs(expected).max())), \
            f"{label}: passive forces beyond joint damping and stiffness"
        return M, probe.qfrc_bias.copy()  # M qacc = tau - qfrc_bias + qfrc_passive

    return Engine(
        engine="mujoco", engine_version=mujoco.__version__, model=label, passive=passive,
        integrator="rk4" if is_rk4 else "euler", timestep=float(m.opt.timestep),
        gravity=[float(g) for g in m.opt.gravity], joint_names=names, settings=settings,
        damping=damping, stiffness=stiffness, springref=springref, q_ref=m.qpos0.copy(), ranges=ranges,
        set_state=set_state, get_state=lambda: (d.qpos.copy(), d.qvel.copy()), step=step,
        dynamics=dynamics, reset=reset,
    )


# --------------------------------------------------------------------------------------
# PyBullet
# --------------------------------------------------------------------------------------


def strip_pybullet(p, body: int, links: list, movable: list, facts: dict, settings: dict) -> None:
    """Switch off what our smooth dynamics do not model. Every changeDynamics must come before
    the first calculateMassMatrix / calculateInverseDynamics (see pybullet_engine.dynamics)."""
    import pybullet

    # linearDamping, angularDamping and maxJointVelocity are per multibody, and the C API resets
    # the command's link index to -1 for them: set them alone, never with per-link arguments.
    p.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, maxJointVelocity=1e6)
    settings["link_damping"] = "linearDamping = angularDamping = 0 (default 0.04)"
    settings["maxJointVelocity"] = 1e6  # default 100: silent clamping
    for i in movable:  # URDF limits become limit constraints: widen them and give them no force
        p.changeDynamics(body, i, jointLowerLimit=-1e30, jointUpperLimit=1e30, jointLimitForce=0.0)
    settings["joint_limits"] = "off (bounds +-1e30, jointLimitForce 0)"
    link_index = {p.getJointInfo(body, i)[12].decode(): i for i in links}
    for name in facts["massless_links"]:  # a link without <inertial> gets mass 1, inertia 1,1,1
        p.changeDynamics(body, link_index[name], mass=0.0, localInertiaDiagonal=[0.0, 0.0, 0.0])
    if facts["massless_links"]:
        settings["massless_links"] = {n: "mass 0, inertia 0 (PyBullet default: mass 1, inertia 1)"
                                      for n in facts["massless_links"]}
    for i in [-1] + links:
        p.setCollisionFilterGroupMask(body, i, 0, 0)
    settings["collisions"] = "off (collision filter group and mask 0)"
    # every revolute/prismatic joint gets a velocity motor: zero its force
    p.setJointMotorControlArray(body, movable, pybullet.VELOCITY_CONTROL, forces=[0.0] * len(movable))


def pybullet_engine(urdf: Path) -> Engine:
    with quiet_stdio():  # pybullet prints its build time on import
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

    facts = read_urdf(urdf)
    h, gravity, settings = timestep_gravity(urdf, facts)
    with quiet_stdio():
        p = BulletClient(connection_mode=pybullet.DIRECT)
        # without URDF_USE_INERTIA_FROM_FILE the inertia is recomputed from collision shapes
        body = p.loadURDF(str(urdf), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    p.setGravity(*gravity)  # PyBullet's gravity defaults to 0
    p.setTimeStep(h)  # default 1/240 s
    p.setPhysicsEngineParameter(numSubSteps=0)
    settings.update(fixed_base=True, inertia="URDF_USE_INERTIA_FROM_FILE", numSubSteps=0,
                    tau_applied_via="TORQUE_CONTROL after VELOCITY_CONTROL with force 0")

    links = [i for i in range(p.getNumJoints(body))]
    movable = [i for i in links if p.getJointInfo(body, i)[2] != pybullet.JOINT_FIXED]
    names = [p.getJointInfo(body, i)[1].decode() for i in movable]
    assert names == [j.name for j in facts["joints"]], f"{urdf}: PyBullet dof order {names}"

    strip_pybullet(p, body, links, movable, facts, settings)
    damping = np.array([p.getJointInfo(body, i)[6] for i in movable])
    assert np.allclose(damping, [j.damping for j in facts["joints"]])
    assert not any(p.getJointInfo(body, i)[7] for i in movable), f"{urdf}: joint friction"
    settings["ignored"] = ignored_extras(facts, understood=set())  # no joint springs, no armature
    if only_in_twin := twin_only(urdf, facts):
        settings["mjcf_twin_only"] = only_in_twin
    n = len(movable)

    def set_state(q, v):
        for k, i in enumerate(movable):
            p.resetJointState(body, i, q[k], v[k])

    def get_state():
        s = p.getJointStates(body, movable)
        return np.array([x[0] for x in s]), np.array([x[1] for x in s])

    def step(tau):
        p.setJointMotorControlArray(body, movable, pybullet.TORQUE_CONTROL, forces=list(map(float, tau)))
        p.stepSimulation()
        assert not p.getContactPoints(body), f"{urdf}: contacts"

    def dynamics(q, v):
        # the inverse-dynamics tree is built at the first call and then cached: every
        # changeDynamics above must come before (they do); it excludes joint damping
        M = np.array(p.calculateMassMatrix(body, list(map(float, q))))
        c = np.array(p.calculateInverseDynamics(body, list(map(float, q)), list(map(float, v)), [0.0] * n))
        return M, c

    h = stable_explicit_timestep(h, damping, dynamics(np.zeros(n), np.zeros(n))[0], settings)
    p.setTimeStep(h)
    return Engine(
        engine="pybullet", engine_version=version("pybullet"), model=rel(urdf), passive="explicit",
        integrator="euler", timestep=h, gravity=gravity, joint_names=names,
        settings=settings, damping=damping, stiffness=np.zeros(n), springref=np.zeros(n),
        q_ref=np.zeros(n), ranges=[j.limit for j in facts["joints"]],
        set_state=set_state, get_state=get_state, step=step, dynamics=dynamics,
        close=lambda: p.disconnect(),  # not p.disconnect: BulletClient disconnects on the lookup
    )


def stable_explicit_timestep(h: float, damping: np.ndarray, M: np.ndarray, settings: dict) -> float:
    """Explicit damping is stable only for h * max eig(M^-1 D) < 2. Without the armature that
    PyBullet cannot model, the half cheetah's light feet give 5.3 at the file's 0.01 s and the
    legs blow up in ~35 steps; then use the largest h / k (k = 2, 5, 10, ...) with a margin."""
    lam = float(np.linalg.eigvals(np.linalg.solve(M, np.diag(damping))).real.max())
    for k in (1, 2, 5, 10, 20, 50, 100):
        hk = float(f"{h / k:.6g}")
        if hk * lam < 1.5:
            if k > 1:
                settings["timestep_override"] = {
                    "file": h, "used": hk,
                    "why": f"explicit damping unstable at the file's timestep: h max eig(M^-1 D) = {h * lam:.2f} > 2 "
                           f"(no armature in PyBullet); {hk * lam:.2f} at the used timestep"}
            return hk
    raise ValueError("no stable timestep")


def ignored_extras(facts: dict, understood: set) -> dict:
    """Nonzero diffosi extension attributes of the URDF's <dynamics> (stiffness, armature, ...)
    that the engine did not simulate: {attribute: {joint: value}}. Our test sets them to zero
    in its own model before comparing. (springref is left out: without stiffness it is no force.)"""
    out: dict = {}
    for j in facts["joints"]:
        for key, value in j.extensions.items():
            if value and key not in understood and key != "springref":
                out.setdefault(key, {})[j.name] = value
    return out


def twin_only(urdf: Path, facts: dict, keys=("stiffness", "armature")) -> dict:
    """Passive parameters the MJCF twin has and the URDF does not carry (information only:
    our engine loading the URDF has none of them either)."""
    twin = mjcf_twin_facts(urdf)
    out: dict = {}
    for j in facts["joints"]:
        for key in keys:
            if twin and twin[key].get(j.name) and not j.extensions.get(key):
                out.setdefault(key, {})[j.name] = twin[key][j.name]
    return out


# --------------------------------------------------------------------------------------
# DART
# --------------------------------------------------------------------------------------


def load_dart(urdf: Path, h: float, gravity: list):
    import dartpy as dart

    loader = dart.utils.DartLoader()
    opts = dart.utils.DartLoader.Options()
    # default root joint is FLOATING (6 extra dofs) unless the root link is named "world"
    opts.mDefaultRootJointType = dart.utils.DartLoader.RootJointType.FIXED
    with quiet_stdio():  # DART warns about a zero inertia (it still simulates it exactly)
        # a link without <inertial> gets mass 1 and identity inertia: make it massless instead
        opts.mDefaultInertia = dart.dynamics.Inertia(0.0, np.zeros(3), np.zeros((3, 3)))
        loader.setOptions(opts)
        skel = loader.parseSkeleton(str(urdf))
    assert skel is not None, f"{urdf}: DART could not parse it"
    world = dart.simulation.World()
    world.setTimeStep(h)
    world.setGravity(gravity)
    deact = world.getDeactivationOptions()
    deact.mEnabled = False  # DART 6.20 worlds sleep slow bodies by default (no effect seen here)
    world.setDeactivationOptions(deact)
    world.addSkeleton(skel)
    skel.setSelfCollisionCheck(False)
    return world, skel


def strip_dart(skel, facts: dict, urdf: Path) -> None:
    """No limits of any kind; DART enforces none of a URDF's by default, but say so."""
    for k in range(skel.getNumJoints()):
        skel.getJoint(k).setLimitEnforcement(False)
    for dof in (skel.getDof(i) for i in range(skel.getNumDofs())):
        dof.setVelocityLimits(-np.inf, np.inf)
        dof.setForceLimits(-np.inf, np.inf)
        assert dof.getCoulombFriction() == 0.0, f"{urdf}: joint friction"


def set_dart_passive(skel, facts: dict, urdf: Path) -> tuple:
    """Damping from <dynamics damping> (the loader reads it too); stiffness and springref from
    the diffosi extensions, which DART's loader ignores: given by hand."""
    damping = np.array([j.damping for j in facts["joints"]])
    stiffness = np.array([j.extensions.get("stiffness", 0.0) for j in facts["joints"]])
    springref = np.array([j.extensions.get("springref", 0.0) for j in facts["joints"]])
    for k in range(skel.getNumDofs()):
        dof = skel.getDof(k)
        assert dof.getDampingCoefficient() == damping[k], f"{urdf}: DART read another damping"
        dof.setDampingCoefficient(float(damping[k]))
        dof.setSpringStiffness(float(stiffness[k]))
        dof.setRestPosition(float(springref[k]))
    return damping, stiffness, springref


def dart_engine(urdf: Path) -> Engine:
    import dartpy as dart

    facts = read_urdf(urdf)
    h, gravity, settings = timestep_gravity(urdf, facts)
    world, skel = load_dart(urdf, h, gravity)
    settings.update(root_joint="FIXED", deactivation="off", self_collision="off",
                    joint_limits="off (position enforcement off; velocity and force limits infinite)",
                    tau_applied_via="skeleton.setForces before every step (cleared by the step)")
    if facts["massless_links"]:
        settings["massless_links"] = {n: "mass 0, inertia 0 (DART default: mass 1, identity inertia)"
                                      for n in facts["massless_links"]}
    n = skel.getNumDofs()
    names = [skel.getDof(i).getName() for i in range(n)]
    assert names == [j.name for j in facts["joints"]], f"{urdf}: DART dof order {names}"
    strip_dart(skel, facts, urdf)
    damping, stiffness, springref = set_dart_passive(skel, facts, urdf)
    if stiffness.any():
        settings["stiffness_set_by_hand"] = nonzero_by_joint(names, stiffness)
        settings["springref_set_by_hand"] = nonzero_by_joint(names, springref)
    # DART 6.20 has no joint armature (no get/setArmature in dartpy, none in GenericJoint properties)
    settings["ignored"] = ignored_extras(facts, understood={"stiffness", "springref"})
    if only_in_twin := twin_only(urdf, facts):
        settings["mjcf_twin_only"] = only_in_twin

    def set_state(q, v):
        skel.setPositions(np.asarray(q, float))
        skel.setVelocities(np.asarray(v, float))

    def step(tau):
        skel.setForces(np.asarray(tau, float))
        world.step()
        assert world.getLastCollisionResult().getNumContacts() == 0

    def dynamics(q, v):
        set_state(q, v)
        # M excludes the implicit h D + h^2 K terms (those are getAugMassMatrix);
        # M a + getCoriolisAndGravityForces() = tau + passive
        return np.array(skel.getMassMatrix()), np.array(skel.getCoriolisAndGravityForces())

    return Engine(
        engine="dart", engine_version=dart.__version__, model=rel(urdf),
        passive="implicit_damping_stiffness", integrator="euler", timestep=h,
        gravity=gravity, joint_names=names, settings=settings, damping=damping,
        stiffness=stiffness, springref=springref, q_ref=np.zeros(n),
        ranges=[j.limit for j in facts["joints"]], set_state=set_state,
        get_state=lambda: (np.array(skel.getPositions()), np.array(skel.getVelocities())),
        step=step, dynamics=dynamics,
    )


# --------------------------------------------------------------------------------------
# Sampling, recording, checking
# --------------------------------------------------------------------------------------


def sample_q(e: Engine, rng) -> np.ndarray:
    """Uniform in the range of a limited joint, else reference +- 1 (rad or m)."""
    q = e.q_ref + rng.uniform(-1.0, 1.0, len(e.q_ref))
    for k, r in enumerate(e.ranges):
        if r is not None:
            q[k] = rng.uniform(r[0], r[1])
    return q


def round3(x) -> np.ndarray:
    return np.array([float(f"{v:.3g}") for v in x])


def tau_scale(e: Engine) -> np.ndarray:
    M, _ = e.dynamics(e.q_ref, np.zeros(len(e.q_ref)))
    return round3(TAU_ACCEL * np.diag(M))


def one_step_samples(e: Engine, rng, scale) -> tuple[list, float]:
    samples, worst = [], 0.0
    nv = len(e.joint_names)
    for _ in range(N_ONE_STEP):
        q, v, tau = sample_q(e, rng), rng.uniform(-1.0, 1.0, nv), rng.uniform(-1.0, 1.0, nv) * scale
        e.reset()
        e.set_state(q, v)
        e.step(tau)
        q1, v1 = e.get_state()
        M, c = e.dynamics(q, v)
        worst = max(worst, step_error(q1, v1, *reference_step(e, q, v, tau)))
        samples.append({"q": q, "v": v, "tau": tau, "q_next": q1, "v_next": v1,
                        "mass_matrix": M, "bias": c})
    return samples, worst


def rollout(e: Engine, rng, scale) -> tuple[dict, float, float]:
    nv = len(e.joint_names)
    q0, v0 = sample_q(e, rng), rng.uniform(-1.0, 1.0, nv)
    taus = rng.uniform(-1.0, 1.0, (T_ROLLOUT, nv)) * scale
    e.reset()
    e.set_state(q0, v0)
    Q, V = [q0], [v0]
    for tau in taus:
        e.step(tau)
        q, v = e.get_state()
        Q.append(q)
        V.append(v)
    Q, V = np.array(Q), np.array(V)
    speed = float(np.abs(V).max())
    assert np.all(np.isfinite(V)) and speed < ROLLOUT_MAX_SPEED, f"{e.model}: rollout reached |v| = {speed}"
    # after the rollout (DART's dynamics() moves the skeleton): each step vs the numpy step
    worst = max(step_error(Q[t + 1], V[t + 1], *reference_step(e, Q[t], V[t], taus[t]))
                for t in range(T_ROLLOUT))
    # the numpy integrator left to run on its own: how far round-off grows over the rollout,
    # i.e. the tolerance a correct engine can expect on this rollout
    q, v, drift = q0, v0, 0.0
    for t in range(T_ROLLOUT):
        q, v = reference_step(e, q, v, taus[t])
        drift = max(drift, step_error(Q[t + 1], V[t + 1], q, v))
    return {"q0": q0, "v0": v0, "taus": taus, "q": Q, "v": V}, worst, speed, drift


def model_sha256(model: str) -> str:
    """Of the model file, so a test can tell golden data made from an older version of it."""
    path = gym_assets_dir() / model.split(":", 1)[1] if model.startswith("gymnasium:") else REPO / model
    return hashlib.sha256(path.read_bytes()).hexdigest()


def case_seed(seed: int, name: str) -> np.random.Generator:
    """Independent stream per case, stable whichever cases run."""
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


def generate(name: str, e: Engine, seed: int) -> tuple[dict, dict]:
    rng = case_seed(seed, name)
    scale = tau_scale(e)
    samples, err1 = one_step_samples(e, rng, scale)
    roll_scale = round3(scale * ROLLOUT_TAU_FRACTION)
    roll, err2, speed, drift = rollout(e, rng, roll_scale)
    settings = dict(e.settings, tau_scale=scale, rollout_tau_scale=roll_scale, seed=seed, case=name,
                    model_sha256=model_sha256(e.model))
    doc = {
        "engine": e.engine, "engine_version": e.engine_version, "model": e.model,
        "passive": e.passive, "integrator": e.integrator, "timestep": e.timestep,
        "gravity": e.gravity, "joint_names": e.joint_names, "settings": settings,
        "self_check": {"reference": "numpy step from the engine's own M(q), c(q, v) and passive convention",
                       "one_step_max_error": err1, "rollout_step_max_error": err2,
                       "rollout_free_running_max_error": drift},
        "one_step": samples, "rollout": roll,
    }
    return jsonable(doc), {"one_step": err1, "rollout": err2, "drift": drift, "max_speed": speed}


def dump(doc: dict) -> str:
    """One top-level key per line, one one-step sample per line: small, diffable, exact
    (json writes the shortest repr that round-trips every float)."""
    lines = []
    for k, v in doc.items():
        if k == "one_step":
            body = ",\n  ".join(json.dumps(s) for s in v)
            lines.append(f'"{k}": [\n  {body}\n ]')
        elif k == "rollout":
            body = ",\n  ".join(f"{json.dumps(a)}: {json.dumps(b)}" for a, b in v.items())
            lines.append(f'"{k}": {{\n  {body}\n }}')
        else:
            lines.append(f"{json.dumps(k)}: {json.dumps(v)}")
    return "{\n " + ",\n ".join(lines) + "\n}\n"


def jsonable(x):
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


# --------------------------------------------------------------------------------------
# The cases
# --------------------------------------------------------------------------------------


def our_models(ext: str) -> list[Path]:
    return sorted(OUR_MODELS.glob(f"*.{ext}"))


def twin_check(urdf: Path, seed: int) -> dict:
    """Not golden data: how far the URDF twin is from its MJCF twin, as each engine sees them.
    M and c of PyBullet and DART (URDF) against MuJoCo (MJCF) at the same random states;
    MuJoCo's M without its armature, which URDF cannot carry."""
    twin = urdf.with_suffix(".xml")
    mj = mujoco_engine(twin, rel(twin))
    armature = np.diag([mj.settings["armature_in_mass_matrix"].get(n, 0.0) for n in mj.joint_names])
    out = {}
    for e in (pybullet_engine(urdf), dart_engine(urdf)):
        rng = case_seed(seed, f"twin_{urdf.stem}")
        assert e.joint_names == mj.joint_names, f"{urdf.stem}: joint names {e.joint_names} vs {mj.joint_names}"
        dm = dc = 0.0
        for _ in range(N_ONE_STEP):
            q, v = sample_q(mj, rng), rng.uniform(-1.0, 1.0, len(mj.joint_names))
            (Mm, cm), (Me, ce) = mj.dynamics(q, v), e.dynamics(q, v)
            dm = max(dm, float(np.abs(Mm - armature - Me).max()))
            dc = max(dc, float(np.abs(cm - ce).max()))
        e.close()
        passive = {"damping": float(np.abs(mj.damping - e.damping).max()),
                   "stiffness": float(np.abs(mj.stiffness - e.stiffness).max())}
        out[e.engine] = {"mass_matrix": dm, "bias": dc, "passive_params": passive,
                         "armature_dropped": float(np.abs(armature).max())}
    return out


def cases() -> dict[str, Callable[[], Engine]]:
    """name -> engine factory, in a stable order."""
    out: dict[str, Callable[[], Engine]] = {}
    for xml in our_models("xml"):
        stem = xml.stem
        out[f"mujoco_{stem}"] = lambda p=xml: mujoco_engine(p, rel(p))
        out[f"mujoco_{stem}_explicit"] = lambda p=xml: mujoco_engine(p, rel(p), eulerdamp=False)
        if stem in RK4_EXTRA:
            out[f"mujoco_{stem}_rk4"] = lambda p=xml: mujoco_engine(p, rel(p), rk4=True)
    assets = gym_assets_dir()
    for name in GYM_ASSETS:
        out[f"mujoco_gym_{name}"] = lambda n=name: mujoco_engine(assets / f"{n}.xml", f"gymnasium:{n}.xml")
    for urdf in our_models("urdf"):
        stem = urdf.stem
        out[f"pybullet_{stem}"] = lambda p=urdf: pybullet_engine(p)
        out[f"dart_{stem}"] = lambda p=urdf: dart_engine(p)
    return out


def main(argv=None) -> int:
    global OUR_MODELS
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--all", action="store_true", help="generate every case")
    ap.add_argument("--only", nargs="*", default=[], help="cases whose name contains any of these")
    ap.add_argument("--seed", type=int, required=False, default=None, help="random seed (required)")
    ap.add_argument("--out", type=Path, default=OUT_DIR)
    ap.add_argument("--tol", type=float, default=TOLERANCE, help="self-consistency tolerance")
    ap.add_argument("--dry-run", action="store_true", help="check, write nothing")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--twins", action="store_true",
                    help="also compare each URDF twin with its MJCF twin (report only)")
    ap.add_argument("--models", type=Path, default=OUR_MODELS,
                    help="directory of our MJCF/URDF models (default reference_models/)")
    args = ap.parse_args(argv)
    OUR_MODELS = args.models.resolve()

    table = cases()
    if args.list:
        print("\n".join(table))
        return 0
    if args.seed is None or not (args.all or args.only):
        ap.error("give --seed and either --all or --only NAME...")
    chosen = [n for n in table if args.all or any(s in n for s in args.only)]
    if not our_models("xml") or not our_models("urdf"):
        print(f"note: no MJCF/URDF models of ours in {rel(OUR_MODELS)} yet", file=sys.stderr)

    args.out.mkdir(parents=True, exist_ok=True)
    failed = []
    print(f"{'case':36s} {'passive':27s} {'one-step':>8s} {'rollout':>8s} {'free-run':>8s} {'max|v|':>6s}")
    for name in chosen:
        e = table[name]()
        try:
            doc, stats = generate(name, e, args.seed)
        finally:
            e.close()
        ok = stats["one_step"] <= args.tol and stats["rollout"] <= args.tol
        print(f"{name:36s} {e.passive:27s} {stats['one_step']:8.1e} {stats['rollout']:8.1e} "
              f"{stats['drift']:8.1e} {stats['max_speed']:6.2f} {'' if ok else 'FAIL'}", flush=True)
        if not ok:
            failed.append(name)
        elif not args.dry_run:
            (args.out / f"{name}.json").write_text(dump(doc))
    if args.twins:
        for urdf in our_models("urdf"):
            print(f"twin {urdf.stem}: {json.dumps(twin_check(urdf, args.seed))}")
    if failed:
        print(f"not written, engine disagrees with its own M and c: {failed}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
