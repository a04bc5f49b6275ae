"""Our constraint contact model against MuJoCo, model by model: one step from MuJoCo's own
states in contact and at joint limits, replay divergence, and normal forces.

For each model, MuJoCo runs the MJCF file as it is (its own solver settings) from the
model's initial state under seeded controls (uniform in each actuator's control range,
generalized forces qfrc_actuator; the wiping arm replays the torques of a wiping
episode, so its tool presses on the table). Along that trajectory:

- one step: from --samples of MuJoCo's states, ours against MuJoCo's next state with its
  solver converged (a copy of the model with tolerance 0, 1000 iterations, line search
  tolerance 1e-15: with elliptic cones MuJoCo's tolerance 1e-15 still stops early, by up
  to 4e-7 in qacc) and against MuJoCo at the file's own tolerance (the gap that
  tolerance leaves). Error: max(|dq| / max(1, |q|), |dv| / max(1, |v|)); states split
  by what MuJoCo had in that step (contact rows, limit rows, none);
- normal forces: per state, the total normal force ours reports (Model.contacts under
  the step's generalized forces) against MuJoCo's (mj_contactForce, converged solver);
- replay: ours alone from the same initial state under the same generalized forces,
  against MuJoCo at its file's settings: the step where the two part by more than 1e-6
  and the largest gap. Contact dynamics are chaotic, so a late divergence says little;
  the one-step numbers are the test.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.engines.base import MODELS, gym_assets_dir, label_of
from harness.engines.numpy_step import step_error
from harness.golden import case_seed

AGREEMENT_TOL = 1e-9  # one step from MuJoCo's states, converged solver, relative
PART = 1e-6  # replay: the trajectories have parted


FEATURES = MODELS.parent / "tests" / "data"


def models() -> dict:
    """The models of the report: name -> (MJCF path, steps); the box dropped on a free
    joint tumbles to rest, gymnasium's ant and humanoid (free joints) stand and fall under
    random controls. The wiping arm's episode
    brings its own arm; the feature models (every collider and contact setting, under
    both cones) fall passively for 1.2 s, before their hinge chains near gimbal lock;
    the chain of 50 overlapping spheres (1176 contacts; MuJoCo's converged solve takes
    about a second a step) runs 3 steps."""
    gym = gym_assets_dir()
    return {"half_cheetah": (MODELS / "half_cheetah.xml", 500), "box": (MODELS / "box.xml", 500),
            "free_box": (MODELS / "free_box.xml", 1000),
            "wiping_arm": (MODELS / "wiping_arm.xml", 2000), "hopper": (gym / "hopper.xml", 500),
            "walker2d": (gym / "walker2d.xml", 500), "ant": (gym / "ant.xml", 300),
            "humanoid": (gym / "humanoid.xml", 300),
            "features_pyramidal": (FEATURES / "contact_features_pyramidal.xml", 300),
            "features_elliptic": (FEATURES / "contact_features_elliptic.xml", 300),
            "box_stack": (FEATURES / "box_stack.xml", 500),
            "capsule_box": (FEATURES / "capsule_box.xml", 500),
            "overlapping_chain": (FEATURES / "overlapping_chain.xml", 3)}


def controls(m, steps: int, seed: int, name: str) -> np.ndarray:
    """Seeded controls uniform in each actuator's control range (-1, 1 when unlimited)."""
    rng = case_seed(seed, f"contact_agreement_{name}")
    lo, hi = np.full(m.nu, -1.0), np.full(m.nu, 1.0)
    limited = m.actuator_ctrllimited.astype(bool)
    lo[limited], hi[limited] = m.actuator_ctrlrange[limited].T
    return rng.uniform(lo, hi, (steps, m.nu))


def mujoco_run(m, q0, v0, ctrl=None, tau=None) -> dict:
    """MuJoCo from (q0, v0) under ctrl (or generalized forces tau): states, the
    generalized forces each step applied, and each step's contact and limit row counts."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = q0, v0
    steps = len(ctrl) if ctrl is not None else len(tau)
    q, v, applied, ncon, nl = [d.qpos.copy()], [d.qvel.copy()], [], [], []
    for t in range(steps):
        if ctrl is not None:
            d.ctrl[:] = ctrl[t]
        else:
            d.qfrc_applied[:] = tau[t]
        mujoco.mj_forward(m, d)
        applied.append(d.qfrc_actuator + d.qfrc_applied)
        ncon.append(int(d.ncon))
        nl.append(int(d.nl))
        mujoco.mj_step(m, d)
        q.append(d.qpos.copy())
        v.append(d.qvel.copy())
    return {"q": np.array(q), "v": np.array(v), "tau": np.array(applied), "ncon": ncon, "nl": nl}


def mujoco_step(m, d, q, v, tau) -> tuple:
    """One MuJoCo step from (q, v) under generalized forces tau (warm start cleared), and
    the total normal force of its contacts."""
    import mujoco

    from harness.engines.mujoco import contact_normal_forces

    mujoco.mj_resetData(m, d)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_forward(m, d)
    force = float(contact_normal_forces(m, d).sum())
    mujoco.mj_step(m, d)
    return d.qpos.copy(), d.qvel.copy(), force


def one_model(name: str, path: Path, steps: int, samples: int, seed: int, episode=None) -> dict:
    """Every number of one model's agreement; `episode` = (q0, v0, taus) replaces the
    seeded controls (the wiping arm)."""
    import mujoco

    import diffosi
    from harness.engines.mujoco import converge, load_mjcf

    filed = load_mjcf(path)
    tight = load_mjcf(path)
    converge(tight.opt)
    ours = diffosi.Model.load(str(path)).with_options(contact_model="constraint")
    if episode is None:
        q0, v0 = filed.qpos0.copy(), np.zeros(filed.nv)
        run = mujoco_run(filed, q0, v0, ctrl=controls(filed, steps, seed, name))
    else:
        q0, v0, taus = episode
        run = mujoco_run(filed, q0, v0, tau=taus[:steps])
    taus = run["tau"]
    d_tight, d_filed = mujoco.MjData(tight), mujoco.MjData(filed)
    picks = np.unique(np.linspace(0, len(taus) - 1, min(samples, len(taus))).astype(int))
    kinds: dict = {"contact": [], "limit": [], "free": []}
    filed_err, force_gap, forces = [], [], []
    for t in picks:
        q, v, tau = run["q"][t], run["v"][t], taus[t]
        q1, v1 = ours.step(q, v, tau)
        qt, vt, ft = mujoco_step(tight, d_tight, q, v, tau)
        qf, vf, _ = mujoco_step(filed, d_filed, q, v, tau)
        err = step_error(q1, v1, qt, vt)
        kind = "contact" if run["ncon"][t] else ("limit" if run["nl"][t] else "free")
        kinds[kind].append(err)
        filed_err.append(step_error(qf, vf, qt, vt))
        fo = float(sum(c["normal_force"] for c in ours.contacts(q, v, tau)))
        force_gap.append(abs(fo - ft) / max(1.0, abs(ft)))
        forces.append(ft)
    q, v = ours.step(run["q"][0], run["v"][0], taus[0])
    gap = [step_error(q, v, run["q"][1], run["v"][1])]
    for t in range(1, len(taus)):
        try:
            q, v = ours.step(q, v, taus[t])
        except ValueError:
            break
        gap.append(step_error(q, v, run["q"][t + 1], run["v"][t + 1]))
    worst = max(max(x) for x in kinds.values() if x)
    summary = {k: {"states": len(x), "median": float(np.median(x)) if x else None,
                   "max": float(max(x)) if x else None} for k, x in kinds.items()}
    o = filed.opt
    return {
        "model": name, "file": label_of(path), "steps": len(taus), "samples": len(picks),
        "timestep": float(o.timestep), "integrator": mujoco.mjtIntegrator(o.integrator).name,
        "cone": mujoco.mjtCone(o.cone).name, "file_tolerance": float(o.tolerance),
        "one_step": summary, "worst": worst, "pass": worst <= AGREEMENT_TOL,
        "file_tolerance_gap": {"median": float(np.median(filed_err)), "max": float(max(filed_err))},
        "normal_force": {"max_relative_gap": float(max(force_gap)), "max_total": float(max(forces))},
        "replay": {"steps": len(gap), "first_parted": next((t for t, e in enumerate(gap) if e > PART), None),
                   "max_gap": float(max(gap)), "gap": [float(g) for g in gap]},
        "contact_states": int(sum(c > 0 for c in run["ncon"])),
        "limit_states": int(sum(n > 0 for n in run["nl"])),
    }
