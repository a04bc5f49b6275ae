"""Reference-engine adapters: MuJoCo, PyBullet and DART behind one interface (base.Engine).

    from harness import engines
    with engines.load("dart", "cartpole") as e:   # reference_models/cartpole.urdf
        e.set_state(q, v); e.step(tau); q1, v1 = e.get_state()
        ours = e.ours()                            # diffosi.Model run as DART runs the file

A model is a reference model's name (MuJoCo loads reference_models/<name>.xml, PyBullet
and DART the URDF twin reference_models/<name>.urdf), a path, or gymnasium:<file> for
gymnasium's MuJoCo assets. MuJoCo's options: eulerdamp=True (False: explicit damping),
rk4=False (True: integrator RK4).

Every engine also takes native=False and friction=None. By default an adapter switches
off whatever breaks agreement with our engine (replay, golden: 1e-12). native=True
leaves the engine's own modelling where a user would leave it (PyBullet's default link
damping 0.04 and velocity cap 100; MuJoCo's and DART's passive-force treatment and any
frictionloss in the file), still with contacts and limits off, the file's gravity and
timestep, and forces applied as by default: a real dynamics gap for transfer studies.
friction={joint: value} adds Coulomb joint friction (N or N m) by each engine's own
mechanism. Either makes `engine.ours()` an approximation, not a twin.
"""

from __future__ import annotations

import importlib
from pathlib import Path

from harness.engines.base import GYM_PREFIX, MODELS, Engine, path_of

ENGINES = ("mujoco", "pybullet", "dart")
_CLASSES = {"mujoco": "MujocoEngine", "pybullet": "PybulletEngine", "dart": "DartEngine"}


def model_path(engine: str, model: str | Path) -> Path:
    """The file an engine loads for a model name or path (see the module docstring)."""
    if isinstance(model, str) and model.startswith(GYM_PREFIX):
        return path_of(model)
    if isinstance(model, str) and "/" not in model and "." not in model:
        return MODELS / f"{model}.{'xml' if engine == 'mujoco' else 'urdf'}"
    return Path(model)


def load(engine: str, model: str | Path, **options) -> Engine:
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}: one of {', '.join(ENGINES)}")
    path = model_path(engine, model)
    if not path.exists():
        raise ValueError(f"{engine}: no model file {path}")
    module = importlib.import_module(f"harness.engines.{engine}")
    return getattr(module, _CLASSES[engine])(path, **options)
