"""pytest's setup for harness/tests: MuJoCo renders off-screen (EGL) unless MUJOCO_GL says
otherwise. gymnasium's env checker renders every mode an environment declares, and MuJoCo
reads MUJOCO_GL once, at its first import, so it is set before any test module imports it."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

# MuJoCo's warnings (gymnasium's half cheetah: settotalmass is deprecated) go to
# harness.engines.mujoco.MJ_WARNINGS, not to the terminal and ./MUJOCO_LOG.TXT.
import harness.engines.mujoco  # noqa: E402,F401
