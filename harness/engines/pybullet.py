"""PyBullet adapter: a URDF twin loaded into PyBullet (DIRECT mode), every default that
would break agreement with semi-implicit Euler switched off. Joint damping is explicit;
PyBullet has no joint springs and no armature (the model's are listed in `ignored`).

Setting a parameter reloads the model from an edited copy of the URDF (in a temporary
directory) and puts the state back. PyBullet cannot move a link's COM after loading
(changeDynamics has no inertial position), and it builds its inverse-dynamics tree at
the first calculateMassMatrix / calculateInverseDynamics and caches it, so a mass
changed later by changeDynamics would step with the new value but report M and c with
the old one. A reload is one mechanism for every parameter, with the URDF's meaning:
<inertial><origin xyz> is the COM and <inertia> is about the COM, as ours.

native=True keeps PyBullet's link damping and its joint velocity cap (100). The damping,
linearDamping = angularDamping = 0.04, is explicit and quadratic: a force
-0.04 (1 + |v|) m v and a torque -0.04 (1 + |w|) I w on each link (v, w the link frame's
velocities; measured: a cart coasting at 1 and 5 m/s slows at 0.08 and 0.24 times v per s).
friction={joint: f} is PyBullet's usual joint friction: the joint's velocity motor with
target velocity 0 and maximum force f, a constraint that holds the joint still unless
more than f pushes it (TORQUE_CONTROL forces add to it).

A URDF whose root is a floating joint from `world` (our free root) is loaded as PyBullet's
own free base: a copy without the world link and that joint, useFixedBase off (the world
link's collisions go with it). floating_base=True loads any other URDF with useFixedBase
off, as PyBullet's loadURDF does by default and Model.load(path, floating_base=True) reads
it (its free joint 'root_joint' at the world origin); by default the root link is fixed,
as our loader, MuJoCo's importer and Pinocchio read it. q, v and tau keep our convention (harness/engines/floating.py);
the base's part of tau is an external force and torque. M and c are not offered for it.
"""

from __future__ import annotations

import importlib.metadata
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from harness.engines.base import Engine, label_of, quiet_stdio
from harness.engines.floating import PybulletBase
from harness.engines.urdf import DIFFOSI_NS, ignored_extras, read_urdf, timestep_gravity, twin_only

with quiet_stdio():  # pybullet prints its build time on import
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

ET.register_namespace("diffosi", DIFFOSI_NS.strip("{}"))  # edited copies keep our prefix


def stable_explicit_timestep(h: float, damping: np.ndarray, M: np.ndarray, settings: dict) -> float:
    """Explicit damping is stable only for h * max eig(M^-1 D) < 2. Without the armature that
    PyBullet cannot model, the half cheetah's light feet give 5.3 at the file's 0.01 s and the
    legs blow up in ~35 steps; then use the largest h / k (k = 2, 5, 10, ...) with a margin."""
    lam = float(np.linalg.eigvals(np.linalg.solve(M, np.diag(damping))).real.max())
    for k in (1, 2, 5, 10, 20, 50, 100):
        hk = float(f"{h / k:.6g}")
        if hk * lam < 1.5:
            if k > 1:
                settings["timestep_override"] = {
                    "file": h, "used": hk,
                    "why": f"explicit damping unstable at the file's timestep: h max eig(M^-1 D) = {h * lam:.2f} > 2 "
                           f"(no armature in PyBullet); {hk * lam:.2f} at the used timestep"}
            return hk
    raise ValueError("no stable timestep")


def strip(p, body: int, links: list, movable: list, settings: dict, native: bool = False,
          friction: list | None = None, massless: dict | None = None) -> None:
    """Switch off what our smooth dynamics do not model: link damping and the joint velocity
    cap (kept when native), joint limits, collisions, and the velocity motor of every movable
    joint (its maximum force is `friction`, per movable joint, default 0); the links of
    `massless` ({name: link index}, links without <inertial>) get mass 0 instead of PyBullet's 1.
    Every changeDynamics must come before the first calculateMassMatrix /
    calculateInverseDynamics (see the module doc)."""
    if native:
        settings["link_damping"] = ("PyBullet's default: linearDamping = angularDamping = 0.04, force "
                                    "-0.04 (1 + |v|) m v and torque -0.04 (1 + |w|) I w per link (native)")
        settings["maxJointVelocity"] = "PyBullet's default: 100 (native)"
    else:
        # linearDamping, angularDamping and maxJointVelocity are per multibody, and the C API
        # resets the command's link index to -1 for them: set them alone, never per link.
        p.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, maxJointVelocity=1e6)
        settings["link_damping"] = "linearDamping = angularDamping = 0 (default 0.04)"
        settings["maxJointVelocity"] = 1e6  # default 100: silent clamping
    for i in movable:  # URDF limits become limit constraints: widen them and give them no force
        p.changeDynamics(body, i, jointLowerLimit=-1e30, jointUpperLimit=1e30, jointLimitForce=0.0)
    settings["joint_limits"] = "off (bounds +-1e30, jointLimitForce 0)"
    for i in (massless or {}).values():  # a link without <inertial> gets mass 1, inertia 1,1,1
        p.changeDynamics(body, i, mass=0.0, localInertiaDiagonal=[0.0, 0.0, 0.0])
    if massless:
        settings["massless_links"] = {n: "mass 0, inertia 0 (PyBullet default: mass 1, inertia 1)" for n in massless}
    for i in [-1] + links:
        p.setCollisionFilterGroupMask(body, i, 0, 0)
    settings["collisions"] = "off (collision filter group and mask 0)"
    # every revolute/prismatic joint gets a velocity motor: zero its force (or make it friction)
    p.setJointMotorControlArray(body, movable, pybullet.VELOCITY_CONTROL, targetVelocities=[0.0] * len(movable),
                                forces=friction or [0.0] * len(movable))


class PybulletEngine(Engine):
    name = "pybullet"
    version = importlib.metadata.version("pybullet")

    def __init__(self, path: Path, native: bool = False, friction: dict | None = None, floating_base: bool = False):
        super().__init__()
        self.model_path, self.label = Path(path), label_of(Path(path))
        facts = read_urdf(self.model_path, floating_base)
        self.floating_base = floating_base
        self._native = native
        self._friction = self.check_friction(friction, [j.name for j in facts["joints"]])
        h, self.gravity, self.settings = timestep_gravity(self.model_path, facts)
        self._facts, self._urdf, self._tmp = facts, ET.parse(self.model_path), None
        self.free = facts["floating"]
        self._load(self.model_path, h, self.settings)
        self.joint_names = [j.name for j in facts["joints"]]
        self.body_names = [link for link in facts["links"] if link != facts["root"]]
        self.damping = np.array([self._p.getJointInfo(self._body, i)[6] for i in self._movable])
        assert np.allclose(self.damping, [j.damping for j in facts["joints"]])
        n = len(self.joint_names)
        self.stiffness, self.springref = np.zeros(n), np.zeros(n)
        self.q_ref = np.r_[self.free.reference() if self.free else [], np.zeros(n)]
        self.ranges = [j.limit for j in facts["joints"]]
        self.passive, self.integrator = "explicit", "Euler"
        self.ignored = self.settings["ignored"] = ignored_extras(facts, understood=set())
        if only_in_twin := twin_only(self.model_path, facts):
            self.settings["mjcf_twin_only"] = only_in_twin
        # PyBullet's M at q = 0: a free base's 6 dofs first, undamped
        M0 = np.array(self._p.calculateMassMatrix(self._body, [0.0] * n))
        self.timestep = stable_explicit_timestep(h, np.r_[np.zeros(len(M0) - n), self.damping], M0, self.settings)
        self._p.setTimeStep(self.timestep)

    def _temporary(self, name: str) -> Path:
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="diffosi-pybullet-")
        return Path(self._tmp.name) / name

    def _free_base_copy(self, urdf: Path) -> Path:
        """The URDF without the world link and the floating joint: its child is the root."""
        tree = ET.parse(urdf)
        robot = tree.getroot()
        robot.remove(robot.find("link[@name='world']"))
        robot.remove(robot.find(f"joint[@name='{self.free.name}']"))
        copy = self._temporary(f"{urdf.stem}_free_base.urdf")
        tree.write(copy)
        return copy

    def _load(self, urdf: Path, h: float, settings: dict) -> None:
        """Connect, load and strip; settings records what was switched off."""
        with quiet_stdio():
            p = self._p = BulletClient(connection_mode=pybullet.DIRECT)
            # without URDF_USE_INERTIA_FROM_FILE the inertia is recomputed from collision shapes
            in_file = self.free and not self.floating_base  # a floating joint from `world`
            body = self._body = p.loadURDF(str(self._free_base_copy(urdf) if in_file else urdf),
                                           useFixedBase=not self.free, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        p.setGravity(*self.gravity)  # PyBullet's gravity defaults to 0
        p.setTimeStep(h)  # default 1/240 s
        p.setPhysicsEngineParameter(numSubSteps=0)
        settings.update(fixed_base=not self.free, inertia="URDF_USE_INERTIA_FROM_FILE", numSubSteps=0,
                        tau_applied_via="TORQUE_CONTROL after VELOCITY_CONTROL with force 0")
        if self.free:
            how = ("floating_base: the root link's free joint" if self.floating_base else
                   f"floating joint {self.free.name!r} and link 'world' removed")
            settings["free_base"] = f"{how}, useFixedBase off; its forces by applyExternalForce/Torque (WORLD_FRAME)"
            self._base, self._quat = PybulletBase(*p.getDynamicsInfo(body, -1)[3:5]), self.free.reference()[3:]
        links = list(range(p.getNumJoints(body)))
        self._movable = [i for i in links if p.getJointInfo(body, i)[2] != pybullet.JOINT_FIXED]
        names = [p.getJointInfo(body, i)[1].decode() for i in self._movable]
        assert names == [j.name for j in self._facts["joints"]], f"{urdf}: PyBullet dof order {names}"
        self._link = {p.getJointInfo(body, i)[12].decode(): i for i in links}
        if self.free:
            self._link[self.free.child] = -1  # the base
        self._strip(links, settings)
        assert not any(p.getJointInfo(body, i)[7] for i in self._movable), f"{urdf}: joint friction"

    def _strip(self, links: list, settings: dict) -> None:
        """Switch off what our smooth dynamics do not model (see `strip`); a link without
        <inertial> gets mass 0 as in our engine."""
        names = [j.name for j in self._facts["joints"]]
        strip(self._p, self._body, links, self._movable, settings, self._native,
              [self._friction.get(n, 0.0) for n in names],
              {n: self._link[n] for n in self._facts["massless_links"]})
        if self._friction:
            settings["joint_friction"] = {n: f"velocity motor, target 0, max force {f}"
                                          for n, f in self._friction.items()}

    def _set_timestep(self, h):
        self._p.setTimeStep(h)

    def set_state(self, q, v):
        q, v = np.asarray(q, float), np.asarray(v, float)
        if self.free:
            com, orientation, velocity, omega = self._base.to_engine(q, v)
            self._p.resetBasePositionAndOrientation(self._body, com, orientation)
            self._p.resetBaseVelocity(self._body, velocity, omega)
            self._quat, q, v = q[3:7], q[7:], v[6:]
        for k, i in enumerate(self._movable):
            self._p.resetJointState(self._body, i, q[k], v[k])

    def get_state(self):
        s = self._p.getJointStates(self._body, self._movable)
        q, v = np.array([x[0] for x in s]), np.array([x[1] for x in s])
        if not self.free:
            return q, v
        base_q, base_v = self._base.from_engine(*self._p.getBasePositionAndOrientation(self._body),
                                                *self._p.getBaseVelocity(self._body), self._quat)
        self._quat = base_q[3:]
        return np.r_[base_q, q], np.r_[base_v, v]

    def step(self, tau):
        p = self._p
        tau = np.asarray(tau, float)
        if self.free:
            force, point, torque = self._base.wrench(self.get_state()[0], tau)
            p.applyExternalForce(self._body, -1, force, point, pybullet.WORLD_FRAME)
            p.applyExternalTorque(self._body, -1, torque, pybullet.WORLD_FRAME)
            tau = tau[6:]
        p.setJointMotorControlArray(self._body, self._movable, pybullet.TORQUE_CONTROL, forces=list(map(float, tau)))
        p.stepSimulation()
        assert not p.getContactPoints(self._body), f"{self.label}: contacts"

    def dynamics(self, q, v):
        if self.free:
            raise NotImplementedError(f"{self.label}: M and c of a free base are in PyBullet's base "
                                      "coordinates (not converted to ours)")
        # calculateInverseDynamics(q, v, 0) = c(q, v), without joint damping
        q, v = list(map(float, q)), list(map(float, v))
        M = np.array(self._p.calculateMassMatrix(self._body, q))
        return M, np.array(self._p.calculateInverseDynamics(self._body, q, v, [0.0] * len(q)))

    def close(self):
        self._p.disconnect()  # not p.disconnect as a value: BulletClient disconnects on the lookup
        if self._tmp is not None:
            self._tmp.cleanup()

    def _element(self, kind: str, owner: str, field: str) -> tuple[ET.Element, str]:
        """The URDF element and attribute holding a parameter (created if missing)."""
        root = self._urdf.getroot()
        if kind == "joint":
            joint = root.find(f"joint[@name='{owner}']")
            dyn = joint.find("dynamics")
            return (dyn if dyn is not None else ET.SubElement(joint, "dynamics")), "damping"
        inertial = root.find(f"link[@name='{owner}']/inertial")
        if inertial is None:
            raise ValueError(f"pybullet: link {owner} has no <inertial> to edit")
        if field == "mass":
            return inertial.find("mass"), "value"
        origin = inertial.find("origin")
        return (origin if origin is not None else ET.SubElement(inertial, "origin")), "xyz"

    def _set(self, kind, owner, field, value):
        if field == "stiffness":
            raise ValueError("pybullet: no joint springs, so no joint/<j>/stiffness")
        element, attribute = self._element(kind, owner, field)
        element.set(attribute, " ".join(repr(float(x)) for x in value))
        edited = self._temporary(self.model_path.name)
        self._urdf.write(edited)
        q, v = self.get_state()
        self._p.disconnect()
        self._load(edited, self.timestep, {})
        self.set_state(q, v)

    def _get(self, kind, owner, field):
        p, body = self._p, self._body
        if field == "damping":
            return np.array([p.getJointInfo(body, self._movable[self.joint_names.index(owner)])[6]])
        if field == "stiffness":
            return np.zeros(1)
        info = p.getDynamicsInfo(body, self._link[owner])  # (mass, ..., local inertial position, ...)
        return np.array([info[0]]) if field == "mass" else np.array(info[3])


def contact_normal_forces(p, body: int) -> np.ndarray:
    """The normal force (N, >= 0) of each contact point of `body` after the last
    stepSimulation: getContactPoints()[9], the impulse of that (sub)step over its length."""
    return np.array([c[9] for c in p.getContactPoints(bodyA=body)], dtype=float)
