"""Joint identification under another engine's contact: does identifying what the target does
differently (armature, MuJoCo's contact parameters) with the torso mass remove DiffOSI's bias?

The half cheetah's shipped UC (policy seed 0) runs UC-Oracle episodes in each target, as
`transfer --task half_cheetah` does, and every control step's last physics transition is
kept. DiffOSI (bounded Levenberg-Marquardt on our engine, the task's residual scale) then
identifies from windows of W consecutive transitions (every 20th start) with three parameter
sets on our model:
- `mass`: the torso mass alone (what the transfer's DiffOSI does);
- `mass+armature`: and the six leg joints' armature (PyBullet and DART have none);
- `mass+armature+floor`: and the floor's solref (2), solimp (5, the last two pinned) and
  friction (3), the contact parameters a hard contact would be fitted with;
- `mass+armature, unknown constraints`: the mass and the six armatures with the target's
  contact, limit and dry-friction impulses eliminated (DiffOsi constraints="unknown", unit
  force scale): no contact law assumed;
- `mass+armature, unknown constraints, DART's conventions`: the same on our model told how
  DART integrates (springs and dampers implicit, impulses through M alone: passive
  "implicit_damping_stiffness", impulses="mass").
Per target and set: the median over windows of the mass error (kg) and its mean absolute
value, pooled over the episodes, and the share of estimates at a bound of the mass's range.

Then how much those settings matter to the controller: the shipped UC (policy seed 0, fed the
true mass) in our engine with the leg armature, every geom's solimp (a "hardness" x: (0.9 x,
0.8 + 0.15 x, 0.01, 0.5, 2), 0 the file's soft floor, 1 close to a hard contact) and every
geom's sliding friction at the file's values, without armature, at hardness 1, both, and at
friction 0.5: its return over the same episodes.
Writes <out>/joint-osi-half_cheetah.{md,json}; the same seed gives the same json.

    python -m harness joint-osi --episodes 3 --horizon 200
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from harness.report import REPORTS, markdown_table, write_json, write_markdown

LEGS = ("bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot")
# name: (params, lower, upper) on top of the mass (bounds per component)
SETS = {
    "mass": ([], [], []),
    "mass+armature": ([f"joint/{j}/armature" for j in LEGS], [0.0] * 6, [0.3] * 6),
    "mass+armature+floor": (
        [f"joint/{j}/armature" for j in LEGS] + ["geom/floor/solref", "geom/floor/solimp", "geom/floor/friction"],
        [0.0] * 6 + [0.02, 0.2] + [0.0, 0.5, 0.001, 0.49, 1.99] + [0.05, 0.0, 0.0],
        [0.3] * 6 + [0.2, 5.0] + [0.99, 0.9999, 0.1, 0.51, 2.01] + [2.0, 0.5, 0.5]),
    "mass+armature, unknown constraints": ([f"joint/{j}/armature" for j in LEGS], [0.0] * 6, [0.3] * 6),
    "mass+armature, unknown constraints, DART's conventions": ([f"joint/{j}/armature" for j in LEGS], [0.0] * 6,
                                                               [0.3] * 6),
}
# The sets run with constraints="unknown": (our model's passive mode or None for the file's, impulses)
UNKNOWN = {"mass+armature, unknown constraints": (None, "model"),
           "mass+armature, unknown constraints, DART's conventions": ("implicit_damping_stiffness", "mass")}
TARGETS = ("mujoco", "pybullet", "dart")
# (leg armature, contact hardness, friction): the file's, then what other engines differ in
SETTINGS = {"the file's": (0.1, 0.0, 0.4), "no armature": (0.0, 0.0, 0.4), "hardness 1": (0.1, 1.0, 0.4),
            "no armature, hardness 1 (PyBullet's, DART's)": (0.0, 1.0, 0.4), "friction 0.5": (0.1, 0.0, 0.5)}
STRIDE = 20  # control steps between window starts


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--episodes", type=int, default=3, help="UC-Oracle episodes per target (default %(default)s)")
    ap.add_argument("--horizon", type=int, default=200, help="control steps per episode (default %(default)s)")
    ap.add_argument("--windows", default="4,20", help="window lengths W (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


def transitions(setup, target: str) -> list:
    """Per episode: (true mass, its transitions (q, v, tau, q', v', constrained))."""
    from harness.transfer import run_episode

    out = []
    for k in range(len(setup.mu)):
        kept: list = []
        run_episode(setup, target, "UC-Oracle", setup.seeds[0], k, False, kept)
        out.append((float(setup.mu[k][0]), kept))
    return out


def identify(model, episodes: list, window: int, name: str) -> dict:
    """The mass's estimates from every window of every episode against the true mass."""
    import diffosi

    extra, lo, hi = SETS[name]
    options = {}
    if name in UNKNOWN:
        passive, impulses = UNKNOWN[name]
        model = model.with_options(passive=passive) if passive else model
        options = {"constraints": "unknown", "impulses": impulses}
    osi = diffosi.DiffOsi(model, params=["body/torso/mass", *extra], lower=[1.0, *lo], upper=[50.0, *hi],
                          **options)
    est, truth, unexcited = [], [], []
    prior_std = 49.0 / np.sqrt(12.0)  # what an unexcited mass reports (the uniform prior's)
    for mu, kept in episodes:
        for s in range(0, len(kept) - window + 1, STRIDE):
            w = kept[s:s + window]
            r = osi.identify(*(np.array([x[i] for x in w]) for i in range(5)))
            est.append(float(r["params"][0]))
            unexcited.append(bool(r["std"][0] >= 0.99 * prior_std))
            truth.append(mu)
    est, e, unexcited = np.array(est), np.array(est) - np.array(truth), np.array(unexcited)
    excited = np.abs(e[~unexcited])
    return {"windows": len(e), "median_error": float(np.median(e)), "mae": float(np.abs(e).mean()),
            "at_bound": float(np.mean((est <= 1.0 + 1e-9) | (est >= 50.0 - 1e-9))),
            "unexcited": float(unexcited.mean()), "mae_excited": float(excited.mean()) if len(excited) else None}


def report(args) -> dict:
    import diffosi

    from harness.transfer import Setup

    ns = argparse.Namespace(task="half_cheetah", episodes=args.episodes, seeds="0", seed=args.seed,
                            horizon=args.horizon, window=4, joint_window=20, unmodelled="", friction=1.0,
                            policies=None)
    setup = Setup(ns, [])
    model = diffosi.Task("half_cheetah").model()
    windows = [int(w) for w in args.windows.split(",")]
    doc = {"episodes": args.episodes, "horizon": args.horizon, "seed": args.seed, "stride": STRIDE,
           "windows": windows, "sets": {k: v[0] for k, v in SETS.items()}, "targets": {}}
    for target in TARGETS:
        episodes = transitions(setup, target)
        rows = {}
        for window in windows:
            for name in SETS:
                r = rows[f"W={window} {name}"] = identify(model, episodes, window, name)
                print(f"  {target:8s} W={window:2d} {name:20s} median error {r['median_error']:+7.2f} kg, "
                      f"MAE {r['mae']:6.2f} kg, at a bound {100 * r['at_bound']:3.0f}%", flush=True)
        doc["targets"][target] = {"masses": [mu for mu, _ in episodes], "results": rows}
    doc["settings"] = sensitivity(setup)
    return doc


def sensitivity(setup) -> dict:
    """The shipped UC's return in our engine under each of SETTINGS (see the module docs)."""
    task = setup.task
    policy = setup.policies[("uc", setup.seeds[0])]
    out = {}
    for name, setting in SETTINGS.items():
        returns = []
        for k, mu in enumerate(setup.mu):
            model = with_setting(task, mu, setting)
            q, v, total = setup.q0[k], setup.v0[k], 0.0
            for _ in range(setup.horizon):
                action = policy.act(task, q, v, mu)
                tau = task.forces(action)
                q1, v1 = q, v
                for _ in range(task.substeps):
                    q1, v1 = model.step(q1, v1, tau)
                total += task.metric(q, v, action, q1, v1)
                q, v = q1, v1
            returns.append(total)
        out[name] = {"setting": setting, "return": [float(np.mean(returns)), float(np.std(returns))]}
        print(f"  ours, {name:45s} return {np.mean(returns):7.1f}", flush=True)
    return out


def with_setting(task, mu, setting):
    """The task's model at mu with (leg armature, hardness, friction) set on the legs and every geom."""
    armature, hardness, friction = setting
    model = task.model()
    for param, value in task.mu_params(mu).items():
        model.set_param(param, value)
    for joint in LEGS:
        model.set_param(f"joint/{joint}/armature", armature)
    for param in model.param_names():
        if param.endswith("/solimp"):
            model.set_param(param, [0.9 * hardness, 0.8 + 0.15 * hardness, 0.01, 0.5, 2.0])
        elif param.startswith("geom/") and param.endswith("/friction"):
            model.set_param(param, [friction, 0.1, 0.1])
    return model


def markdown(doc: dict) -> list[str]:
    lines = ["# Joint identification under another engine's contact (half cheetah)", "",
             f"`python -m harness joint-osi --episodes {doc['episodes']} --horizon {doc['horizon']} "
             f"--windows {','.join(map(str, doc['windows']))}`", "",
             f"UC-Oracle episodes of the shipped UC (policy seed 0) in each target, {doc['episodes']} episodes x "
             f"{doc['horizon']} control steps; DiffOSI on our model from windows of W consecutive transitions "
             f"(every {doc['stride']}th start). Mass error = estimate - true torso mass (kg). A window leaves "
             "the mass unexcited when it cannot tell it (with the constraints unknown: every body whose "
             "motion the torso's weight shows in may touch), and the estimate stays at its start, the "
             "model's 6.25 kg.", ""]
    rows = []
    for target, t in doc["targets"].items():
        for key, r in t["results"].items():
            excited = "-" if r["mae_excited"] is None else f"{r['mae_excited']:.2f}"
            rows.append([target, key, f"{r['median_error']:+.2f}", f"{r['mae']:.2f}", f"{100 * r['at_bound']:.0f}%",
                         f"{100 * r['unexcited']:.0f}%", excited, r["windows"]])
    lines += markdown_table(["target", "window, parameters", "median mass error (kg)", "mass MAE (kg)",
                             "at a bound", "mass unexcited", "MAE where excited (kg)", "windows"], rows)
    lines += ["", "Parameter sets: " + "; ".join(f"`{k}`: torso mass" + (" + " + ", ".join(v) if v else "")
                                                  for k, v in doc["sets"].items()) + ".", "",
              "## How much those settings matter to the controller", "",
              "The shipped UC (policy seed 0, fed the true mass) in our engine, the same episodes, with the "
              "leg armature, the contact's hardness (every geom's solimp, see the command's help) and every "
              "geom's friction set as listed:", ""]
    base = doc["settings"]["the file's"]["return"][0]
    lines += markdown_table(["settings", "(armature, hardness, friction)", "return", "of the file's"],
                            [[name, r["setting"], f"{r['return'][0]:.0f} ± {r['return'][1]:.0f}",
                              f"{100 * r['return'][0] / base:.0f}%"] for name, r in doc["settings"].items()])
    return lines


def run(args) -> int:
    doc = report(args)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "joint-osi-half_cheetah.json", doc)
    write_markdown(args.out / "joint-osi-half_cheetah.md", markdown(doc))
    print(f"wrote {args.out / 'joint-osi-half_cheetah.md'} and .json")
    return 0
