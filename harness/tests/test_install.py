"""The harness as a user installs it: the wheel built from this checkout and diffosi[harness]'s
dependencies installed offline (pip --no-index, only the wheel and the wheelhouse `make
install-test` fills) into a fresh venv, then, from a directory outside the checkout,
`python -m harness check` on a robot file and `gymnasium.make("diffosi/CartPole-v0")` with no
import of ours. Run by `make install-test` (over a minute: not part of `make test`).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
WHEELHOUSE = Path(os.environ.get("DIFFOSI_WHEELHOUSE", REPO / ".venv" / "wheelhouse"))
# The child processes see neither the checkout (no PYTHONPATH) nor a display.
ENV = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")} | {"MUJOCO_GL": "egl"}


def run(args, cwd, check=True):
    done = subprocess.run([str(a) for a in args], cwd=cwd, env=ENV, capture_output=True, text=True)
    if check and done.returncode != 0:
        raise AssertionError(f"{args} exited {done.returncode}:\n{done.stdout}\n{done.stderr}")
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(python of the fresh venv, a working directory outside the checkout)."""
    assert (WHEELHOUSE / ".filled").exists(), f"no wheelhouse at {WHEELHOUSE}: `make install-test` fills it"
    tmp = tmp_path_factory.mktemp("install")
    maturin = Path(sys.executable).parent / "maturin"
    run([maturin, "build", "--release", "--locked", "--offline", "--quiet", "-o", tmp / "dist"], cwd=REPO)
    run([sys.executable, "-m", "venv", tmp / "venv"], cwd=tmp)
    python = tmp / "venv" / "bin" / "python"
    run([python, "-m", "pip", "install", "--quiet", "--no-index", "--find-links", tmp / "dist",
         "--find-links", WHEELHOUSE, "diffosi[harness]"], cwd=tmp)
    work = tmp / "work"
    work.mkdir()
    return python, work


def test_the_installed_harness_is_the_wheels(installed):
    python, work = installed
    out = run([python, "-c", "import harness, diffosi; print(harness.__file__); print(diffosi.__file__)"], cwd=work)
    site = python.parent.parent / "lib"
    for line in out.stdout.split():
        assert Path(line).resolve().is_relative_to(site.resolve()), line


def test_check_runs_from_outside_the_checkout(installed):
    python, work = installed
    robot = work / "pendulum.urdf"  # a user's own file, outside both checkout and venv
    robot.write_text((REPO / "reference_models" / "pendulum.urdf").read_text())
    done = run([python, "-m", "harness", "check", robot.name, "--samples", "3", "--steps", "20"], cwd=work, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    report = json.loads((work / "reports" / "check-pendulum.json").read_text())  # reports/ of the cwd
    for engine in ("mujoco", "pybullet", "dart"):
        row = report["engines"][engine]
        assert row["loaded"], row
        assert row["one_step_error"] <= 1e-9, (engine, row["one_step_error"])


def test_check_of_a_broken_file_exits_2(installed):
    python, work = installed
    (work / "broken.urdf").write_text("<robot name='r'><link name='a'>\n")
    done = run([python, "-m", "harness", "check", "broken.urdf", "--out", "out"], cwd=work, check=False)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "broken.urdf" in done.stdout + done.stderr
    assert "Traceback" not in done.stderr


def test_a_command_without_its_package_says_which(installed):
    python, work = installed
    done = run([python, "-m", "harness", "bench", "--quick"], cwd=work, check=False)
    assert done.returncode == 2
    assert "needs the Python package pinocchio" in done.stderr and "Traceback" not in done.stderr


GYM = """
import sys, json, gymnasium, numpy as np
lazy = "harness.gym_env" not in sys.modules and "diffosi" not in sys.modules
env = gymnasium.make("diffosi/CartPole-v0", mu=0.3, render_mode="rgb_array")
obs, _ = env.reset(seed=7)
obs, reward, *_ = env.step(np.array([0.5]))
frame = env.render()
try:
    gymnasium.make("diffosi/CartPole-v0", render_mode="ansi")
    refusal = None
except ValueError as e:
    refusal = str(e)
print(json.dumps({"lazy": lazy, "obs": obs.tolist(), "reward": reward, "frame": [frame.shape, str(frame.dtype),
                  int(frame.min()), int(frame.max())], "refusal": refusal}))
"""


def test_gym_make_needs_no_import_of_ours(installed):
    python, work = installed
    got = json.loads(run([python, "-c", GYM], cwd=work).stdout.splitlines()[-1])
    assert got["lazy"]  # importing gymnasium registered the ids without loading our modules
    import gymnasium

    import harness.gym_env  # noqa: F401 - the checkout's registration, for the same episode here

    env = gymnasium.make("diffosi/CartPole-v0", mu=0.3)
    env.reset(seed=7)
    obs, reward, *_ = env.step(np.array([0.5]))
    assert got["obs"] == obs.tolist() and got["reward"] == reward  # same numbers as the checkout's
    shape, dtype, low, high = got["frame"]
    assert shape == [480, 480, 3] and dtype == "uint8" and high > low
    assert "rgb_array" in got["refusal"]
