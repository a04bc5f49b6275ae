"""`python -m harness overview`: every task x target x method from the per-target reports, a
missing report listed as missing, and the README block rewritten between its markers only.
Run with `make test`."""

import argparse
import shutil

import pytest

from harness import overview
from harness.report import REPORTS


def test_overview_of_the_committed_reports(tmp_path):
    for path in REPORTS.glob("transfer-*-*.json"):
        shutil.copy(path, tmp_path / path.name)
    (tmp_path / "transfer-half_cheetah-dart.json").unlink()
    assert overview.run(argparse.Namespace(readme=False, reports=tmp_path)) == 0
    doc = overview.collect(tmp_path)
    assert set(doc) == set(overview.TASKS)
    assert doc["half_cheetah"]["missing"] == ["dart"]
    assert list(doc["cartpole"]["environments"]) == ["ours", "mujoco", "pybullet", "dart"]
    wiping = doc["wiping"]["environments"]["mujoco"]
    assert overview.share("wiping", wiping, "UC-Oracle") == 1.0
    assert overview.share("wiping", wiping, "DR") < 1.0  # lower metric is better: DR loses
    text = (tmp_path / "overview.md").read_text()
    assert "No report yet for: DART." in text and "## wiping" in text
    assert (tmp_path / "overview.png").stat().st_size > 10_000


def test_readme_block_replaces_only_the_marked_lines(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("before\n" + overview.MARKERS[0] + "\nold\n" + overview.MARKERS[1] + "\nafter\n")
    overview.rewrite_readme(readme, overview.MARKERS[0] + "\nnew\n" + overview.MARKERS[1])
    assert readme.read_text() == "before\n" + overview.MARKERS[0] + "\nnew\n" + overview.MARKERS[1] + "\nafter\n"
    readme.write_text("no markers\n")
    with pytest.raises(ValueError, match="markers"):
        overview.rewrite_readme(readme, "x")
