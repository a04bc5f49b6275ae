"""Registers the gymnasium environments of harness/gym_env.py under gymnasium's ids
("diffosi/CartPole-v0", "diffosi/HalfCheetah-v0", "diffosi/Wiping-v0", "diffosi/Quadruped-v0")
in any Python of an environment where the wheel is installed, so that
`gymnasium.make("diffosi/CartPole-v0")` needs no `import harness.gym_env` first.

Gymnasium 1.x loads no plugins (its `gymnasium.envs` entry-point group was removed in 1.0),
so the wheel ships `diffosi_gym.pth`, which imports this module at interpreter start-up.
Importing it only installs an import hook: nothing (not gymnasium, not diffosi) is loaded
until the program itself imports gymnasium; right after `gymnasium.envs` has registered
gymnasium's own environments, ours are registered by entry-point string, so the
environment's module (and diffosi) loads at the first `make`.
"""

import importlib.abc
import importlib.util
import sys

ENTRY_POINTS = {
    "diffosi/CartPole-v0": "harness.gym_env:CartPoleEnv",
    "diffosi/HalfCheetah-v0": "harness.gym_env:HalfCheetahEnv",
    "diffosi/Wiping-v0": "harness.gym_env:WipingEnv",
    "diffosi/Quadruped-v0": "harness.gym_env:QuadrupedEnv",
}


def register() -> None:
    """Register every id not yet registered (idempotent)."""
    from gymnasium.envs.registration import register as gym_register
    from gymnasium.envs.registration import registry

    for env_id, entry_point in ENTRY_POINTS.items():
        if env_id not in registry:
            gym_register(id=env_id, entry_point=entry_point)


class AfterGymnasiumEnvs(importlib.abc.MetaPathFinder):
    """Finds `gymnasium.envs` as usual and calls register() once that module has run."""

    def find_spec(self, name, path, target=None):
        if name != "gymnasium.envs":
            return None
        sys.meta_path.remove(self)  # one use; the real finders locate the module
        spec = importlib.util.find_spec(name)
        run = spec.loader.exec_module

        def run_then_register(module):
            run(module)
            register()

        spec.loader.exec_module = run_then_register
        return spec


if "gymnasium.envs" in sys.modules:
    register()
else:
    sys.meta_path.insert(0, AfterGymnasiumEnvs())
