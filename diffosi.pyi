"""Type information for the Python module `diffosi` (the pyo3 bindings in bindings/).

Shipped in the wheel as diffosi/__init__.pyi with py.typed (maturin places it). Units are
SI throughout; q has nq entries and v, tau nv (MuJoCo's qpos, qvel, qfrc_applied); every
array argument is anything `numpy.asarray(x, dtype=float64)` accepts. Bad shapes, NaN and
unknown names raise ValueError, missing files OSError. `make test` runs mypy's stubtest on
this file against the built module (harness/tests/test_stub.py): a method added to or
changed in the bindings fails it until this file follows.
"""

from collections.abc import Sequence
from os import PathLike
from typing import Any, Literal, TypedDict, final

import numpy as np
from numpy.typing import ArrayLike, NDArray

__version__: str
__all__ = ["Model", "DiffOsi", "CmaEs", "Task", "Policy", "Wiping", "WipingRun", "OnlineOsi", "__version__"]

_F64 = NDArray[np.float64]
_Path = str | PathLike[str]
_Flag = Literal["unexcited", "at_bound", "not_converged", "misfit", "changed"]

class _Estimate(TypedDict):
    """What `DiffOsi.identify` and `CmaEs.identify` return."""

    params: _F64  # (nmu,) the estimate of mu
    std: _F64  # (nmu,) standard errors; an unexcited direction: the uniform prior's
    loss: float
    iterations: int
    evaluations: int
    flags: list[_Flag]

class _OnlineEstimate(TypedDict):
    """What `OnlineOsi.push` returns."""

    mu: _F64  # (nmu,)
    std: _F64  # (nmu,)
    loss: float
    iterations: int
    evaluations: int
    flags: list[_Flag]

class _WipingEstimate(TypedDict):
    """What `Wiping.identify` returns."""

    mu: _F64  # (nmu,) tool k_p in N/cm, k_d in N s/m, then the joints' (0.01 N m s/rad, 0.01 N m/rad)
    std: _F64
    loss: float
    iterations: int
    evaluations: int
    flags: list[_Flag]

class _Episode(TypedDict):
    """What `Wiping.episode` returns: T + 1 rows."""

    q: _F64  # (T+1, nq)
    v: _F64  # (T+1, nv)
    tau: _F64  # (T+1, nv) the torques the step from each row applies, N m
    force: _F64  # (T+1,) sensed normal force, N
    xi: _F64  # (T+1,) admittance offset, m
    metric: float  # N^2

class _Keyframe(TypedDict):
    q: _F64  # (nq,)
    v: _F64  # (nv,)
    ctrl: _F64  # (nu,)
    act: _F64  # (na,)
    mocap_pos: _F64  # (nmocap, 3)
    mocap_quat: _F64  # (nmocap, 4) w x y z
    time: float  # s

class _Contact(TypedDict):
    """One contact point of `Model.contacts`, world frame, SI; forces on a, b feels the opposite."""

    geoms: tuple[str, str]
    bodies: tuple[str, str]
    point: _F64  # (3,) m
    normal: _F64  # (3,) unit, from b into a
    depth: float  # m, > 0 overlapping
    normal_force: float  # N
    friction: _F64  # (3,) N
    force: _F64  # (3,) N
    torque: _F64  # (3,) N m
    frame: _F64  # (3, 3) rows: normal, two tangents
    frame_force: _F64  # (6,)

class _TrainingRow(TypedDict):
    iteration: int
    env_steps: int
    episodes: int
    mean_return: float
    mean_metric: float

@final
class Model:
    """A rigid-body model with its simulation buffers (MJCF `.xml` or URDF `.urdf`)."""

    @staticmethod
    def load(
        path: _Path,
        floating_base: bool = False,
        package_dirs: Sequence[_Path] | None = None,
        inertial: Literal["pinocchio", "pybullet"] = "pinocchio",
    ) -> Model: ...
    def with_options(
        self,
        *,
        timestep: float | None = None,
        gravity: ArrayLike | None = None,
        integrator: Literal["Euler", "RK4", "implicit", "implicitfast"] | None = None,
        passive: Literal["explicit", "implicit_damping", "implicit_damping_stiffness"] | None = None,
        contact: bool | None = None,
        limits: bool | None = None,
        contact_model: Literal["constraint", "smooth"] | None = None,
        density: float | None = None,
        viscosity: float | None = None,
        wind: ArrayLike | None = None,
    ) -> Model: ...
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int: ...
    @property
    def nv(self) -> int: ...
    @property
    def nu(self) -> int: ...
    @property
    def na(self) -> int: ...
    @property
    def nmocap(self) -> int: ...
    @property
    def timestep(self) -> float: ...
    @property
    def gravity(self) -> _F64: ...
    @property
    def integrator(self) -> str: ...
    @property
    def passive(self) -> str: ...
    @property
    def contact_model(self) -> str: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def body_names(self) -> list[str]: ...
    @property
    def actuator_names(self) -> list[str]: ...
    @property
    def keyframe_names(self) -> list[str]: ...
    @property
    def site_names(self) -> list[str]: ...
    @property
    def sensor_names(self) -> list[str]: ...
    @property
    def sensor_adr(self) -> list[int]: ...
    @property
    def sensor_dim(self) -> list[int]: ...
    def joint_address(self, name: str) -> tuple[int, int]: ...
    def coordinate_names(self) -> tuple[list[str], list[str]]: ...
    def reference_q(self) -> _F64: ...
    def keyframe(self, name: str) -> _Keyframe: ...
    def compiled(self) -> dict[str, list[dict[str, Any]]]: ...
    def param_names(self) -> list[str]: ...
    def get_param(self, name: str) -> _F64: ...
    def set_param(self, name: str, value: ArrayLike) -> None: ...
    def step(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        ctrl: ArrayLike | None = None,
        act: ArrayLike | None = None,
        mocap_pos: ArrayLike | None = None,
        mocap_quat: ArrayLike | None = None,
    ) -> tuple[_F64, ...]:
        """(q1, v1) of shapes (nq,), (nv,); (q1, v1, act1) when na > 0."""
    def rollout(
        self,
        q0: ArrayLike,
        v0: ArrayLike,
        taus: ArrayLike,
        ctrls: ArrayLike | None = None,
        act0: ArrayLike | None = None,
        mocap_pos: ArrayLike | None = None,
        mocap_quat: ArrayLike | None = None,
    ) -> tuple[_F64, ...]:
        """taus (T, nv) -> (Q (T+1, nq), V (T+1, nv)), and A (T+1, na) when na > 0."""
    def step_jacobians(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        params: Sequence[str] | None = None,
        ctrl: ArrayLike | None = None,
        act: ArrayLike | None = None,
        mocap_pos: ArrayLike | None = None,
        mocap_quat: ArrayLike | None = None,
    ) -> dict[str, _F64]:
        """Blocks "dq_dq", "dq_dv", "dq_dtau", "dv_dq", "dv_dv", "dv_dtau" (nv x nv), "dq_dp",
        "dv_dp" (nv x total length of params); with ctrl or act also the actuator blocks."""
    def transition_jacobians(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike) -> tuple[_F64, _F64]:
        """(A (2 nv x 2 nv), B (2 nv x nv)): mjd_transitionFD's layout, exact."""
    def sensors(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        ctrl: ArrayLike | None = None,
        act: ArrayLike | None = None,
        mocap_pos: ArrayLike | None = None,
        mocap_quat: ArrayLike | None = None,
    ) -> _F64: ...
    def contacts(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike | None = None,
        mocap_pos: ArrayLike | None = None,
        mocap_quat: ArrayLike | None = None,
    ) -> list[_Contact]: ...
    def body_contact_forces(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike | None = None,
        mocap_pos: ArrayLike | None = None,
        mocap_quat: ArrayLike | None = None,
    ) -> _F64:
        """(len(body_names), 3) net contact force on each body, N, world frame."""

@final
class DiffOsi:
    """Online system identification of named parameters from a window of transitions."""

    def __new__(
        cls,
        model: Model,
        params: Sequence[str],
        lower: ArrayLike,
        upper: ArrayLike,
        method: Literal["lm", "adam"] = "lm",
        scale: ArrayLike | None = None,
        loss: Literal["squared", "huber"] = "squared",
        huber: float = 1.345,
        constraints: Literal["modelled", "unknown"] = "modelled",
        margin: float = 0.02,
        force_scale: ArrayLike | None = None,
        impulses: Literal["model", "mass"] = "model",
    ) -> DiffOsi: ...
    def identify(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        q_next: ArrayLike,
        v_next: ArrayLike,
        init: ArrayLike | None = None,
    ) -> _Estimate:
        """W transitions: q (W, nq), v (W, nv), tau (W, nv), q_next (W, nq), v_next (W, nv)."""
    @property
    def params(self) -> list[str]: ...
    @property
    def lower(self) -> _F64: ...
    @property
    def upper(self) -> _F64: ...
    @property
    def prior(self) -> _F64: ...
    @property
    def method(self) -> str: ...
    @property
    def loss(self) -> str: ...
    @property
    def huber(self) -> float | None: ...

@final
class CmaEs:
    """The derivative-free CMA-ES baseline behind DiffOsi's interface."""

    def __new__(
        cls,
        model: Model,
        params: Sequence[str],
        lower: ArrayLike,
        upper: ArrayLike,
        scale: ArrayLike | None = None,
        seed: int = 0,
        max_evaluations: int = 20000,
    ) -> CmaEs: ...
    def identify(
        self,
        q: ArrayLike,
        v: ArrayLike,
        tau: ArrayLike,
        q_next: ArrayLike,
        v_next: ArrayLike,
        init: ArrayLike | None = None,
    ) -> _Estimate: ...
    @property
    def params(self) -> list[str]: ...
    @property
    def lower(self) -> _F64: ...
    @property
    def upper(self) -> _F64: ...
    @property
    def prior(self) -> _F64: ...
    @property
    def seed(self) -> int: ...
    @property
    def max_evaluations(self) -> int: ...

@final
class Task:
    """A control task by name: "cartpole", "half_cheetah", "half_cheetah_contact", "quadruped"."""

    def __new__(cls, name: str) -> Task: ...
    @property
    def name(self) -> str: ...
    @property
    def horizon(self) -> int: ...
    @property
    def substeps(self) -> int: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def act_dim(self) -> int: ...
    @property
    def nmu(self) -> int: ...
    @property
    def mu_range(self) -> tuple[_F64, _F64]: ...
    def model(self, mu: ArrayLike | None = None) -> Model: ...
    def mu_params(self, mu: ArrayLike) -> dict[str, _F64]: ...
    def reset(self, seed: int) -> tuple[_F64, _F64]: ...
    def episodes(self, count: int, seed: int) -> tuple[_F64, _F64, _F64]:
        """(mu (count, nmu), q0 (count, nq), v0 (count, nv))."""
    def observe(self, q: ArrayLike, v: ArrayLike) -> _F64: ...
    def forces(self, action: ArrayLike) -> _F64: ...
    def inputs(self, action: ArrayLike) -> tuple[_F64, _F64]:
        """(tau (nv,), ctrl (nu,) or empty) a control step holds."""
    def held_forces(self, q: ArrayLike, v: ArrayLike, action: ArrayLike) -> _F64:
        """Generalized forces (nv,) that with zero ctrl make the step from (q, v) under the action."""
    def terminated(self, q: ArrayLike, v: ArrayLike) -> bool: ...
    def metric(self, q: ArrayLike, v: ArrayLike, action: ArrayLike, q_next: ArrayLike, v_next: ArrayLike) -> float: ...

@final
class OnlineOsi:
    """Online DiffOSI of a task's mu, one transition at a time."""

    def __new__(
        cls,
        task: Task,
        window: int = 1,
        method: Literal["lm", "adam"] = "lm",
        change_detection: bool = False,
        seed: int = 0,
        scale: ArrayLike | None = None,
        loss: Literal["squared", "huber"] = "squared",
        huber: float = 1.345,
        constraints: Literal["modelled", "unknown"] = "modelled",
        margin: float = 0.02,
        force_scale: ArrayLike | None = None,
        impulses: Literal["model", "mass"] = "model",
        restarts: int = 8,
    ) -> OnlineOsi: ...
    def push(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike, q_next: ArrayLike, v_next: ArrayLike) -> _OnlineEstimate: ...
    @property
    def mu(self) -> _F64: ...
    @property
    def window(self) -> int: ...
    @property
    def method(self) -> str: ...
    @property
    def loss(self) -> str: ...
    @property
    def change_detection(self) -> bool: ...

@final
class Policy:
    """A trained policy ("uc": fed mu, or "dr": domain-randomised)."""

    @staticmethod
    def load(path: _Path) -> Policy: ...
    @staticmethod
    def train(task: Task, kind: Literal["uc", "dr"], seed: int = 0, steps: int | None = None) -> tuple[Policy, list[_TrainingRow]]: ...
    def save(self, path: _Path) -> None: ...
    def parameters(self) -> NDArray[np.float32]: ...
    @property
    def kind(self) -> str: ...
    @property
    def task(self) -> str: ...
    def act(self, task: Task, q: ArrayLike, v: ArrayLike, mu: ArrayLike | None = None) -> _F64: ...

@final
class Wiping:
    """The table-wiping task (the paper's Section 4.4)."""

    def __new__(cls, unknowns: int = 2) -> Wiping: ...
    @property
    def nmu(self) -> int: ...
    @property
    def unknowns(self) -> list[str]: ...
    @property
    def mu_range(self) -> tuple[_F64, _F64]: ...
    @property
    def canonical_gains(self) -> tuple[float, float]: ...
    @property
    def gains_range(self) -> tuple[tuple[float, float], tuple[float, float]]: ...
    @property
    def force_goal(self) -> float: ...
    @property
    def contact_force(self) -> float: ...
    def episode(self, mu: ArrayLike, gains: ArrayLike | None = None, steps: int = 3000) -> _Episode: ...
    def identify(
        self,
        q: ArrayLike,
        v: ArrayLike,
        xi: ArrayLike,
        force: ArrayLike,
        gains: ArrayLike | None = None,
        segments: int = 50,
        length: int = 5,
        seed: int = 0,
        method: Literal["lm", "cmaes"] = "lm",
        max_evaluations: int = 300,
        loss: Literal["squared", "huber"] = "squared",
        huber: float = 1.345,
    ) -> _WipingEstimate: ...
    def act(
        self, k: int, q: ArrayLike, v: ArrayLike, xi: float, force: float, gains: ArrayLike | None = None
    ) -> tuple[_F64, float]: ...
    def uc_gains(self, path: _Path, mu: ArrayLike) -> tuple[float, float]: ...
    def run(self, mu: ArrayLike) -> WipingRun: ...

@final
class WipingRun:
    """One wiping episode driven a control step at a time (`Wiping.run(mu)`)."""

    def step(self, gains: ArrayLike) -> float: ...
    @property
    def q(self) -> _F64: ...
    @property
    def v(self) -> _F64: ...
    @property
    def xi(self) -> float: ...
    @property
    def force(self) -> float: ...
    @property
    def k(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def timestep(self) -> float: ...
    @property
    def stroking(self) -> bool: ...
