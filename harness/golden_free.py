"""Golden data for ball and free joints and fluid forces: MuJoCo's, PyBullet's and DART's
own steps.

For each MuJoCo case, MuJoCo 4 loads the model with contacts and joint limits disabled (and
the fluid the case sets, else the file's) and steps 20 random valid states (every quaternion
normalised, velocities and generalized forces uniform) and one 50-step rollout under random
forces, with the file's integrator or the one the case names. The PyBullet and DART cases
step the same kind of states of the floating arm's URDF twin through the harness's adapters
(harness/engines: their free bases converted to MuJoCo's convention, floating.py). The Rust
test tests/golden_free.rs steps the same states in our engine (its own loader, contacts and
limits off, the engine's passive convention and integrator) and asserts 1e-12. Writes
reference_models/golden/free/<case>.json; the same seed gives the same files.

    python -m harness golden-free --seed 0
"""

from __future__ import annotations

import argparse
import json
import zlib
from pathlib import Path

import numpy as np

from harness.engines.base import MODELS, gym_assets_dir
from harness.engines.mujoco import load_mjcf
from harness.report import jsonable

OUT_DIR = MODELS / "golden" / "free"
N_ONE_STEP, T_ROLLOUT = 20, 50
# A medium in every direction: (density, viscosity, wind)
AIR_AND_WIND = (1000.0, 0.02, (0.5, -1.0, 0.3))
# MuJoCo's case: (model, integrator or None for the file's, fluid or None for the file's)
CASES = {
    "free_ball_euler": ("reference_models/free_ball.xml", "Euler", None),
    "free_ball_rk4": ("reference_models/free_ball.xml", "RK4", None),
    "free_ball_fluid": ("reference_models/free_ball.xml", "RK4", AIR_AND_WIND),
    "floating_arm": ("reference_models/floating_arm.xml", None, None),
    "gym_ant": ("gymnasium:ant.xml", None, None),
    "gym_humanoid": ("gymnasium:humanoid.xml", None, None),
    "gym_humanoidstandup": ("gymnasium:humanoidstandup.xml", None, None),
    "gym_swimmer": ("gymnasium:swimmer.xml", None, None),
}
# The other engines' cases: (engine, reference model whose URDF twin they load)
ENGINE_CASES = {
    "pybullet_floating_arm": ("pybullet", "floating_arm"),
    "dart_floating_arm": ("dart", "floating_arm"),
}


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--out", type=Path, default=OUT_DIR)


def model_path(name: str) -> Path:
    if name.startswith("gymnasium:"):
        return gym_assets_dir() / name.split(":", 1)[1]
    return MODELS.parent / name


def sample_q(m, rng) -> np.ndarray:
    """qpos0 moved by up to 0.5 per coordinate, quaternions normalised."""
    import mujoco

    q = m.qpos0 + rng.uniform(-0.5, 0.5, m.nq)
    free, ball = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)
    for j in range(m.njnt):
        kind, a = int(m.jnt_type[j]), m.jnt_qposadr[j]  # int: a numpy int is not `in` a tuple of enums
        if kind in (free, ball):
            a += 3 if kind == free else 0
            q[a:a + 4] /= np.linalg.norm(q[a:a + 4])
    return q


def mujoco_model(model: str, integrator: str | None = None, fluid: tuple | None = None):
    """MuJoCo's model of a file, contacts and limits off, with the integrator and fluid given."""
    import mujoco

    m = load_mjcf(model_path(model))
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    if integrator:
        m.opt.integrator = {"Euler": mujoco.mjtIntegrator.mjINT_EULER,
                            "RK4": mujoco.mjtIntegrator.mjINT_RK4}[integrator]
    if fluid:
        m.opt.density, m.opt.viscosity, m.opt.wind[:] = fluid
    return m


def inputs(m, name: str, seed: int) -> tuple[list, tuple]:
    """The case's random one-step inputs [(q, v, tau)] and rollout (q0, v0, taus), drawn for
    MuJoCo's model m from the case's own stream."""
    import mujoco

    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    scale = 10.0 * np.maximum(np.diag(full_mass(m, mujoco.MjData(m), m.qpos0)), 1e-3)
    one_step = [(sample_q(m, rng), rng.uniform(-2.0, 2.0, m.nv), rng.uniform(-1.0, 1.0, m.nv) * scale)
                for _ in range(N_ONE_STEP)]
    q0, v0 = sample_q(m, rng), rng.uniform(-1.0, 1.0, m.nv)
    return one_step, (q0, v0, rng.uniform(-1.0, 1.0, (T_ROLLOUT, m.nv)) * scale * 0.2)


def stepped(step, rollout, one_step: list, start: tuple) -> dict:
    """The data of a case: step(q, v, tau) -> (q', v') from each one-step input, and
    rollout(q0, v0, taus) -> (Q, V)."""
    steps = [{"q": q, "v": v, "tau": tau, "q_next": q1, "v_next": v1}
             for (q, v, tau), (q1, v1) in ((x, step(*x)) for x in one_step)]
    qs, vs = rollout(*start)
    return {"one_step": steps, "rollout": {"q0": start[0], "v0": start[1], "taus": start[2], "q": qs, "v": vs}}


SETTINGS = {"tau": "uniform in +-1 times 10 M_ii at qpos0 (armature in M), rollout 0.2 of that"}


def record(name: str, seed: int) -> dict:
    import mujoco

    model, integrator, fluid = CASES[name]
    m = mujoco_model(model, integrator, fluid)
    d = mujoco.MjData(m)

    def step(q, v, tau):
        d.qpos[:], d.qvel[:], d.qfrc_applied[:], d.ctrl[:] = q, v, tau, 0.0
        mujoco.mj_step(m, d)
        return d.qpos.copy(), d.qvel.copy()

    def rollout(q0, v0, taus):
        qs, vs = [q0], [v0]
        for tau in taus:
            q, v = step(qs[-1], vs[-1], tau)
            qs.append(q)
            vs.append(v)
        return qs, vs

    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    integrator = {0: "Euler", 1: "RK4"}[int(m.opt.integrator)]
    return {"engine": "mujoco", "engine_version": mujoco.__version__, "model": model,
            "passive": "implicit_damping" if integrator == "Euler" else "explicit",
            "integrator": integrator, "timestep": m.opt.timestep,
            "nq": m.nq, "nv": m.nv, "joint_names": names,
            "fluid": {"density": m.opt.density, "viscosity": m.opt.viscosity, "wind": m.opt.wind.copy()},
            "settings": {"disableflags": ["contact", "limit"], "seed": seed, **SETTINGS},
            **stepped(step, rollout, *inputs(m, name, seed))}


def record_engine(name: str, seed: int) -> dict:
    """A PyBullet or DART case: the URDF twin through the adapter, sampled as MuJoCo's twin."""
    from harness import engines

    engine, model = ENGINE_CASES[name]
    m = mujoco_model(f"reference_models/{model}.xml")
    with engines.load(engine, model) as e:
        def step(q, v, tau):
            e.reset()
            e.set_state(q, v)
            e.step(tau)
            return e.get_state()

        data = stepped(step, e.rollout, *inputs(m, name, seed))
        return {"engine": e.name, "engine_version": e.version, "model": e.label, "passive": e.passive,
                "integrator": e.integrator, "timestep": e.timestep, "nq": m.nq, "nv": m.nv,
                "joint_names": [e.free.name, *e.joint_names],
                "fluid": {"density": 0.0, "viscosity": 0.0, "wind": [0.0, 0.0, 0.0]},
                "settings": {**e.settings, "seed": seed, **SETTINGS}, **data}


def full_mass(m, d, q) -> np.ndarray:
    import mujoco

    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)  # MuJoCo 4: armature included
    return M


def run(args) -> int:
    args.out.mkdir(parents=True, exist_ok=True)
    for name in [*CASES, *ENGINE_CASES]:
        doc = record(name, args.seed) if name in CASES else record_engine(name, args.seed)
        path = args.out / f"{name}.json"
        path.write_text(json.dumps(jsonable(doc), indent=1) + "\n")
        print(f"wrote {path} (nq {doc['nq']}, nv {doc['nv']}, {doc['integrator']})")
    return 0
