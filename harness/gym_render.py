"""Rendering of the gymnasium environments (harness/gym_env.py), as gymnasium's API has it:
`gymnasium.make(id, render_mode="rgb_array")`, then `env.render()` returns the current
frame, an (height, width, 3) uint8 array; render_mode None (the default) renders nothing.

A frame is MuJoCo's renderer on the environment's MJCF model: our state q is set as
MuJoCo's qpos (the same joints in the same order: every one of these models has hinge and
slide joints only), positions are computed (mj_kinematics) and the scene is drawn from
MuJoCo's default free camera. Without a display MuJoCo needs an off-screen OpenGL
context: set MUJOCO_GL=egl (or osmesa) before the first import of mujoco.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

RENDER_MODES = ["rgb_array"]
WIDTH, HEIGHT = 480, 480


def checked_mode(render_mode):
    """render_mode if these environments render it, else a ValueError that says what they do."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode={render_mode!r}: diffosi's environments render 'rgb_array' "
                         "(MuJoCo's renderer on the model's MJCF) or nothing (None)")
    return render_mode


class MujocoFrames:
    """MuJoCo's renderer on one MJCF file; frame(q) draws the model at joint positions q."""

    def __init__(self, mjcf: Path):
        try:
            import mujoco
        except ImportError as e:
            raise RuntimeError("render_mode='rgb_array' draws through MuJoCo, which is not installed "
                               "(pip install \"diffosi[harness]\")") from e
        self.mujoco = mujoco
        from harness.engines.mujoco import load_mjcf

        self.model = load_mjcf(mjcf)
        self.data = mujoco.MjData(self.model)
        try:
            self.renderer = mujoco.Renderer(self.model, HEIGHT, WIDTH)
        except Exception as e:  # noqa: BLE001 - MuJoCo's GL errors have several types
            raise RuntimeError(f"render_mode='rgb_array': MuJoCo could make no OpenGL context ({e}); "
                               "without a display, set MUJOCO_GL=egl or MUJOCO_GL=osmesa") from e

    def frame(self, q) -> np.ndarray:
        if q is not None:  # before the first reset: the model's own qpos0
            self.data.qpos[:] = q
        self.mujoco.mj_kinematics(self.model, self.data)
        self.renderer.update_scene(self.data)
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()


class MjcfRendering:
    """Mixin of a gymnasium.Env drawn from an MJCF file: the subclass sets `mjcf` (the file)
    and `render_q()` (its current joint positions, or None before the first reset)."""

    mjcf: Path
    _frames = None

    def render(self):
        if self.render_mode is None:
            return None
        if self._frames is None:
            self._frames = MujocoFrames(self.mjcf)
        return self._frames.frame(self.render_q())

    def close(self):
        if self._frames is not None:
            self._frames.close()
            self._frames = None
