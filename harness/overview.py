"""The transfer study at a glance: every task x target x method from the per-target reports.

Reads reports/transfer-<task>-<target>.json (the cartpole and the half cheetah as `transfer
--task <task> --target <target>` writes them, the wiping task's too), left by the main job or
by the full study (`make study`), and writes reports/overview.{md,json,png}: per task, each
method's score in our engine (the source, no gap) and in every target, and its share of
UC-Oracle's score in the same engine. With --readme it also rewrites the README's block
between the overview markers: the figure (the user guide's transfer chapter includes the tables
from reports/overview.md when it is built). A report that is missing is
listed as missing, never filled in.

    python -m harness overview --readme
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from harness.report import REPO, REPORTS, markdown_table, write_json, write_markdown

TASKS = {  # task: (score, whether higher is better, its methods)
    "cartpole": ("steps in bounds", True, ("DR", "UC-DiffOSI", "UC-Oracle")),
    "half_cheetah": ("return", True, ("DR", "UC-Average", "UC-DiffOSI", "UC-DiffOSI-joint", "UC-Oracle")),
    "half_cheetah_contact": ("return", True, ("DR", "UC-Average", "UC-DiffOSI-joint", "UC-Oracle")),
    "wiping": ("force MSE (N^2)", False, ("DR", "UC-Average", "UC-DiffOSI", "UC-Oracle")),
}
TARGETS = ("mujoco", "pybullet", "dart")
NAMES = {"ours": "ours (source)", "mujoco": "MuJoCo", "pybullet": "PyBullet", "dart": "DART"}
COLOURS = {"DR": "C0", "UC-Average": "C4", "UC-DiffOSI": "C1", "UC-DiffOSI-joint": "C3", "UC-Oracle": "C2"}
MARKERS = ("<!-- overview:start (python -m harness overview --readme writes this block) -->",
           "<!-- overview:end -->")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--readme", action="store_true", help="rewrite the README's overview block")
    ap.add_argument("--reports", type=Path, default=REPORTS, help="where the per-target reports are")


def scores(task: str, doc: dict) -> tuple[dict, dict]:
    """(the target's, ours) {method: [mean, std]} from one per-target report."""
    if task == "wiping":
        s = doc["summary"]
        return {m: s[m]["target"] for m in s}, {m: s[m]["ours"] for m in s}
    return ({m: r["summary"]["score"] for m, r in doc["methods"].items()},
            {m: s["score"] for m, s in doc["source"].items()})


def collect(reports: Path) -> dict:
    """{task: {"environments": {env: {method: [mean, std]}}, "missing": [...], "commands": {...}}}."""
    out = {}
    for task in TASKS:
        block = {"environments": {}, "missing": [], "commands": {}}
        for target in TARGETS:
            path = reports / f"transfer-{task}-{target}.json"
            if not path.exists():
                block["missing"].append(target)
                continue
            doc = json.loads(path.read_text())
            theirs, ours = scores(task, doc)
            block["environments"].setdefault("ours", ours)
            block["environments"][target] = theirs
            block["commands"][target] = doc.get("meta", {}).get("command") or \
                f"python -m harness transfer --task {task} --target {target}"
        out[task] = block
    return out


def share(task: str, methods: dict, method: str) -> float:
    """A method's score over UC-Oracle's in the same engine (the wiping task: the inverse,
    so that above 100% is better everywhere)."""
    oracle, x = methods["UC-Oracle"][0], methods[method][0]
    return x / oracle if TASKS[task][1] else oracle / x


def markdown(doc: dict, png: str) -> list[str]:
    lines = ["# Transfer overview: every task, target and method", "",
             "Controllers and DiffOSI trained and run on our engine; the \"real world\" is each reference "
             "engine (task performance, mean ± std over episodes; in brackets the share of UC-Oracle's in the "
             "same engine, for the wiping task UC-Oracle's metric over the method's, so that 100% is "
             "UC-Oracle and more is better everywhere).", ""]
    for task, block in doc.items():
        score, higher, methods = TASKS[task]
        envs = block["environments"]
        lines += [f"## {task} ({score}, {'higher' if higher else 'lower'} is better)", ""]
        if envs:
            digits = 0 if higher else 3
            rows = [[m] + [f"{envs[e][m][0]:.{digits}f} ± {envs[e][m][1]:.{digits}f} "
                           f"({100 * share(task, envs[e], m):.0f}%)" if m in envs[e] else "-" for e in envs]
                    for m in methods]
            lines += markdown_table(["Approach"] + [NAMES[e] for e in envs], rows)
        if block["missing"]:
            lines += ["", "No report yet for: " + ", ".join(NAMES[t] for t in block["missing"]) + "."]
        lines.append("")
    lines += [f"![transfer overview]({png})"]
    return lines


def plot(path: Path, doc: dict) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = {task: block for task, block in doc.items() if block["environments"]}
    fig, axes = plt.subplots(1, len(shown), figsize=(4.4 * len(shown), 4), dpi=110, squeeze=False)
    for ax, (task, block) in zip(axes[0], shown.items()):
        score, higher, methods = TASKS[task]
        envs = block["environments"]
        width = 0.8 / len(methods)
        for i, m in enumerate(methods):
            ax.bar(np.arange(len(envs)) + (i - (len(methods) - 1) / 2) * width,
                   [100 * share(task, envs[e], m) if m in envs[e] else 0.0 for e in envs], width, label=m,
                   color=COLOURS[m])
        ax.axhline(100, color="grey", lw=0.8, ls="--")
        ax.set_xticks(range(len(envs)), [NAMES[e].split(" ")[0] for e in envs])
        ax.set(title=f"{task}", ylabel="% of UC-Oracle in the same engine")
        ax.grid(True, axis="y", alpha=0.3)
    # One legend below the panels for every method of every panel.
    shown_methods = {label: handle for ax in axes[0] for handle, label in zip(*ax.get_legend_handles_labels())}
    fig.legend(shown_methods.values(), shown_methods.keys(), loc="lower center", ncol=len(shown_methods), fontsize=9)
    fig.suptitle("Transfer: each method against UC-Oracle, in our engine and in every reference engine")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path


def readme_block() -> str:
    """The overview for the README: the figure from reports/, the tables one link away."""
    line = ("Transfer to MuJoCo, PyBullet and DART, every task and method "
            "([tables](docs/src/transfer.md)):\n\n![transfer overview](reports/overview.png)")
    return "\n".join([MARKERS[0], line, MARKERS[1]])


def rewrite_readme(readme: Path, block: str) -> None:
    text = readme.read_text()
    start, end = text.find(MARKERS[0]), text.find(MARKERS[1])
    if start < 0 or end < start:
        raise ValueError(f"{readme}: no overview markers ({MARKERS[0]} ... {MARKERS[1]})")
    readme.write_text(text[:start] + block + text[end + len(MARKERS[1]):])


def run(args) -> int:
    doc = collect(args.reports)
    png = plot(args.reports / "overview.png", doc)
    write_json(args.reports / "overview.json", doc)
    lines = markdown(doc, png.name)
    write_markdown(args.reports / "overview.md", lines)
    if args.readme:
        rewrite_readme(REPO / "README.md", readme_block())
    print("\n".join(lines))
    return 0
