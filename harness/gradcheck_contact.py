"""Step Jacobians in contact against finite differences of our step and of MuJoCo's.

    python -m harness gradcheck --contact --model hopper [--states 5] [--seed 0]

gymnasium's hopper or half cheetah run as their files say (contacts, limits, the file's
options; ours: the constraint model), MuJoCo's solver converged (tolerance 0). States
come from MuJoCo's own trajectory under seeded controls (harness.agreement's), taken
evenly among the steps with contacts. Parameters: the torso's mass and COM, the first
motor's joint damping, and the floor's friction, solref and solimp (MuJoCo mixes a
pair's values from its geoms at every step, so an edit of its MjModel arrays means what
ours does).

A contact solution is piecewise smooth in its inputs: a stencil that crosses a switch (a
contact appearing, a row turning active or inactive, friction between stick and slip)
differences two pieces. Each block is therefore differenced twice, with the steps of
harness.gradcheck times SCALE and with steps SHRINK times smaller; where the two disagree by more
than AGREE (relative to the block) the state is skipped for that block and counted. The
error of a block (harness.gradcheck.block_error) is the worst over the states kept.
A parameter can sit on a kink at every state: where two geoms' values tie (MuJoCo mixes
the larger friction) or solref's time constant equals refsafe's bound 2h (the half
cheetah's floor has both), our derivative is the mean of the one-sided ones, which
central differences approach only at O(step); such rows show every state skipped. The
check fails on any kept block above its threshold, or a state block with no state kept.
"""

from __future__ import annotations

import numpy as np

from harness.agreement import controls, mujoco_run, mujoco_step
from harness.gradcheck import THRESHOLDS, block_error, exact_blocks, fd_blocks, fmt, row_of
from harness.report import REPORTS, markdown_table, write_json, write_markdown

SCALE = 1.0 / 64.0  # contact is stiff: harness.gradcheck's steps times this (truncation ~1e-9)
SHRINK = 8.0  # the second stencil's steps are this much smaller
AGREE = 1e-7  # two stencils agree: no switch (or kink) inside the larger one
ZERO_SCALE = 1e-6  # the size of a zero parameter component, for its step
SETTLE = 300  # MuJoCo steps before states are taken: the feet on the floor
PARAMS = ("body/torso/mass", "body/torso/com", "geom/floor/friction", "geom/floor/solref", "geom/floor/solimp")


class ConvergedMujoco:
    """mj_step of a file as it is, solver converged, from a set state with generalized
    forces through qfrc_applied (warm start cleared); parameters named as ours: body mass
    (the inertia about the COM kept) and COM, joint damping, geom friction, solref, solimp."""

    def __init__(self, path):
        import mujoco

        from harness.engines.mujoco import converge, load_mjcf

        self.m = load_mjcf(path)
        converge(self.m.opt)
        self.d = mujoco.MjData(self.m)

    def step(self, q, v, tau):
        return mujoco_step(self.m, self.d, q, v, tau)[:2]

    def _field(self, name):
        kind, owner, field = name.split("/")
        m = self.m
        arrays = {
            ("body", "mass"): (m.body_mass, m.body), ("body", "com"): (m.body_ipos, m.body),
            ("joint", "damping"): (m.dof_damping, lambda j: m.joint(j).dofadr),
            ("geom", "friction"): (m.geom_friction, m.geom), ("geom", "solref"): (m.geom_solref, m.geom),
            ("geom", "solimp"): (m.geom_solimp, m.geom),
        }
        if (kind, field) not in arrays:
            raise ValueError(f"MuJoCo oracle: no parameter {name}")
        array, index = arrays[kind, field]
        i = index(owner)
        return array, int(np.atleast_1d(getattr(i, "id", i))[0])

    def get_param(self, name):
        array, i = self._field(name)
        return np.atleast_1d(array[i]).astype(float).copy()

    def set_param(self, name, value):
        import mujoco

        array, i = self._field(name)
        array[i] = value if array.ndim > 1 else value[0]
        mujoco.mj_setConst(self.m, self.d)  # invweight0, as ours recomputes it


def contact_states(m, name: str, n: int, seed: int) -> list:
    """n (q, v, tau) of MuJoCo model m's trajectory under seeded controls, evenly among the
    steps after SETTLE that had contacts."""
    run = mujoco_run(m, m.qpos0.copy(), np.zeros(m.nv), ctrl=controls(m, SETTLE + 20 * n, seed, name))
    touching = [t for t, c in enumerate(run["ncon"]) if c and t >= SETTLE]
    if len(touching) < n:
        raise RuntimeError(f"gradcheck --contact: {name} touched its floor in {len(touching)} steps")
    picks = [touching[k] for k in np.linspace(0, len(touching) - 1, n).astype(int)]
    return [(run["q"][t], run["v"][t], run["tau"][t]) for t in picks]


def param_steps(name, p):
    """H |p_i|, H of harness.gradcheck; where p_i = 0, H ZERO_SCALE for a friction or
    solimp (MuJoCo clamps a zero friction to 1e-5 and a zero impedance to 1e-4: a stencil
    from 0 stays in the clamped piece instead of straddling its kink), else H."""
    from harness.gradcheck import H

    clamped = name.rsplit("/", 1)[-1] in ("friction", "solimp")
    return H * np.where(p != 0.0, np.abs(p), ZERO_SCALE if clamped else 1.0)


def compare(model, oracle, states, params) -> dict:
    """{row: {"error", "kept", "skipped"}}: the worst block error over the states where two
    stencils agree on every block of the row, and how many states were kept and skipped."""
    rows: dict = {}
    for q, v, tau in states:
        exact = exact_blocks(model, q, v, tau, params)
        wide = fd_blocks(oracle, q, v, tau, params, param_steps, scale=SCALE)
        narrow = fd_blocks(oracle, q, v, tau, params, param_steps, scale=SCALE / SHRINK)
        by_row: dict = {}
        for key in exact:
            by_row.setdefault(row_of(*key), []).append(key)
        for name, keys in by_row.items():
            row = rows.setdefault(name, {"error": 0.0, "kept": 0, "skipped": 0})
            rho = {k: np.maximum(wide[k][1], narrow[k][1]) for k in keys}
            if any(block_error(narrow[k][0], wide[k][0], rho[k]) > AGREE for k in keys):
                row["skipped"] += 1
                continue
            row["kept"] += 1
            row["error"] = max(row["error"], *(block_error(exact[k], *narrow[k]) for k in keys))
    return rows


def gradcheck_contact(name: str, n_states: int, seed: int) -> dict:
    import mujoco

    import diffosi
    from harness.engines.base import gym_assets_dir

    path = gym_assets_dir() / f"{name}.xml"
    ours = diffosi.Model.load(str(path))
    oracle = ConvergedMujoco(path)
    first_motor = oracle.m.joint(int(oracle.m.actuator_trnid[0, 0])).name
    params = [*PARAMS, f"joint/{first_motor}/damping"]
    states = contact_states(oracle.m, name, n_states, seed)
    vs_ours, vs_mujoco = compare(ours, ours, states, params), compare(ours, oracle, states, params)
    rows = []
    for row, r in vs_ours.items():
        m = vs_mujoco[row]
        errors = {"ours_fd": r["error"] if r["kept"] else None, "mujoco_fd": m["error"] if m["kept"] else None}
        rows.append({"block": row, **errors, "skipped_ours": r["skipped"], "skipped_mujoco": m["skipped"],
                     "pass": all(x is None or x <= THRESHOLDS[k] for k, x in errors.items())})
    return {"model": name, "file": str(path.name), "mujoco": mujoco.__version__, "states": n_states,
            "seed": seed, "timestep": float(oracle.m.opt.timestep), "params": params,
            "thresholds": THRESHOLDS, "agree": AGREE, "shrink": SHRINK, "rows": rows,
            "pass": all(r["pass"] for r in rows)
            and all(r["ours_fd"] is not None for r in rows if r["block"].startswith("d"))}


def markdown(doc: dict) -> list:
    t = doc["thresholds"]
    lines = [
        f"# Gradient check in contact: {doc['model']}",
        "",
        f"Our step Jacobians (constraint model) vs finite differences of our step (ours-FD) and of MuJoCo "
        f"{doc['mujoco']}'s mj_step with its solver converged (MuJoCo-FD), on gymnasium's `{doc['file']}` as "
        f"the file runs it (h = {doc['timestep']} s), at {doc['states']} states in contact along MuJoCo's "
        f"trajectory under seeded controls (seed {doc['seed']}). Each block is differenced with two step sizes "
        f"({doc['shrink']:.0f}x apart); a state whose two differences disagree by more than {doc['agree']:.0e} "
        f"(a switch of the contact solution inside the stencil) is skipped for that block and counted. Error: "
        f"the worst over the kept states of ||J - J_fd|| / ||J_fd|| (harness/gradcheck.py). Thresholds: "
        f"ours-FD <= {t['ours_fd']:.0e}, MuJoCo-FD <= {t['mujoco_fd']:.0e}; — = every state skipped.",
        "",
    ]
    cells = [[r["block"], fmt(r["ours_fd"]), fmt(r["mujoco_fd"]), r["skipped_ours"], r["skipped_mujoco"],
              "PASS" if r["pass"] else "FAIL"] for r in doc["rows"]]
    lines += markdown_table(["block", "vs ours-FD", "vs MuJoCo-FD", "skipped (ours)", "skipped (MuJoCo)",
                             "result"], cells)
    lines += ["", f"**{'PASS' if doc['pass'] else 'FAIL'}**"]
    return lines


def run(args) -> int:
    doc = gradcheck_contact(args.model, args.states, args.seed)
    lines = markdown(doc)
    out = args.out if args.out is not None else REPORTS
    write_markdown(out / f"gradcheck-contact-{args.model}.md", lines)
    write_json(out / f"gradcheck-contact-{args.model}.json", doc)
    print("\n".join(lines))
    return 0 if doc["pass"] else 1
