"""Our tangent-space step Jacobians against MuJoCo's on models with ball and free joints.

    python -m harness gradcheck-free [--states 5] [--seed 0]

Gymnasium's ant and humanoid and our free_ball model in a fluid and wind
(reference_models/free_ball.xml, density 1000, viscosity 0.02, wind (0.5, -1, 0.3)), all under
Euler with implicit damping (mjd_transitionFD has no RK4; our RK4 Jacobians are checked against
differences of our own step by tests/tangent_derivatives.rs), contacts and joint limits off: at
seeded states (the reference pose moved
by up to 0.3 along every tangent direction, velocities up to 1, generalized forces up to 10% of
each dof's diagonal of M), our exact `transition_jacobians` (A = d(q', v')/d(q, v), positions
in the tangent space as mjd_transitionFD has them) against MuJoCo's mjd_transitionFD,
centered, eps 1e-6 (its own step differenced; A, and B = d x'/d ctrl compared with ours times
the actuators' gears where the model has motors). Error of a block: max |ours - MuJoCo| /
max(1, max |MuJoCo|). Writes reports/gradcheck-free.{md,json}; exit status 1 above 1e-5.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from harness.engines.base import MODELS, gym_assets_dir
from harness.engines.mujoco import load_mjcf
from harness.report import REPORTS, markdown_table, write_json, write_markdown

EPS = 1e-6
TOLERANCE = 1e-5
WIND = (1000.0, 0.02, (0.5, -1.0, 0.3))
CASES = {"ant": "gymnasium:ant.xml", "humanoid": "gymnasium:humanoid.xml",
         "free_ball in a wind": "reference_models/free_ball.xml"}


def a_error(m, ours, q, v, tau) -> float:
    """Our exact A = d(q', v')/d(q, v) against MuJoCo's mjd_transitionFD (centred, eps EPS) at (q,
    v, tau), relative: max |a - A| / max(1, max |A|)."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_forward(m, d)
    A = np.zeros((2 * m.nv, 2 * m.nv))
    mujoco.mjd_transitionFD(m, d, EPS, True, A, None, None, None)
    a, _ = ours.transition_jacobians(q, v, tau)
    return float(np.abs(a - A).max() / max(1.0, np.abs(A).max()))


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--states", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS)


def load(case: str):
    """(MuJoCo model, ours), both under Euler, contacts and limits off; free_ball in a wind."""
    import mujoco

    import diffosi

    name = CASES[case]
    path = gym_assets_dir() / name.split(":")[1] if name.startswith("gymnasium:") else MODELS.parent / name
    m = load_mjcf(path)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    ours = diffosi.Model.load(str(path)).with_options(contact=False, limits=False, integrator="Euler",
                                                      passive="implicit_damping")
    if case.startswith("free_ball"):
        density, viscosity, wind = WIND
        m.opt.density, m.opt.viscosity, m.opt.wind[:] = density, viscosity, wind
        ours = ours.with_options(density=density, viscosity=viscosity, wind=list(wind))
    return m, ours


def compare(case: str, n_states: int, seed: int) -> dict:
    import mujoco

    m, ours = load(case)
    d = mujoco.MjData(m)
    rng = np.random.default_rng([seed, len(case)])
    worst = {"A": 0.0, "B": 0.0}
    for _ in range(n_states):
        q = m.qpos0.copy()
        mujoco.mj_integratePos(m, q, rng.uniform(-0.3, 0.3, m.nv), 1.0)
        v = rng.uniform(-1.0, 1.0, m.nv)
        d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        tau = rng.uniform(-0.1, 0.1, m.nv) * np.diag(M) / m.opt.timestep
        d.qfrc_applied[:], d.ctrl[:] = tau, 0.0
        A = np.zeros((2 * m.nv, 2 * m.nv))
        B = np.zeros((2 * m.nv, m.nu)) if m.nu else None
        mujoco.mjd_transitionFD(m, d, EPS, True, A, B, None, None)
        a, b = ours.transition_jacobians(q, v, tau)
        worst["A"] = max(worst["A"], float(np.abs(a - A).max() / max(1.0, np.abs(A).max())))
        if m.nu:
            gears = np.zeros((m.nv, m.nu))
            for k in range(m.nu):
                gears[m.jnt_dofadr[m.actuator_trnid[k, 0]], k] = m.actuator_gear[k, 0]
            theirs = b @ gears
            worst["B"] = max(worst["B"], float(np.abs(theirs - B).max() / max(1.0, np.abs(B).max())))
    return {"nq": int(m.nq), "nv": int(m.nv), "nu": int(m.nu),
            "integrator": {0: "Euler", 1: "RK4"}[int(m.opt.integrator)], "states": n_states,
            "errors": worst, "passes": max(worst.values()) <= TOLERANCE}


def run(args) -> int:
    doc = {"eps": EPS, "tolerance": TOLERANCE, "seed": args.seed,
           "cases": {case: compare(case, args.states, args.seed) for case in CASES}}
    rows = [[case, f"{c['nq']}/{c['nv']}/{c['nu']}", c["integrator"], f"{c['errors']['A']:.1e}",
             f"{c['errors']['B']:.1e}" if c["nu"] else "—", "PASS" if c["passes"] else "FAIL"]
            for case, c in doc["cases"].items()]
    lines = ["# Step Jacobians with ball and free joints against MuJoCo's", "",
             f"`python -m harness gradcheck-free --states {args.states} --seed {args.seed}`", "",
             "Our exact `transition_jacobians` (tangent space, mjd_transitionFD's layout) against "
             f"MuJoCo's mjd_transitionFD (centered, eps {EPS:g}), contacts and limits off; error = "
             "max |ours - MuJoCo| / max(1, max |MuJoCo|) over the states; B per control (ours times "
             "the gears).", "",
             *markdown_table(["model", "nq/nv/nu", "integrator", "A", "B", f"≤ {TOLERANCE:g}"], rows)]
    write_markdown(args.out / "gradcheck-free.md", lines)
    write_json(args.out / "gradcheck-free.json", doc)
    for row in rows:
        print("  " + "  ".join(row))
    return 0 if all(c["passes"] for c in doc["cases"].values()) else 1
