"""Replay random states and torques in MuJoCo, PyBullet and DART and in our engine; report agreement.

For each engine, our engine is configured as that engine runs the model
(`engine.ours()`: same file twin, timestep, gravity, integrator, passive-force mode,
what the engine does not simulate zeroed). Two checks:

- one step from --samples random states and torques (harness/engines/sampling.py):
  max |dq|, max |dv| and the relative error max(|dq| / max(1, |q'|), |dv| / max(1, |v'|));
  PASS at <= 1e-12;
- a --steps rollout from one random state under one random torque sequence, the same
  for every engine (uniform in [-1, 1] times 0.2 of the smallest per-dof torque scale
  among the engines), ours run alone vs the engine run alone; the relative error at
  every step, PASS at <= 1e-9 over the whole rollout.

Writes <out>/replay-<model>.md (settings each engine ran with, thresholds, PASS/FAIL),
.json (the numbers; the same seed gives identical files) and .png (rollout error vs
step, log scale). Exit status 1 if any engine fails.

    python -m harness replay --model cartpole --engines mujoco,pybullet,dart --steps 500 --seed 0
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from harness import engines
from harness.engines.numpy_step import step_error
from harness.engines.sampling import sample_rollout, sample_transition, tau_scale
from harness.golden import ROLLOUT_TAU_FRACTION, case_seed
from harness.report import REPORTS, markdown_table, plot_lines, write_json, write_markdown

ONE_STEP_TOL = 1e-12
ROLLOUT_TOL = 1e-9


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--model", required=True, help="reference model name (cartpole, half_cheetah, ...) or a "
                    ".xml / .urdf file")
    ap.add_argument("--engines", default=",".join(engines.ENGINES),
                    help="comma-separated engines (default %(default)s)")
    ap.add_argument("--steps", type=int, default=500, help="rollout length (default %(default)s)")
    ap.add_argument("--samples", type=int, default=100, help="one-step samples (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


def one_step(e: engines.Engine, ours, rng, samples: int) -> dict:
    scale = tau_scale(e)
    dq = dv = rel = 0.0
    for _ in range(samples):
        q, v, tau = sample_transition(e, rng, scale)
        e.reset()
        e.set_state(q, v)
        e.step(tau)
        (q1, v1), (Q1, V1) = e.get_state(), ours.step(q, v, tau)
        dq, dv = max(dq, float(np.abs(q1 - Q1).max())), max(dv, float(np.abs(v1 - V1).max()))
        rel = max(rel, step_error(Q1, V1, q1, v1))
    return {"samples": samples, "tau_scale": scale, "max_dq": dq, "max_dv": dv, "max_error": rel}


def rollout(e: engines.Engine, ours, q0, v0, taus) -> dict:
    Q, V = ours.rollout(q0, v0, taus)
    e.reset()
    e.set_state(q0, v0)
    errors = [step_error(Q[0], V[0], *e.get_state())]
    for t, tau in enumerate(taus):
        e.step(tau)
        errors.append(step_error(Q[t + 1], V[t + 1], *e.get_state()))
    return {"max_error": max(errors), "max_speed": float(np.abs(V).max()), "error": errors}


def compare(loaded: list, model: str, steps: int, samples: int, seed: int) -> tuple[dict, dict]:
    """(rollout start, {engine: its numbers}): the one-step and rollout checks of each loaded
    engine against ours (`engine.ours()`); the rollout's torque scale is the smallest among them."""
    rng = case_seed(seed, f"replay_{model}")
    scale = np.min([tau_scale(e) for e in loaded], axis=0) * ROLLOUT_TAU_FRACTION
    q0, v0, taus = sample_rollout(loaded[0], rng, scale, steps)
    results = {}
    for e in loaded:
        assert e.joint_names == loaded[0].joint_names, f"{e.name}: joints {e.joint_names}"
        ours = e.ours()
        first = one_step(e, ours, case_seed(seed, f"replay_{model}_{e.name}"), samples)
        roll = rollout(e, ours, q0, v0, taus)
        results[e.name] = {
            "version": e.version, "model": e.label, "passive": e.passive, "integrator": e.integrator,
            "timestep": e.timestep, "gravity": e.gravity, "settings": e.settings, "ignored": e.ignored,
            "one_step": first, "rollout": roll,
            "pass": first["max_error"] <= ONE_STEP_TOL and roll["max_error"] <= ROLLOUT_TOL,
        }
    return {"q0": q0, "v0": v0, "tau_scale": scale}, results


def replay(model: str, names: list[str], steps: int, samples: int, seed: int) -> dict:
    """Every number of the report, as a JSON-ready dict."""
    loaded = [engines.load(n, model) for n in names]
    try:
        start, results = compare(loaded, model, steps, samples, seed)
    finally:
        for e in loaded:
            e.close()
    return {
        "model": model, "seed": seed, "steps": steps, "samples": samples,
        "thresholds": {"one_step": ONE_STEP_TOL, "rollout": ROLLOUT_TOL},
        "error": "max(|dq| / max(1, |q|), |dv| / max(1, |v|)), ours vs the engine, max norms",
        "rollout_start": start, "engines": results, "pass": all(r["pass"] for r in results.values()),
    }


def sci(x: float) -> str:
    """1e-9 rather than Python's 1e-09."""
    return f"{x:.0e}".replace("e-0", "e-")


def verdict(ok: bool) -> str:
    return "PASS" if ok else "**FAIL**"


def markdown(doc: dict, png: str) -> list[str]:
    model, res = doc["model"], doc["engines"]
    lines = [
        f"# Replay: {model}, ours vs {', '.join(res)}",
        "",
        f"`python -m harness replay --model {model} --engines {','.join(res)} --steps {doc['steps']} "
        f"--samples {doc['samples']} --seed {doc['seed']}`",
        "",
        f"Result: {verdict(doc['pass'])}. Each engine runs the model with its own settings (below); our "
        "engine runs it the same way (`engine.ours()`: same file twin, timestep, gravity, integrator "
        "and passive-force mode, what the engine does not simulate set to zero). Error = "
        "max(|dq| / max(1, |q|), |dv| / max(1, |v|)). Thresholds: one step <= "
        f"{sci(ONE_STEP_TOL)} over {doc['samples']} random states and torques; rollout <= {sci(ROLLOUT_TOL)} "
        f"at every one of {doc['steps']} steps from one random state under one random torque sequence, "
        "the same for every engine.",
        "",
    ]
    rows = [[name, r["version"], f"`{r['model']}`", r["passive"], r["integrator"], f"{r['timestep']:g}",
             f"{r['one_step']['max_dq']:.1e}", f"{r['one_step']['max_dv']:.1e}",
             f"{r['one_step']['max_error']:.1e}", f"{r['rollout']['max_error']:.1e}",
             f"{r['rollout']['max_speed']:.2f}", verdict(r["pass"])] for name, r in res.items()]
    lines += markdown_table(["engine", "version", "model file", "passive forces", "integrator", "h (s)",
                             "one step max abs dq", "max abs dv", "one step error", "rollout error",
                             "rollout max abs v", "result"], rows)
    lines += ["", f"![rollout error vs step]({png})", "", "## Settings each engine ran with", ""]
    for name, r in res.items():
        lines.append(f"### {name} {r['version']}")
        lines.append("")
        ignored = json.dumps(r["ignored"]) if r["ignored"] else "nothing"
        lines.append(f"- not simulated by {name}, so zeroed in ours: {ignored}")
        lines += [f"- {key}: {json.dumps(value)}" for key, value in r["settings"].items() if key != "ignored"]
        lines.append("")
    start = doc["rollout_start"]
    lines.append(f"Rollout torque scale per dof (N or N m): {np.round(start['tau_scale'], 4).tolist()}.")
    return lines


def run(args) -> int:
    names = [n.strip() for n in args.engines.split(",") if n.strip()]
    unknown = sorted(set(names) - set(engines.ENGINES))
    if unknown or not names:
        print(f"replay: unknown engines {unknown}; choose from {', '.join(engines.ENGINES)}")
        return 2
    doc = replay(args.model, names, args.steps, args.samples, args.seed)
    stem = f"replay-{Path(args.model).stem}"  # a model name, or a file's stem
    png = plot_lines(args.out / f"{stem}.png", {n: r["rollout"]["error"] for n, r in doc["engines"].items()},
                     title=f"{args.model}: ours vs each engine, seed {args.seed}", xlabel="step",
                     ylabel="relative state error (0 drawn at 1e-18)",
                     hlines={f"rollout threshold {sci(ROLLOUT_TOL)}": ROLLOUT_TOL})
    write_json(args.out / f"{stem}.json", doc)
    md = write_markdown(args.out / f"{stem}.md", markdown(doc, png.name))
    for name, r in doc["engines"].items():
        print(f"{name:9s} one step {r['one_step']['max_error']:.1e}  rollout {r['rollout']['max_error']:.1e}  "
              f"{'PASS' if r['pass'] else 'FAIL'}")
    print(f"wrote {md}, {md.with_suffix('.json')}, {png}")
    return 0 if doc["pass"] else 1
