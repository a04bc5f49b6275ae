"""Draw the PNG figures of the Rust experiments from their JSON (`diffosi reproduce` writes the JSON).

- The context-window study (paper Fig. 4), reports/window-<task>.json ->
  reports/window-<task>.png: UC-DiffOSI's mean |mu_hat - mu| against the control step, one
  line per context window N (N - 1 transitions), log scale; the JSON layout is documented
  in src/experiments/mod.rs.
- Task performance against the true mu, reports/table1-by-mu-cartpole.json (Table 1's
  methods on 10x its episodes) -> reports/by-mu-cartpole.png: per method, the mean score
  of its episodes in equal bins of the true mu's range (`summary.by_mu`, binned by the
  Rust experiments; the episodes per bin under the axis): which poles each method loses.
- The wiping task's higher-dimension study (paper Fig. 6), `--task wiping-dims`:
  reports/wiping-dims.json -> reports/wiping-dims.png: per dimension, the parameter error
  (mean over mu's components of |mu_hat - mu|) of DiffOSI and CMA-ES against evaluations
  (top row) and wall time (bottom row), log-log, mean over runs bold and each run faint
  (src/experiments/wiping_dims.rs).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from harness.report import REPORTS, plot_lines


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--task", default="cartpole")
    ap.add_argument("--reports", type=Path, default=REPORTS, help="where the JSON is and the PNG goes")


def window_figure(doc: dict, out: Path) -> Path:
    """None (no episode still running at that step) is drawn as a gap."""
    series = {
        f"N = {c['context_window']} ({c['transitions']} transition{'s' if c['transitions'] > 1 else ''})":
            np.array([np.nan if e is None else e for e in c["mean_abs_error"]], float)
        for c in doc["curves"]
    }
    title = (f"{doc['task']}: UC-DiffOSI |mu error| vs step "
             f"({len(doc['models'])} models x {doc['episodes_per_model']} episodes)")
    return plot_lines(out, series, title, "control step", "mean |mu_hat - mu|")


# The study whose per-method `by_mu` bins a task's by-mu figure draws (the half cheetah's
# Table 2, 9 episodes per method, is too thin to bin).
TABLES = {"cartpole": "table1-by-mu-cartpole"}


def by_mu_figure(doc: dict, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=110)
    for k, m in enumerate(doc["methods"]):
        bins = m["summary"]["by_mu"]
        centres = [(b["lo"] + b["hi"]) / 2 for b in bins]
        means = [np.nan if b["mean"] is None else b["mean"] for b in bins]
        style = "-" if m["source"] in ("oracle", "diffosi") else "--"
        ax.plot(centres, means, style, marker="o", ms=3.5, lw=1.6 if style == "-" else 1.0,
                color=f"C{k}", label=m["label"])
    first = doc["methods"][0]["summary"]["by_mu"]
    ax.set_xticks([b["lo"] for b in first] + [first[-1]["hi"]])
    counts = ", ".join(str(b["episodes"]) for b in first)
    episodes = len(doc["methods"][0]["episodes"])
    ax.set(title=f"{doc['task']}: task performance vs true mu ({episodes} episodes per method)",
           xlabel=f"true mu (bins; episodes per bin: {counts})", ylabel="mean task metric")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, metadata={"Software": None})
    plt.close(fig)
    return out


def dims_figure(doc: dict, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dims = doc["dimensions"]
    timing = {t["dimension"]: t for t in doc["timing"]}
    fig, axes = plt.subplots(2, len(dims), figsize=(3.2 * len(dims), 5.6), dpi=110, squeeze=False)
    floor = 1e-14
    for col, d in enumerate(dims):
        for solver, colour in (("diffosi", "C0"), ("cmaes", "C3")):
            label = "DiffOSI" if solver == "diffosi" else "CMA-ES"
            evals = np.array([[p["evaluations"] for p in r[solver]] for r in d["runs"]], float)
            errors = np.maximum(np.array([[p["abs_error"] for p in r[solver]] for r in d["runs"]], float), floor)
            secs = np.array(timing[d["dimension"]][f"{solver}_seconds"], float)
            for row, x in ((0, evals), (1, secs)):
                ax = axes[row][col]
                for k in range(len(errors)):
                    ax.plot(x[k], errors[k], color=colour, alpha=0.25, lw=0.8)
                ax.plot(x.mean(axis=0), np.exp(np.log(errors).mean(axis=0)), color=colour, lw=1.8, label=label)
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.grid(True, which="major", alpha=0.3)
        axes[0][col].set_title(f"{d['dimension']}-D")
        axes[0][col].set_xlabel("evaluations (passes over the segments)")
        axes[1][col].set_xlabel("wall time (s)")
    axes[0][0].set_ylabel("mean |mu_hat - mu|")
    axes[1][0].set_ylabel("mean |mu_hat - mu|")
    axes[0][0].legend(fontsize=8)
    fig.suptitle("Wiping: identifying joint stiffness and damping, DiffOSI vs CMA-ES")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, metadata={"Software": None})
    plt.close(fig)
    return out


def draw(reports: Path, source: str, figure, out: str, experiment: str) -> None:
    """figure(the JSON of reports/<source>.json) -> reports/<out>.png; a missing JSON names the
    `diffosi reproduce` run that writes it."""
    path = reports / f"{source}.json"
    if not path.exists():
        raise SystemExit(f"{path} missing: run `diffosi reproduce {experiment}` first")
    print(f"wrote {figure(json.loads(path.read_text()), reports / f'{out}.png')}")


def run(args) -> int:
    if args.task == "wiping-dims":
        draw(args.reports, "wiping-dims", dims_figure, "wiping-dims", args.task)
        return 0
    draw(args.reports, f"window-{args.task}", window_figure, f"window-{args.task}", args.task)
    if args.task in TABLES:
        draw(args.reports, TABLES[args.task], by_mu_figure, f"by-mu-{args.task}", args.task)
    return 0
