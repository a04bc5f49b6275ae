"""Golden dynamics data: one-step transitions and rollouts from MuJoCo, PyBullet and DART.

Each case loads one model into one reference engine (harness/engines: contacts, joint
limits, link damping, ... switched off) and records 20 random one-step transitions (with
the engine's own mass matrix and bias force) and a 200-step rollout under random
generalized forces. Before a case is written it is checked against the numpy integrator
built from that engine's own M(q) and c(q, v) and passive-force convention
(harness/engines/numpy_step.py); a case that disagrees by more than --tol is not written
and the command exits 1. The file format is a contract with the Rust tests
(tests/golden.rs): reference_models/golden/README.md.

    python -m harness golden --all --seed 0
    python -m harness golden --only cartpole --seed 0 --dry-run
    python -m harness golden --all --seed 0 --twins   # also URDF twin vs MJCF twin
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import zlib
from pathlib import Path
from typing import Callable

import numpy as np

from harness import engines
from harness.engines.base import MODELS, Engine, gym_assets_dir, label_of, path_of
from harness.engines.numpy_step import reference_step, step_error
from harness.engines.sampling import round3, sample_rollout, sample_state, sample_transition, tau_scale
from harness.report import jsonable

OUT_DIR = MODELS / "golden" / "dynamics"
N_ONE_STEP = 20
T_ROLLOUT = 200
ROLLOUT_TAU_FRACTION = 0.2  # rollout torques are this fraction of the one-step scale
ROLLOUT_MAX_SPEED = 100.0  # a rollout faster than this is not "well-behaved": fail loudly
TOLERANCE = 1e-12

# Gymnasium's planar and fixed-base MuJoCo assets (no free/ball joints, tendons, equalities).
GYM_ASSETS = [
    "half_cheetah", "hopper", "walker2d", "walker2d_v5", "inverted_pendulum",
    "inverted_double_pendulum", "reacher", "pusher", "pusher_v5",
    "swimmer", "point",  # also planar: swimmer needs its fluid forces off (see engines/mujoco.py)
]
# ant, humanoid and humanoidstandup (free joints) and swimmer's fluid: harness/golden_free.py.
RK4_EXTRA = {"double_pendulum"}  # our models that get a third MuJoCo case with RK4


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--all", action="store_true", help="generate every case")
    ap.add_argument("--only", nargs="*", default=[], help="cases whose name contains any of these")
    ap.add_argument("--seed", type=int, default=None, help="random seed (required)")
    ap.add_argument("--out", type=Path, default=OUT_DIR)
    ap.add_argument("--tol", type=float, default=TOLERANCE, help="self-consistency tolerance")
    ap.add_argument("--dry-run", action="store_true", help="check, write nothing")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--twins", action="store_true",
                    help="also compare each URDF twin with its MJCF twin (report only)")
    ap.add_argument("--models", type=Path, default=MODELS,
                    help="directory of our MJCF/URDF models (default reference_models/)")


def one_step_samples(e: Engine, rng, scale) -> tuple[list, float]:
    samples, worst = [], 0.0
    for _ in range(N_ONE_STEP):
        q, v, tau = sample_transition(e, rng, scale)
        e.reset()
        e.set_state(q, v)
        e.step(tau)
        q1, v1 = e.get_state()
        M, c = e.dynamics(q, v)
        worst = max(worst, step_error(q1, v1, *reference_step(e, q, v, tau)))
        samples.append({"q": q, "v": v, "tau": tau, "q_next": q1, "v_next": v1,
                        "mass_matrix": M, "bias": c})
    return samples, worst


def rollout(e: Engine, rng, scale) -> tuple[dict, float, float, float]:
    q0, v0, taus = sample_rollout(e, rng, scale, T_ROLLOUT)
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
    assert np.all(np.isfinite(V)) and speed < ROLLOUT_MAX_SPEED, f"{e.label}: rollout reached |v| = {speed}"
    worst = max(step_error(Q[t + 1], V[t + 1], *reference_step(e, Q[t], V[t], taus[t]))
                for t in range(T_ROLLOUT))
    # the numpy integrator left to run on its own: how far round-off grows over the rollout,
    # i.e. the tolerance a correct engine can expect on this rollout
    q, v, drift = q0, v0, 0.0
    for t in range(T_ROLLOUT):
        q, v = reference_step(e, q, v, taus[t])
        drift = max(drift, step_error(Q[t + 1], V[t + 1], q, v))
    return {"q0": q0, "v0": v0, "taus": taus, "q": Q, "v": V}, worst, speed, drift


def model_sha256(label: str) -> str:
    """Of the model file, so a test can tell golden data made from an older version of it."""
    return hashlib.sha256(path_of(label).read_bytes()).hexdigest()


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
                    model_sha256=model_sha256(e.label))
    doc = {
        "engine": e.name, "engine_version": e.version, "model": e.label,
        "passive": e.passive, "integrator": e.integrator.lower(),  # the file format's spelling
        "timestep": e.timestep, "gravity": e.gravity, "joint_names": e.joint_names, "settings": settings,
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


def twin_check(urdf: Path, seed: int) -> dict:
    """Not golden data: how far the URDF twin is from its MJCF twin, as each engine sees them.
    M and c of PyBullet and DART (URDF) against MuJoCo (MJCF) at the same random states;
    MuJoCo's M without its armature, which URDF cannot carry."""
    mj = engines.load("mujoco", urdf.with_suffix(".xml"))
    armature = np.diag([mj.settings["armature_in_mass_matrix"].get(n, 0.0) for n in mj.joint_names])
    out = {}
    for name in ("pybullet", "dart"):
        rng = case_seed(seed, f"twin_{urdf.stem}")
        with engines.load(name, urdf) as e:
            assert e.joint_names == mj.joint_names, f"{urdf.stem}: joint names {e.joint_names} vs {mj.joint_names}"
            dm = dc = 0.0
            for _ in range(N_ONE_STEP):
                q, v = sample_state(mj, rng)
                (Mm, cm), (Me, ce) = mj.dynamics(q, v), e.dynamics(q, v)
                dm = max(dm, float(np.abs(Mm - armature - Me).max()))
                dc = max(dc, float(np.abs(cm - ce).max()))
            passive = {"damping": float(np.abs(mj.damping - e.damping).max()),
                       "stiffness": float(np.abs(mj.stiffness - e.stiffness).max())}
        out[name] = {"mass_matrix": dm, "bias": dc, "passive_params": passive,
                     "armature_dropped": float(np.abs(armature).max())}
    return out


def one_dof(path: Path) -> bool:
    """Whether a model has hinges and slides only (nq = nv); ball and free joints are
    golden-free's (harness/golden_free.py)."""
    import diffosi

    m = diffosi.Model.load(str(path))
    return m.nq == m.nv


def cases(models: Path) -> dict[str, Callable[[], Engine]]:
    """name -> engine factory, in a stable order."""
    out: dict[str, Callable[[], Engine]] = {}
    for xml in filter(one_dof, sorted(models.glob("*.xml"))):
        stem = xml.stem
        out[f"mujoco_{stem}"] = lambda p=xml: engines.load("mujoco", p)
        out[f"mujoco_{stem}_explicit"] = lambda p=xml: engines.load("mujoco", p, eulerdamp=False)
        if stem in RK4_EXTRA:
            out[f"mujoco_{stem}_rk4"] = lambda p=xml: engines.load("mujoco", p, rk4=True)
    assets = gym_assets_dir()
    for name in GYM_ASSETS:
        out[f"mujoco_gym_{name}"] = lambda n=name: engines.load("mujoco", assets / f"{n}.xml")
    for urdf in filter(one_dof, sorted(models.glob("*.urdf"))):
        stem = urdf.stem
        out[f"pybullet_{stem}"] = lambda p=urdf: engines.load("pybullet", p)
        out[f"dart_{stem}"] = lambda p=urdf: engines.load("dart", p)
    return out


def run(args) -> int:
    models = args.models.resolve()
    table = cases(models)
    if args.list:
        print("\n".join(table))
        return 0
    if args.seed is None or not (args.all or args.only):
        print("golden: give --seed and either --all or --only NAME...", file=sys.stderr)
        return 2
    chosen = [n for n in table if args.all or any(s in n for s in args.only)]
    urdfs = [u for u in sorted(models.glob("*.urdf")) if one_dof(u)]
    if not urdfs or not any(models.glob("*.xml")):
        print(f"note: no MJCF/URDF models of ours in {label_of(models)} yet", file=sys.stderr)

    args.out.mkdir(parents=True, exist_ok=True)
    failed = []
    print(f"{'case':36s} {'passive':27s} {'one-step':>8s} {'rollout':>8s} {'free-run':>8s} {'max|v|':>6s}")
    for name in chosen:
        with table[name]() as e:
            doc, stats = generate(name, e, args.seed)
        ok = stats["one_step"] <= args.tol and stats["rollout"] <= args.tol
        print(f"{name:36s} {e.passive:27s} {stats['one_step']:8.1e} {stats['rollout']:8.1e} "
              f"{stats['drift']:8.1e} {stats['max_speed']:6.2f} {'' if ok else 'FAIL'}", flush=True)
        if not ok:
            failed.append(name)
        elif not args.dry_run:
            (args.out / f"{name}.json").write_text(dump(doc))
    if args.twins:
        for urdf in urdfs:
            print(f"twin {urdf.stem}: {json.dumps(twin_check(urdf, args.seed))}")
    if failed:
        print(f"not written, engine disagrees with its own M and c: {failed}", file=sys.stderr)
    return 1 if failed else 0
