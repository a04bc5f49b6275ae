#!/usr/bin/env python3
"""Write MuJoCo's compiled view of MJCF files as JSON, the truth for our MJCF loader.

Usage (from the repository root, with the project venv):

    .venv/bin/python scripts/mujoco_compiled.py            # default set, see below
    .venv/bin/python scripts/mujoco_compiled.py a.xml ...  # just these files

The default set is gymnasium's fourteen MuJoCo models, written as gym_<name>.json, and
every reference_models/*.xml and tests/data/mjcf_*.xml, written as <name>.json,
all into reference_models/golden/compiled/. tests/mjcf_vs_mujoco.rs loads the same
XML with our loader and compares.

Conventions of the output: quaternions (w, x, y, z); body pos/quat relative to
the parent body; ipos/iquat the inertial frame in the body frame and inertia the
principal moments in it; joint axis/pos in the body frame; angles in radians
(MuJoCo has already converted degrees). Every number is a float written with
repr(), so it reads back exactly.
"""

import json
import pathlib
import sys

import mujoco

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "reference_models" / "golden" / "compiled"
GYM_ASSETS = pathlib.Path(
    __import__("gymnasium").__file__).parent / "envs" / "mujoco" / "assets"
GYM_MODELS = [
    "half_cheetah", "hopper", "walker2d", "walker2d_v5", "inverted_pendulum",
    "inverted_double_pendulum", "reacher", "pusher", "pusher_v5", "point",
    "swimmer", "ant", "humanoid", "humanoidstandup",
]
INTEGRATORS = {
    int(mujoco.mjtIntegrator.mjINT_EULER): "Euler",
    int(mujoco.mjtIntegrator.mjINT_RK4): "RK4",
    int(mujoco.mjtIntegrator.mjINT_IMPLICIT): "implicit",
    int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast",
}
JOINT_TYPES = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
GEOM_TYPES = {0: "plane", 1: "hfield", 2: "sphere", 3: "capsule", 4: "ellipsoid",
              5: "cylinder", 6: "box", 7: "mesh", 8: "sdf"}


def floats(a):
    return [float(x) for x in a]


def compiled(m):
    """The parts of a compiled mjModel that our Model holds."""
    name = lambda obj, i: mujoco.mj_id2name(m, obj, i) or ""
    opt = {
        "timestep": float(m.opt.timestep),
        "gravity": floats(m.opt.gravity),
        "integrator": INTEGRATORS[int(m.opt.integrator)],
        "eulerdamp_disabled": bool(m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EULERDAMP),
        "gravity_disabled": bool(m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY),
        "density": float(m.opt.density),
        "viscosity": float(m.opt.viscosity),
        "wind": floats(m.opt.wind),
    }
    bodies = [{
        "name": name(mujoco.mjtObj.mjOBJ_BODY, i),
        "parent": int(m.body_parentid[i]),
        "pos": floats(m.body_pos[i]),
        "quat": floats(m.body_quat[i]),
        "mass": float(m.body_mass[i]),
        "ipos": floats(m.body_ipos[i]),
        "iquat": floats(m.body_iquat[i]),
        "inertia": floats(m.body_inertia[i]),
    } for i in range(m.nbody)]
    joints = []
    for j in range(m.njnt):
        dof = int(m.jnt_dofadr[j])
        qpos = int(m.jnt_qposadr[j])
        nq = {0: 7, 1: 4}.get(int(m.jnt_type[j]), 1)
        joints.append({
            "name": name(mujoco.mjtObj.mjOBJ_JOINT, j),
            "type": JOINT_TYPES[int(m.jnt_type[j])],
            "body": int(m.jnt_bodyid[j]),
            "axis": floats(m.jnt_axis[j]),
            "pos": floats(m.jnt_pos[j]),
            "limited": bool(m.jnt_limited[j]),
            "range": floats(m.jnt_range[j]),
            "damping": float(m.dof_damping[dof]),
            "stiffness": float(m.jnt_stiffness[j]),
            "springref": float(m.qpos_spring[qpos]),
            "armature": float(m.dof_armature[dof]),
            "ref": float(m.qpos0[qpos]),
            "frictionloss": float(m.dof_frictionloss[dof]),
            "qpos0": floats(m.qpos0[qpos:qpos + nq]),
        })
    actuators = [{
        "name": name(mujoco.mjtObj.mjOBJ_ACTUATOR, a),
        "joint": int(m.actuator_trnid[a, 0]),
        "trntype": int(m.actuator_trntype[a]),
        "gear": float(m.actuator_gear[a, 0]),
        "gain": float(m.actuator_gainprm[a, 0]),
        "ctrllimited": bool(m.actuator_ctrllimited[a]),
        "ctrlrange": floats(m.actuator_ctrlrange[a]),
    } for a in range(m.nu)]
    geoms = [{
        "name": name(mujoco.mjtObj.mjOBJ_GEOM, g),
        "type": GEOM_TYPES[int(m.geom_type[g])],
        "body": int(m.geom_bodyid[g]),
        "size": floats(m.geom_size[g]),
        "pos": floats(m.geom_pos[g]),
        "quat": floats(m.geom_quat[g]),
        "contype": int(m.geom_contype[g]),
        "conaffinity": int(m.geom_conaffinity[g]),
        "friction": floats(m.geom_friction[g]),
    } for g in range(m.ngeom)]
    return {"model": m.names[:m.names.index(b"\0")].decode(), "opt": opt, "bodies": bodies,
            "joints": joints, "actuators": actuators, "geoms": geoms}


def write(xml, out_name, source):
    m = mujoco.MjModel.from_xml_path(str(xml))
    data = {"source": source, **compiled(m)}
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / f"{out_name}.json"
    path.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {path.relative_to(ROOT)}")


def write_file(path):
    """A model file, named in the JSON relative to the repository if inside it."""
    path = path.resolve()
    source = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    write(path, path.stem, str(source))


def main(args):
    if args:
        for a in args:
            write_file(pathlib.Path(a))
        return
    for stem in GYM_MODELS:
        write(GYM_ASSETS / f"{stem}.xml", f"gym_{stem}", f"gymnasium:{stem}.xml")
    for p in sorted((ROOT / "reference_models").glob("*.xml")):
        write_file(p)
    for p in sorted((ROOT / "tests" / "data").glob("mjcf_*.xml")):
        write_file(p)


if __name__ == "__main__":
    main(sys.argv[1:])
