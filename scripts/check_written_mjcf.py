#!/usr/bin/env python3
"""Compile the MJCF files our writer produced with MuJoCo, and check them.

Usage (from the repository root, with the project venv):

    cargo test --release --test roundtrip          # writes target/tmp/roundtrip/*.xml
    .venv/bin/python scripts/check_written_mjcf.py

Every written file must compile, and MuJoCo's body masses, COMs and inertia
tensors must be the <inertial> values written in it. A file written from an
MJCF model (reference_*, data_*, gym_*; not *_urdf, random*) must also compile
to the same model as its original: body poses and inertias, joints, dofs,
geoms, actuators, options, and 200 steps of the smooth dynamics (constraints
and contacts disabled; the Spec holds neither) under random controls. Our
loader reads disabled gravity as zero gravity.
Tolerance 1e-12, relative (inertia tensors: to their largest entry); exit 1
on any failure.
"""

import pathlib
import sys
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
WRITTEN = ROOT / "target" / "tmp" / "roundtrip"
ORIGINALS = {
    "reference": ROOT / "reference_models",
    "data": ROOT / "tests" / "data",
    "gym": pathlib.Path(__import__("gymnasium").__file__).parent / "envs" / "mujoco" / "assets",
}
TOL = 1e-12


def error(a, b):
    """Largest difference relative to the largest entry (floor 1e-300)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b), initial=0.0) / max(np.max(np.abs(b), initial=0.0), 1e-300))


def tensors(m):
    """Each body's inertia tensor about its COM, in body axes."""
    out = []
    for i in range(m.nbody):
        r = np.zeros(9)
        mujoco.mju_quat2Mat(r, m.body_iquat[i])
        r = r.reshape(3, 3)
        out.append(r @ np.diag(m.body_inertia[i]) @ r.T)
    return np.array(out)


def rotations(quats):
    out = np.zeros((len(quats), 9))
    for r, q in zip(out, quats):
        mujoco.mju_quat2Mat(r, q)
    return out


def written_inertials(path):
    """(mass, COM, tensor) of each body's <inertial>, in document order."""
    out = []
    for inertial in ET.parse(path).getroot().iter("inertial"):
        num = lambda key: [float(x) for x in inertial.get(key).split()]
        if inertial.get("fullinertia"):
            xx, yy, zz, xy, xz, yz = num("fullinertia")
            tensor = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
        else:
            tensor = np.diag(num("diaginertia"))
        out.append((num("mass")[0], num("pos"), tensor))
    return out


def rollout(m, seed):
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    states = []
    for _ in range(200):
        d.ctrl[:] = rng.uniform(-1, 1, m.nu)
        mujoco.mj_step(m, d)
        states.append(np.concatenate([d.qpos, d.qvel]))
    return np.array(states)


def sizes(m):
    """The geom size entries a shape uses (a plane's only render)."""
    g = mujoco.mjtGeom
    used = {int(g.mjGEOM_PLANE): 0, int(g.mjGEOM_SPHERE): 1, int(g.mjGEOM_CAPSULE): 2,
            int(g.mjGEOM_CYLINDER): 2}
    return np.concatenate([s[:used.get(int(t), 3)] for s, t in zip(m.geom_size, m.geom_type)])


def options(m):
    """Timestep, effective gravity and integrator, as our loader reads them."""
    integrator = int(m.opt.integrator)
    gravity_on = not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    return [m.opt.timestep, *(m.opt.gravity * gravity_on), integrator]


def compare_with_original(m, m0):
    gain = lambda m: m.actuator_gear[:, 0] * m.actuator_gainprm[:, 0]
    ctrlrange = lambda m: m.actuator_ctrlrange * m.actuator_ctrllimited[:, None]
    checks = {
        "body_pos": (m.body_pos, m0.body_pos),
        "body_rot": (rotations(m.body_quat), rotations(m0.body_quat)),
        "body_mass": (m.body_mass, m0.body_mass),
        "body_ipos": (m.body_ipos, m0.body_ipos),
        "body_inertia": (tensors(m), tensors(m0)),
        "jnt_type": (m.jnt_type, m0.jnt_type),
        "jnt_axis": (m.jnt_axis, m0.jnt_axis),
        "jnt_pos": (m.jnt_pos, m0.jnt_pos),
        "jnt_range": (m.jnt_range * m.jnt_limited[:, None], m0.jnt_range * m0.jnt_limited[:, None]),
        "qpos0": (m.qpos0, m0.qpos0),
        "qpos_spring": (m.qpos_spring, m0.qpos_spring),
        "jnt_stiffness": (m.jnt_stiffness, m0.jnt_stiffness),
        "dof_damping": (m.dof_damping, m0.dof_damping),
        "dof_armature": (m.dof_armature, m0.dof_armature),
        "dof_frictionloss": (m.dof_frictionloss, m0.dof_frictionloss),
        "geom_pos": (m.geom_pos, m0.geom_pos),
        "geom_rot": (rotations(m.geom_quat), rotations(m0.geom_quat)),
        "geom_size": (sizes(m), sizes(m0)),
        "geom_contype": (m.geom_contype, m0.geom_contype),
        "geom_conaffinity": (m.geom_conaffinity, m0.geom_conaffinity),
        "geom_friction": (m.geom_friction, m0.geom_friction),
        "actuator_gain": (gain(m), gain(m0)),
        "ctrlrange": (ctrlrange(m), ctrlrange(m0)),
        "options": (options(m), options(m0)),
        "rollout": (rollout(m, 0), rollout(m0, 0)),
    }
    return {k: error(a, b) for k, (a, b) in checks.items()}


def check(path):
    m = mujoco.MjModel.from_xml_path(str(path))
    written = written_inertials(path)
    errors = {
        "written mass": error(m.body_mass[1:], [w[0] for w in written]),
        "written com": error(m.body_ipos[1:], [w[1] for w in written]),
        "written inertia": max(error(t, w[2]) for t, w in zip(tensors(m)[1:], written)),
    }
    prefix, _, stem = path.stem.partition("_")
    if prefix in ORIGINALS and not stem.endswith("_urdf"):
        m0 = mujoco.MjModel.from_xml_path(str(ORIGINALS[prefix] / f"{stem}.xml"))
        errors.update(compare_with_original(m, m0))
    return errors


def main():
    files = sorted(WRITTEN.glob("*.xml"))
    if not files:
        sys.exit(f"no files in {WRITTEN}: run `cargo test --release --test roundtrip` first")
    failed = False
    for path in files:
        errors = check(path)
        worst = max(errors, key=errors.get)
        bad = {k: v for k, v in errors.items() if not v <= TOL}
        failed |= bool(bad)
        print(f"{path.stem:32} {len(errors):2} checks, worst {errors[worst]:.1e} ({worst})"
              + (f"  FAILED: {bad}" if bad else ""))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
