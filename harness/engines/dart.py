"""DART adapter: a URDF twin loaded with dartpy's DartLoader into a world of its own.

DART treats joint damping AND stiffness implicitly (our implicit_damping_stiffness).
Its MJCF parser ignores <inertial> (mass 1, identity inertia), so it always loads the
URDF twin. DART 6.20 has no joint armature (no get/setArmature in dartpy, none in the
GenericJoint properties): the model's armature is listed in `ignored`. Parameters are
set with BodyNode.setMass / setLocalCOM (DART keeps the moment of inertia about the
COM, as ours) and DegreeOfFreedom.setDampingCoefficient / setSpringStiffness.

native=True changes nothing here (DART's implicit passive forces are its own either way;
it is recorded in the settings). friction={joint: f} is DART's joint Coulomb friction,
DegreeOfFreedom.setCoulombFriction(f), a constraint of its LCP solver.

package_dirs: where package://NAME/ paths resolve, for DART's loader
(DartLoader.addPackageDirectory) and ours(), as our loader resolves them.

A URDF floating joint from `world` (our free root) is DART's FreeJoint; q, v and tau keep
our convention (harness/engines/floating.py). M and c are not offered for it.
floating_base=True floats any other URDF's root link by DART's loader (root joint type
FLOATING: a FreeJoint at the world origin), as PybulletEngine(floating_base=True) and
Model.load(path, floating_base=True) read it (a free joint 'root_joint'); by default the root
link is fixed (root joint type FIXED), as our loader, MuJoCo's importer and Pinocchio read it.
"""

from __future__ import annotations

from pathlib import Path

import dartpy as dart
import numpy as np

from harness.engines.base import Engine, label_of, nonzero_by_joint, quiet_stdio
from harness.engines.floating import DartBase
from harness.engines.urdf import ignored_extras, package_directories, read_urdf, timestep_gravity, twin_only


def load_world(urdf: Path, h: float, gravity: list, floating_base: bool = False, package_dirs=()):
    """DART's URDF loader on `urdf`, each package://NAME/ it names found in package_dirs as our
    loader finds it (harness.engines.urdf.package_directories), in a world of its own."""
    loader = dart.utils.DartLoader()
    for name, directory in package_directories(urdf, package_dirs).items():
        loader.addPackageDirectory(name, str(directory))
    opts = dart.utils.DartLoader.Options()
    # the root link's joint (unless it is named "world"): DART's default is FLOATING
    kind = dart.utils.DartLoader.RootJointType
    opts.mDefaultRootJointType = kind.FLOATING if floating_base else kind.FIXED
    with quiet_stdio():  # DART warns about a zero inertia (it still simulates it exactly)
        # a link without <inertial> gets mass 1 and identity inertia: make it massless instead
        opts.mDefaultInertia = dart.dynamics.Inertia(0.0, np.zeros(3), np.zeros((3, 3)))
        loader.setOptions(opts)
        skel = loader.parseSkeleton(str(urdf))
    assert skel is not None, f"{urdf}: DART could not parse it"
    world = dart.simulation.World()
    world.setTimeStep(h)
    world.setGravity(gravity)
    deact = world.getDeactivationOptions()
    deact.mEnabled = False  # DART 6.20 worlds sleep slow bodies by default (no effect seen here)
    world.setDeactivationOptions(deact)
    world.addSkeleton(skel)
    skel.setSelfCollisionCheck(False)
    return world, skel


def strip(skel, urdf: Path) -> None:
    """No limits of any kind; DART enforces none of a URDF's by default, but say so."""
    for k in range(skel.getNumJoints()):
        skel.getJoint(k).setLimitEnforcement(False)
    for dof in (skel.getDof(i) for i in range(skel.getNumDofs())):
        dof.setVelocityLimits(-np.inf, np.inf)
        dof.setForceLimits(-np.inf, np.inf)
        assert dof.getCoulombFriction() == 0.0, f"{urdf}: joint friction"


def set_passive(skel, facts: dict, urdf: Path, first: int = 0) -> tuple:
    """Damping from <dynamics damping> (the loader reads it too); stiffness and springref from
    the diffosi extensions, which DART's loader ignores: given by hand. The one-dof joints'
    dofs start at `first` (after a FreeJoint's six)."""
    damping = np.array([j.damping for j in facts["joints"]])
    stiffness = np.array([j.extensions.get("stiffness", 0.0) for j in facts["joints"]])
    springref = np.array([j.extensions.get("springref", 0.0) for j in facts["joints"]])
    for k in range(len(damping)):
        dof = skel.getDof(first + k)
        assert dof.getDampingCoefficient() == damping[k], f"{urdf}: DART read another damping"
        dof.setDampingCoefficient(float(damping[k]))
        dof.setSpringStiffness(float(stiffness[k]))
        dof.setRestPosition(float(springref[k]))
    return damping, stiffness, springref


class DartEngine(Engine):
    name = "dart"
    version = dart.__version__

    def __init__(self, path: Path, native: bool = False, friction: dict | None = None, floating_base: bool = False,
                 package_dirs=()):
        super().__init__()
        self.package_dirs = tuple(package_dirs)
        self.model_path, self.label = Path(path), label_of(Path(path))
        facts = read_urdf(self.model_path, floating_base)
        self.floating_base = floating_base
        self.timestep, self.gravity, settings = timestep_gravity(self.model_path, facts)
        self.world, skel = load_world(self.model_path, self.timestep, self.gravity, floating_base, package_dirs)
        self.skel = skel
        settings.update(root_joint="FLOATING" if floating_base else "FIXED", deactivation="off",
                        self_collision="off",
                        joint_limits="off (position enforcement off; velocity and force limits infinite)",
                        tau_applied_via="skeleton.setForces before every step (cleared by the step)")
        if facts["massless_links"]:
            settings["massless_links"] = {n: "mass 0, inertia 0 (DART default: mass 1, identity inertia)"
                                          for n in facts["massless_links"]}
        self.free = facts["floating"]
        first = 6 if self.free else 0
        if self.free:
            root = skel.getJoint(0)
            assert root.getType() == "FreeJoint" and np.allclose(root.getTransformFromChildBodyNode().matrix(),
                                                                  np.eye(4)), f"{path}: DART's free root"
            self._base, self._quat = DartBase(root.getTransformFromParentBodyNode().matrix()), self.free.reference()[3:]
            how = "floating_base: the root link's" if floating_base else f"floating joint {self.free.name!r} as"
            settings["free_base"] = f"{how} DART's FreeJoint"
        n = skel.getNumDofs() - first
        names = self.joint_names = [skel.getDof(first + i).getName() for i in range(n)]
        assert names == [j.name for j in facts["joints"]], f"{path}: DART dof order {names}"
        self.body_names = [skel.getBodyNode(i).getName() for i in range(skel.getNumBodyNodes())]
        strip(skel, self.model_path)
        self.damping, self.stiffness, self.springref = set_passive(skel, facts, self.model_path, first)
        if self.stiffness.any():
            settings["stiffness_set_by_hand"] = nonzero_by_joint(names, self.stiffness)
            settings["springref_set_by_hand"] = nonzero_by_joint(names, self.springref)
        self.ignored = settings["ignored"] = ignored_extras(facts, understood={"stiffness", "springref"})
        if only_in_twin := twin_only(self.model_path, facts):
            settings["mjcf_twin_only"] = only_in_twin
        if native:
            settings["native"] = "nothing to leave on: passive forces are implicit in DART either way"
        for joint, value in self.check_friction(friction, names).items():
            skel.getDof(names.index(joint)).setCoulombFriction(value)
            settings.setdefault("joint_friction", {})[joint] = f"setCoulombFriction({value})"
        self.settings = settings
        self.passive, self.integrator = "implicit_damping_stiffness", "Euler"
        self.q_ref = np.r_[self.free.reference() if self.free else [], np.zeros(n)]
        self.ranges = [j.limit for j in facts["joints"]]

    def _set_timestep(self, h):
        self.world.setTimeStep(h)

    def set_state(self, q, v):
        q, v = np.asarray(q, float), np.asarray(v, float)
        if self.free:
            (positions, velocities), self._quat = self._base.to_engine(q, v), q[3:7]
            q, v = np.r_[positions, q[7:]], np.r_[velocities, v[6:]]
        self.skel.setPositions(q)
        self.skel.setVelocities(v)

    def get_state(self):
        q, v = np.array(self.skel.getPositions()), np.array(self.skel.getVelocities())
        if not self.free:
            return q, v
        base_q, base_v = self._base.from_engine(q[:6], v[:6], self._quat)
        self._quat = base_q[3:]
        return np.r_[base_q, q[6:]], np.r_[base_v, v[6:]]

    def step(self, tau):
        tau = np.asarray(tau, float)
        if self.free:
            tau = np.r_[self._base.forces(self.get_state()[0], tau), tau[6:]]
        self.skel.setForces(tau)  # cleared by the step: set before every step
        self.world.step()
        assert self.world.getLastCollisionResult().getNumContacts() == 0

    def dynamics(self, q, v):
        if self.free:
            raise NotImplementedError(f"{self.label}: M and c of a FreeJoint are in DART's coordinates "
                                      "(not converted to ours)")
        saved = self.get_state()
        self.set_state(q, v)
        # M excludes the implicit h D + h^2 K terms (those are getAugMassMatrix);
        # M a + getCoriolisAndGravityForces() = tau + passive
        M, c = np.array(self.skel.getMassMatrix()), np.array(self.skel.getCoriolisAndGravityForces())
        self.set_state(*saved)
        return M, c

    def _set(self, kind, owner, field, value):
        if kind == "body":
            node = self.skel.getBodyNode(owner)
            if field == "mass":
                node.setMass(float(value[0]))
            else:
                node.setLocalCOM(value)
        elif field == "damping":
            self.skel.getDof(self.joint_names.index(owner)).setDampingCoefficient(float(value[0]))
        else:
            self.skel.getDof(self.joint_names.index(owner)).setSpringStiffness(float(value[0]))

    def _get(self, kind, owner, field):
        if kind == "body":
            node = self.skel.getBodyNode(owner)
            return np.array([node.getMass()]) if field == "mass" else np.array(node.getLocalCOM())
        dof = self.skel.getDof(self.joint_names.index(owner))
        return np.array([dof.getDampingCoefficient() if field == "damping" else dof.getSpringStiffness()])


def contact_normal_forces(world) -> np.ndarray:
    """The normal force (N) of each contact of the world's last step: the contact's force
    (world frame, set by the constraint solver) along its unit normal, > 0 pushing apart."""
    contacts = world.getLastCollisionResult().getContacts()
    return np.array([float(np.dot(c.force, c.normal)) for c in contacts])
