"""The quadruped task's Go1 (src/tasks/quadruped/go1.rs) in MuJoCo: the same URDF through
MuJoCo's importer, with the task's additions made the same way in an MjSpec.

- compiler fusestatic off: the importer otherwise fuses the URDF's fixed links (the feet) into
  their parents, and a contact's softness reads its bodies' invweight0, so a foot's own body
  and a fused calf push differently (0.03 m/s apart after one step); ours keeps them welded;
- a free joint on `base`, whose rank-one inertia becomes 1e-6 I (MuJoCo refuses the file's);
- the floor, the plane z = 0 (MuJoCo's default friction 1, 0.005, 0.0001), and every robot
  geom colliding with it alone (contype 1, conaffinity 0);
- the twelve servos as MuJoCo position actuators, force kp (ctrl - q) - kd q' clamped to the
  joint's URDF effort, kp 20 N m/rad and kd 0.5 N m s/rad (the task's);
- the payload, a jointless body on the trunk whose mass, COM and box inertia are the task's mu
  (set_param of body/payload/{mass,com,inertia}, rebuilt from the spec at the next set_state);
- timestep 0.005 s, Euler, MuJoCo's default contact solver settings: the URDF's options.

What it cannot represent is nothing the task uses: the one-step agreement with ours is 1e-10
in the air and in contact (harness/tests/test_quadruped.py).
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.engines.base import MODELS

URDF = MODELS / "go1" / "go1.urdf"
KP, KD = 20.0, 0.5
TIMESTEP = 0.005
PAYLOAD_BOX = np.array([0.2, 0.1, 0.05])
PAYLOAD_HEIGHT = 0.082
LEGS, PARTS = ("FR", "FL", "RR", "RL"), ("hip", "thigh", "calf")
EFFORT = {"hip": 23.7, "thigh": 23.7, "calf": 35.55}


def go1_spec() -> mujoco.MjSpec:
    """The task's model, payload mass 0, as an MjSpec (see the module docstring)."""
    spec = mujoco.MjSpec.from_file(str(URDF))
    spec.compiler.fusestatic = False
    base = spec.body("base")
    base.fullinertia = [1e-6, 1e-6, 1e-6, 0.0, 0.0, 0.0]
    base.add_freejoint()
    spec.option.timestep = TIMESTEP
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = 1, 0
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0,
                            conaffinity=1, friction=[1.0, 0.005, 0.0001])
    spec.body("trunk").add_body(name="payload", mass=0.0, ipos=[0.0, 0.0, PAYLOAD_HEIGHT],
                                inertia=[0.0, 0.0, 0.0])
    for leg in LEGS:
        for part in PARTS:
            effort = EFFORT[part]
            spec.add_actuator(target=f"{leg}_{part}_joint", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              gainprm=[KP] + [0.0] * 9, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                              biasprm=[0.0, -KP, -KD] + [0.0] * 7, forcelimited=True,
                              forcerange=[-effort, effort])
    return spec


class MujocoGo1:
    """The Go1 in MuJoCo behind the transfer's environment interface: set_param (the payload's
    named parameters), set_state, step(tau, ctrl) (one mj_step, tau in qfrc_applied), get_state."""

    name, version, label = "mujoco", mujoco.__version__, "go1/go1.urdf"
    passive, integrator, timestep = "implicit_damping", "Euler", TIMESTEP
    gravity = [0.0, 0.0, -9.81]

    def __init__(self):
        self.spec = go1_spec()
        self.payload = self.spec.body("payload")
        self.m = self.d = None
        self.settings = {"importer": "MjSpec.from_file (URDF), fusestatic off", "kp": KP, "kd": KD,
                         "timestep": TIMESTEP, "floor_friction": [1.0, 0.005, 0.0001],
                         "servos": "position actuators, forcerange = URDF effort"}

    def set_param(self, name: str, value) -> None:
        value = np.atleast_1d(np.asarray(value, float))
        field = {"body/payload/mass": "mass", "body/payload/com": "ipos",
                 "body/payload/inertia": "inertia"}.get(name)
        if field is None:
            raise ValueError(f"mujoco Go1: no parameter {name!r} (the payload's mass, com, inertia)")
        if field == "inertia":
            if np.any(value[3:]):
                raise ValueError(f"mujoco Go1: {name} must be diagonal, got {value.tolist()}")
            value = value[:3]
        setattr(self.payload, field, value[0] if field == "mass" else value)
        self.m = None

    def set_state(self, q, v) -> None:
        if self.m is None:
            self.m = self.spec.compile()
            self.d = mujoco.MjData(self.m)
        mujoco.mj_resetData(self.m, self.d)
        self.d.qpos[:], self.d.qvel[:] = q, v

    def get_state(self) -> tuple:
        return self.d.qpos.copy(), self.d.qvel.copy()

    def step(self, tau, ctrl) -> None:
        self.d.qfrc_applied[:], self.d.ctrl[:] = tau, ctrl
        mujoco.mj_step(self.m, self.d)

    @property
    def constrained(self) -> bool:
        """Whether the last step had constraint rows (contacts, limits, joint friction)."""
        return int(self.d.nefc) > 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        pass
