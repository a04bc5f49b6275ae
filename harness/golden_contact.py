"""Golden data with contact: MuJoCo's converged next states and contact forces from its own
states in contact, for `cargo test` (tests/golden_contact.rs) to regress our constraint
model without Python.

For each model of harness/agreement.py (the half cheetah, the box on six joints and dropped on a free one, the wiping arm, gymnasium's
hopper, walker2d, ant and humanoid, the contact-feature models), MuJoCo runs the file from its initial state under seeded controls (the
wiping arm: a wiping episode's torques, its tool on the table, replayed on
reference_models/wiping_arm.xml); from --states of its states with a contact (and, where the
trajectory has them, at joint limits), one step of MuJoCo with its solver converged
(tolerance 0, 1000 iterations) gives the next state, the contacts that make constraint rows
(geoms, dist; those detected in their gap are left out) and each contact's force in its
frame (mj_contactForce). Writes
reference_models/golden/contact/<model>.json; deterministic for a seed.

    python -m harness golden-contact --seed 0
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from harness.agreement import controls, models, mujoco_run
from harness.engines.base import MODELS, label_of
from harness.golden import model_sha256

OUT = MODELS / "golden" / "contact"


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--states", type=int, default=12, help="states per model (default %(default)s)")
    ap.add_argument("--out", type=Path, default=OUT)


def trajectory(name: str, steps: int, seed: int, filed) -> dict:
    if name != "wiping_arm":
        return mujoco_run(filed, filed.qpos0.copy(), np.zeros(filed.nv), ctrl=controls(filed, steps, seed, name))
    from harness import wiping_replay

    with tempfile.TemporaryDirectory() as tmp:
        rec, _ = wiping_replay.record("50,50", steps, Path(tmp))
    return mujoco_run(filed, rec["q"][0], rec["v"][0], tau=rec["tau"][:steps])


def case(name: str, path: Path, steps: int, seed: int, count: int) -> dict:
    import mujoco

    from harness.engines.mujoco import converge, load_mjcf

    filed, tight = load_mjcf(path), load_mjcf(path)
    converge(tight.opt)
    run = trajectory(name, steps, seed, filed)
    touching = [t for t, n in enumerate(run["ncon"]) if n]
    limits = [t for t, n in enumerate(run["nl"]) if n and t not in touching]
    picks = [touching[i] for i in np.linspace(0, len(touching) - 1, count).astype(int)]
    picks += limits[: max(1, count // 4)]
    d, f = mujoco.MjData(tight), np.zeros(6)
    states = []
    for t in sorted(set(picks)):
        q, v, tau = run["q"][t], run["v"][t], run["tau"][t]
        mujoco.mj_resetData(tight, d)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_forward(tight, d)
        contacts = []
        for i in range(d.ncon):
            c = d.contact[i]
            mujoco.mj_contactForce(tight, d, i, f)
            if c.exclude:  # detected but outside its margin (in the gap): no rows
                continue
            contacts.append({"geoms": [tight.geom(int(g)).name for g in c.geom], "dist": float(c.dist),
                             "dim": int(c.dim), "force": f[: c.dim].tolist()})
        nl = int(d.nl)
        mujoco.mj_step(tight, d)
        states.append({"q": q.tolist(), "v": v.tolist(), "tau": tau.tolist(), "q_next": d.qpos.tolist(),
                       "v_next": d.qvel.tolist(), "limit_rows": nl, "contacts": contacts})
    return {"engine": "mujoco", "engine_version": mujoco.__version__, "model": label_of(path),
            "model_sha256": model_sha256(label_of(path)), "seed": seed,
            "solver": {"tolerance": 0.0, "iterations": 1000, "ls_tolerance": 1e-15, "ls_iterations": 100},
            "timestep": float(filed.opt.timestep), "states": states}


def run(args) -> int:
    args.out.mkdir(parents=True, exist_ok=True)
    for name, (path, steps) in models().items():
        doc = case(name, path, steps, args.seed, args.states)
        out = args.out / f"{name}.json"
        out.write_text(json.dumps(doc, indent=1) + "\n")
        ncon = sum(len(s["contacts"]) for s in doc["states"])
        print(f"{name:12s} {len(doc['states'])} states, {ncon} contacts -> {out}")
    return 0
