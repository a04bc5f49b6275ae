"""The harness prints nothing of MuJoCo's and writes no MUJOCO_LOG.TXT where it runs (issue 40,
item 7): gymnasium's half cheetah sets the deprecated compiler attribute settotalmass, which
MuJoCo 4 reports on every compile. Run from an empty directory as a user would."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

LOAD = """
from harness.engines.base import gym_assets_dir
from harness.engines.mujoco import MJ_WARNINGS, load_mjcf
m = load_mjcf(gym_assets_dir() / "half_cheetah.xml")
print(len(MJ_WARNINGS), round(float(m.body_subtreemass[0]), 9))
"""


def run(tmp_path, *args):
    env = {"PYTHONPATH": str(REPO), "MUJOCO_GL": "egl", "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)


def test_gym_half_cheetah_loads_without_warning_or_log(tmp_path):
    out = run(tmp_path, "-c", LOAD)
    assert out.returncode == 0, out.stderr
    # The warning is kept (a report lists it), the file's total mass of 14 kg applied.
    assert out.stdout.split() == ["1", "14.0"], out.stdout
    assert "settotalmass" not in out.stderr
    assert list(tmp_path.iterdir()) == []


def test_harness_modules_loading_the_gym_half_cheetah_are_quiet(tmp_path):
    """osi-bench reads the file's torso mass from MuJoCo's compile of it (it printed the
    warning and wrote ./MUJOCO_LOG.TXT before every load went through load_mjcf)."""
    out = run(tmp_path, "-c", "from harness import osi_bench; print(osi_bench._gym_mass('half_cheetah', 'torso'))")
    assert out.returncode == 0, out.stderr
    assert float(out.stdout) > 0
    assert "settotalmass" not in out.stdout + out.stderr
    assert list(tmp_path.iterdir()) == []
