"""Report writers shared by the harness's commands: Markdown, JSON and PNG under reports/.

JSON is deterministic (insertion order, Python's shortest round-trip float repr), so
the same inputs give byte-identical files. Plots use matplotlib's Agg backend (no display).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from harness.engines.base import REPO

# In the checkout its reports/; installed from the wheel (REPO is then site-packages), the
# working directory's reports/.
REPORTS = REPO / "reports" if (REPO / "Cargo.toml").is_file() else Path("reports")


def jsonable(x):
    """numpy arrays and scalars (nested in dicts, lists, tuples) as plain Python values."""
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    return x


def write_json(path: Path, doc: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(jsonable(doc), indent=1) + "\n")
    return path


def write_markdown(path: Path, lines: list[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines).rstrip("\n") + "\n")
    return path


def markdown_table(header: list[str], rows: list[list]) -> list[str]:
    """A Markdown table as lines; cells are formatted with str()."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


def plot_lines(path: Path, series: dict[str, np.ndarray], title: str, xlabel: str, ylabel: str,
               hlines: dict[str, float] | None = None, logy: bool = True, floor: float = 1e-18) -> Path:
    """One line per series (x = index), optional labelled horizontal lines (thresholds).
    On a log axis values below `floor` (zeros: exact agreement) are drawn at `floor`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    for name, y in series.items():
        y = np.asarray(y, float)
        ax.plot(np.arange(len(y)), np.maximum(y, floor) if logy else y, label=name, lw=1.2)
    for name, y in (hlines or {}).items():
        ax.axhline(y, color="grey", ls="--", lw=0.8, label=name)
    if logy:
        ax.set_yscale("log")
    ax.set(title=title, xlabel=xlabel, ylabel=ylabel)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})  # no version stamp: same data, same bytes
    plt.close(fig)
    return path
