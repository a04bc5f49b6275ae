"""The one interface every reference-engine adapter implements.

Conventions (all adapters): a model's dofs are its one-dof joints (hinge or slide),
so nq = nv, and every per-dof vector is in `joint_names` order, asserted equal to
the model's joint order (MJCF document order; the URDF's non-fixed joints). PyBullet and
DART also take a URDF whose root is a floating joint (`free`: its urdf.FloatingJoint, else None):
then q, v and tau start with that free joint's 7, 6 and 6 numbers in MuJoCo's convention
(harness/engines/floating.py), and the per-joint vectors (damping, ...) and `joint_names`
are the one-dof joints'. SI units,
angles in rad. `tau` are generalized forces on every dof, applied directly (no
actuators). `dynamics(q, v)` returns the engine's own M(q) (armature included where
the engine has it) and bias c(q, v) (Coriolis, centrifugal, gravity; no damping or
stiffness), with

    M a = tau - c - D v - K (q - q_s)

where the passive mode says at which time each passive term is taken (see
harness/engines/numpy_step.py). Parameter names and meanings are our engine's
(DESIGN.md): body/<b>/mass, body/<b>/com (body-frame COM, 3 values),
joint/<j>/damping, joint/<j>/stiffness; changing a mass keeps the COM and the inertia
about the COM, changing a COM keeps the mass and the inertia about the COM.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "reference_models"
GYM_PREFIX = "gymnasium:"  # a label for gymnasium's MuJoCo assets, e.g. gymnasium:hopper.xml


def gym_assets_dir() -> Path:
    import gymnasium

    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"


def label_of(path: Path) -> str:
    """How golden files and reports name a model file: relative to the repo, or
    gymnasium:<file> for gymnasium's assets, else the absolute path."""
    path = path.resolve()
    if path.parent == gym_assets_dir().resolve():  # before the repo: .venv is inside it
        return GYM_PREFIX + path.name
    if path.is_relative_to(REPO):
        return str(path.relative_to(REPO))
    return str(path)


def path_of(label: str) -> Path:
    """The inverse of label_of."""
    if label.startswith(GYM_PREFIX):
        return gym_assets_dir() / label.removeprefix(GYM_PREFIX)
    path = Path(label)
    return path if path.is_absolute() else REPO / path


def nonzero_by_joint(names, values) -> dict:
    return {n: float(x) for n, x in zip(names, values) if x != 0.0}


@contextlib.contextmanager
def quiet_stdio(into: list | None = None):
    """Silence C-level stdout/stderr (PyBullet and DART print warnings from C++); with `into`,
    append what was printed to it, line by line."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile(mode="w+") if into is not None else open(os.devnull, "w") as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            if into is not None:
                sink.seek(0)
                into.extend(sink.read().splitlines())


class Engine:
    """One model loaded into one reference engine, ready to step.

    Set by each adapter: name, version, label, model_path (the file the engine loaded:
    MJCF for MuJoCo, the URDF twin for PyBullet and DART), passive (explicit |
    implicit_damping | implicit_damping_stiffness), integrator ("Euler" | "RK4", our
    engine's spelling), timestep, gravity, joint_names, body_names (the bodies whose
    parameters can be set), settings (what was switched off and why), ignored
    ({param: {joint: value}}: values of the model file the engine does not simulate,
    which our engine must zero to match), damping, stiffness, springref, q_ref (the
    reference configuration), ranges ((lo, hi) of a limited joint, else None; used only
    for sampling, limits are off in every engine), free (see the module docstring).
    """

    name: str
    version: str
    label: str
    model_path: Path
    passive: str
    integrator: str
    timestep: float
    gravity: list
    joint_names: list
    body_names: list
    settings: dict
    ignored: dict
    damping: np.ndarray
    stiffness: np.ndarray
    springref: np.ndarray
    q_ref: np.ndarray
    ranges: list
    free = None
    package_dirs: tuple = ()  # where our loader resolves package:// paths (ours())

    def __init__(self):
        self._changed: dict = {}  # parameters changed by set_param, in order, for ours()

    @staticmethod
    def check_friction(friction: dict | None, joints: list) -> dict:
        """Coulomb joint friction {joint: force (N) or torque (N m) >= 0}, the unmodelled
        effect the `friction` option adds (our engine has none): names and values checked."""
        friction = dict(friction or {})
        for joint, value in friction.items():
            if joint not in joints:
                raise ValueError(f"friction: unknown joint {joint!r} (joints {joints})")
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"friction: {joint} must be finite and >= 0, got {value}")
        return {j: float(x) for j, x in friction.items()}

    # ---- the engine-specific part

    def set_state(self, q, v) -> None:
        raise NotImplementedError

    def get_state(self) -> tuple:
        raise NotImplementedError

    def step(self, tau) -> None:
        """Apply generalized forces tau (length nv) for one step."""
        raise NotImplementedError

    def dynamics(self, q, v) -> tuple:
        """(M(q), c(q, v)); leaves the engine's state as it was."""
        raise NotImplementedError

    def reset(self) -> None:
        """Clear any history (time, warm starts) before an independent sample."""

    def close(self) -> None:
        """Release the engine."""

    def _set_timestep(self, h: float) -> None:
        raise NotImplementedError

    def set_timestep(self, h: float) -> None:
        """Run the model at timestep h (s) instead of the file's (or the default)."""
        if not (np.isfinite(h) and h > 0):
            raise ValueError(f"timestep must be finite and > 0, got {h}")
        self._set_timestep(float(h))
        self.settings["timestep_override"] = {"file": self.timestep, "used": float(h)}
        self.timestep = float(h)

    def _set(self, kind: str, owner: str, field: str, value: np.ndarray) -> None:
        """Write one parameter into the engine (kind body|joint, value already checked)."""
        raise NotImplementedError

    def _get(self, kind: str, owner: str, field: str) -> np.ndarray:
        raise NotImplementedError

    # ---- shared

    def rollout(self, q0, v0, taus) -> tuple:
        """(Q, V), shapes (T+1, nq) and (T+1, nv): the states visited from (q0, v0) under
        each row of taus, after a reset."""
        self.reset()
        self.set_state(q0, v0)
        states = [self.get_state()]
        for tau in taus:
            self.step(tau)
            states.append(self.get_state())
        Q, V = zip(*states)
        return np.array(Q), np.array(V)

    @property
    def nv(self) -> int:
        """The number of dofs: the one-dof joints' and a free root's six."""
        return len(self.joint_names) + (6 if self.free else 0)

    def mass_matrix(self, q) -> np.ndarray:
        return self.dynamics(q, np.zeros(self.nv))[0]

    def _parse(self, name: str) -> tuple[str, str, str]:
        kind, _, rest = name.partition("/")
        owner, _, field = rest.rpartition("/")
        fields = {"body": ("mass", "com"), "joint": ("damping", "stiffness")}
        owners = {"body": self.body_names, "joint": self.joint_names}
        if kind not in fields or field not in fields[kind] or owner not in owners[kind]:
            raise ValueError(f"{self.name}: unknown parameter {name!r} (have body/<b>/mass, body/<b>/com, "
                             f"joint/<j>/damping, joint/<j>/stiffness for bodies {self.body_names} "
                             f"and joints {self.joint_names})")
        return kind, owner, field

    def set_param(self, name: str, value) -> None:
        """Set a parameter by our name, with our meaning (see the module docstring)."""
        kind, owner, field = self._parse(name)
        value = np.atleast_1d(np.asarray(value, dtype=float))
        size = 3 if field == "com" else 1
        if value.shape != (size,) or not np.all(np.isfinite(value)):
            raise ValueError(f"{name}: expected {size} finite value(s), got {value}")
        if field != "com" and value[0] < 0:
            raise ValueError(f"{name}: must not be negative, got {value[0]}")
        self._set(kind, owner, field, value)
        if kind == "joint":
            getattr(self, field)[self.joint_names.index(owner)] = value[0]
        self._changed[name] = value

    def get_param(self, name: str) -> np.ndarray:
        """The engine's current value of a parameter (read from the engine)."""
        return self._get(*self._parse(name))

    def ours(self):
        """Our engine (diffosi.Model) configured as this engine runs the model: the same
        file, its timestep, gravity, integrator and passive mode, contacts and limits off
        (as the engines run), the ignored parameters zeroed and every set_param change
        applied."""
        import diffosi

        floating_base = getattr(self, "floating_base", False)
        m = diffosi.Model.load(str(self.model_path), floating_base=floating_base,
                               package_dirs=[str(d) for d in self.package_dirs]).with_options(
            timestep=self.timestep, gravity=list(self.gravity), integrator=self.integrator,
            passive=self.passive, contact=False, limits=False)
        if "fluid_off" in self.settings:  # the engine's fluid forces switched off (MuJoCo's adapter)
            m = m.with_options(density=0.0, viscosity=0.0)
        for param, joints in self.ignored.items():
            for joint in joints:
                m.set_param(f"joint/{joint}/{param}", 0.0)
        for name, value in self._changed.items():
            m.set_param(name, value)
        return m

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        return f"<{self.name} {self.version}: {self.label}, {self.passive}, {self.integrator}, h={self.timestep}>"
