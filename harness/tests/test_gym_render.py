"""render_mode of the gymnasium environments (harness/gym_render.py) and their registration by
the start-up hook (harness/gym_hook.py), each in a fresh interpreter: MuJoCo reads MUJOCO_GL
at its first import, and the hook must act before gymnasium is imported."""

import json
import os
import subprocess
import sys
from pathlib import Path

import gymnasium
import pytest

from harness import gym_env  # noqa: F401 - registers the ids in this process

REPO = Path(__file__).resolve().parents[2]

FRAMES = """
import json, gymnasium, numpy as np, harness.gym_env
out = {}
for env_id in ("diffosi/CartPole-v0", "diffosi/HalfCheetah-v0", "diffosi/Wiping-v0"):
    env = gymnasium.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    for _ in range(5):
        env.step(np.ones(env.action_space.shape))
    moved = env.render()
    out[env_id] = [list(first.shape), str(first.dtype), bool(np.any(first != moved)), env.unwrapped.render() is not None]
    env.close()
print(json.dumps(out))
"""

HOOK = """
import sys, json
import harness.gym_hook   # what the wheel's diffosi_gym.pth does at start-up
import gymnasium
lazy = "harness.gym_env" not in sys.modules and "diffosi" not in sys.modules
env = gymnasium.make("diffosi/CartPole-v0", mu=0.1)
obs, _ = env.reset(seed=3)
print(json.dumps({"lazy": lazy, "obs": obs.tolist()}))
"""


def python(code: str) -> str:
    env = dict(os.environ, MUJOCO_GL="egl")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()[-1]


def test_rgb_array_frames_follow_the_state():
    frames = json.loads(python(FRAMES))
    for env_id, (shape, dtype, moved, rendered) in frames.items():
        assert shape == [480, 480, 3] and dtype == "uint8", env_id
        assert moved, f"{env_id}: five steps changed nothing in the frame"
        assert rendered


def test_no_render_mode_renders_nothing():
    env = gymnasium.make("diffosi/CartPole-v0").unwrapped
    env.reset(seed=0)
    assert env.render_mode is None and env.render() is None


@pytest.mark.parametrize("env_id", ["diffosi/CartPole-v0", "diffosi/HalfCheetah-v0", "diffosi/Wiping-v0"])
def test_other_render_modes_are_refused(env_id):
    with pytest.raises(ValueError, match="render 'rgb_array'"):
        gymnasium.make(env_id, render_mode="ansi")


def test_the_hook_registers_before_any_import_of_ours():
    got = json.loads(python(HOOK))
    assert got["lazy"]
    env = gymnasium.make("diffosi/CartPole-v0", mu=0.1)
    obs, _ = env.reset(seed=3)
    assert got["obs"] == obs.tolist()
