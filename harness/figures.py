"""Draw the PNG figures of the Rust experiments from their JSON (`diffosi reproduce` writes the JSON).

Today: the context-window study (paper Fig. 4), reports/window-<task>.json ->
reports/window-<task>.png: UC-DiffOSI's mean |mu_hat - mu| against the control step, one
line per context window N (N - 1 transitions), log scale; the JSON layout is documented
in src/experiments/mod.rs.
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


def run(args) -> int:
    source = args.reports / f"window-{args.task}.json"
    if not source.exists():
        raise SystemExit(f"{source} missing: run `diffosi reproduce {args.task}` first")
    out = window_figure(json.loads(source.read_text()), args.reports / f"window-{args.task}.png")
    print(f"wrote {out}")
    return 0
