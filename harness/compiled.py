"""A model as each engine compiled it, in one form, and the field-by-field comparison of two.

The form (`Compiled`): bodies {name: {parent, mass, com, inertia}} and joints {name: {type,
body, axis, range, damping, armature}}, read from the engine after it loaded the file:

- a body's parent is a body name ("world" for the fixed world; the world itself is left
  out), mass in kg, com in m in the body (URDF link) frame, inertia the 3x3 tensor about
  the COM in body axes (kg m^2);
- a joint's type is hinge | slide | ball | free, axis the unit axis in its body's frame,
  range (lo, hi) or None when unlimited, damping (N s/m or N m s/rad) and armature (kg or
  kg m^2; 0 in an engine that has none: PyBullet, DART 6.20).

Per body the comparison reports, in order, parent (the tree's topology), mass, com,
principal moments (the sorted eigenvalues of the inertia) and principal axes (the tensor
itself, once its moments agree); per joint type, body, axis, range, damping, armature. Two
numbers match when |a - b| <= tol max(1, |a|, |b|).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.engines.base import quiet_stdio

COMPILED_TOL = 1e-6  # relative; PyBullet diagonalises each inertia iteratively (~1e-8 off)
BODY_FIELDS = ("parent", "mass", "com", "principal moments", "principal axes")
JOINT_FIELDS = ("type", "body", "axis", "range", "damping", "armature")
WORLD = "world"


def body(parent: str, mass: float, com, inertia) -> dict:
    return {"parent": parent, "mass": float(mass), "com": np.asarray(com, float).reshape(3),
            "inertia": np.asarray(inertia, float).reshape(3, 3)}


def joint(kind: str, owner: str, axis, limits, damping: float, armature: float) -> dict:
    """A ball or free joint has no axis: zeros (engines store any)."""
    axis = np.asarray(axis, float).reshape(3) if kind in ("hinge", "slide") else np.zeros(3)
    return {"type": kind, "body": owner, "axis": axis,
            "range": None if limits is None else (float(limits[0]), float(limits[1])),
            "damping": float(damping), "armature": float(armature)}


# ---- each engine


def ours(model) -> dict:
    """From diffosi.Model.compiled()."""
    c = model.compiled()
    bodies = {b["name"]: body(b["parent"], b["mass"], b["com"], b["inertia"]) for b in c["bodies"][1:]}
    joints = {j["name"]: joint(j["type"], j["body"], j["axis"], j["range"], j["damping"], j["armature"])
              for j in c["joints"]}
    return {"bodies": bodies, "joints": joints}


def mujoco(m) -> dict:
    """From an MjModel (MJCF, or a URDF through MuJoCo's importer)."""
    import mujoco as mj

    from harness.engines.floating import quat_matrix

    bodies = {}
    for i in range(1, m.nbody):
        R = quat_matrix(m.body_iquat[i])
        bodies[m.body(i).name] = body(m.body(int(m.body_parentid[i])).name or WORLD, m.body_mass[i],
                                      m.body_ipos[i], R @ np.diag(m.body_inertia[i]) @ R.T)
    joints = {}
    for j in range(m.njnt):
        kind = mj.mjtJoint(m.jnt_type[j]).name.removeprefix("mjJNT_").lower()
        dof = m.jnt_dofadr[j]
        joints[m.joint(j).name] = joint(kind, m.body(int(m.jnt_bodyid[j])).name, m.jnt_axis[j],
                                        m.jnt_range[j] if m.jnt_limited[j] else None,
                                        m.dof_damping[dof], m.dof_armature[dof])
    return {"bodies": bodies, "joints": joints}


def pybullet(path: Path) -> dict:
    """PyBullet's own reading of a URDF (fixed base, inertia from the file: harness.corpus's
    load), before any adapter changes it. PyBullet's link frame is the COM frame; its
    dynamics info gives that frame in the URDF link frame, its joint axis is in the former."""
    import pybullet as pb

    from harness.corpus import pybullet_body, pybullet_client
    from harness.engines.floating import quat_matrix

    with quiet_stdio():
        p = pybullet_client()
        try:
            index = pybullet_body(p, path)
            if index is None:
                raise ValueError(f"PyBullet could not load {path}")
            return pybullet_read(p, index, pb, quat_matrix)
        finally:
            p.disconnect()


def pybullet_mjcf(path: Path) -> dict:
    """PyBullet's own reading of an MJCF file (loadMJCF, its defaults): every multibody it
    creates, read as `pybullet_read` reads a URDF's. PyBullet gives each MJCF joint a massless
    link of its own, welded to the body (`fold_massless` folds it); it raises pybullet.error
    on a file it cannot read."""
    import pybullet as pb

    from harness.corpus import pybullet_client
    from harness.engines.floating import quat_matrix

    with quiet_stdio():
        p = pybullet_client()
        try:
            return merged(pybullet_read(p, index, pb, quat_matrix) for index in p.loadMJCF(str(path)))
        finally:
            p.disconnect()


def pybullet_read(p, index: int, pb, quat_matrix) -> dict:
    kinds = {pb.JOINT_REVOLUTE: "hinge", pb.JOINT_PRISMATIC: "slide"}
    base = p.getBodyInfo(index)[0].decode()
    names = {-1: base}
    bodies, joints = {}, {}
    for link in [-1, *range(p.getNumJoints(index))]:
        info = p.getDynamicsInfo(index, link)
        w, x, y, z = info[4][3], *info[4][:3]  # PyBullet's quaternion is x, y, z, w
        R = quat_matrix([w, x, y, z])
        tensor = R @ np.diag(info[2]) @ R.T
        if link == -1:
            if base != WORLD:
                bodies[base] = body(WORLD, info[0], info[3], tensor)
            continue
        j = p.getJointInfo(index, link)
        name = names[link] = j[12].decode()
        bodies[name] = body(names[j[16]], info[0], info[3], tensor)
        if j[2] in kinds:
            lo, hi = j[8], j[9]
            # PyBullet gives the axis in the link's COM frame: R takes it to the URDF link frame
            joints[j[1].decode()] = joint(kinds[j[2]], name, R @ np.array(j[13]), (lo, hi) if lo < hi else None,
                                          j[6], 0.0)
    return {"bodies": bodies, "joints": joints}


def dart(skel) -> dict:
    """From a dartpy Skeleton (the DART adapter's). DART 6.20 has no armature."""
    kinds = {"RevoluteJoint": "hinge", "PrismaticJoint": "slide", "FreeJoint": "free", "BallJoint": "ball"}
    bodies, joints = {}, {}
    for i in range(skel.getNumBodyNodes()):
        node = skel.getBodyNode(i)
        parent = node.getParentBodyNode()
        bodies[node.getName()] = body(parent.getName() if parent is not None else WORLD, node.getMass(),
                                      node.getLocalCOM(), node.getInertia().getMoment())
        j = node.getParentJoint()
        if j.getType() not in kinds:
            continue
        lo, hi = j.getPositionLowerLimit(0), j.getPositionUpperLimit(0)
        # the axis is in the joint frame: the child body's frame takes it (the identity from a URDF)
        axis = (j.getTransformFromChildBodyNode().rotation() @ j.getAxis()
                if j.getType() in ("RevoluteJoint", "PrismaticJoint") else None)
        joints[j.getName()] = joint(kinds[j.getType()], node.getName(), axis,
                                    (lo, hi) if np.isfinite(lo) and np.isfinite(hi) and lo < hi else None,
                                    j.getDampingCoefficient(0), 0.0)
    return {"bodies": bodies, "joints": joints}


def dart_mjcf(path: Path) -> dict:
    """DART's own reading of an MJCF file (dartpy.utils.MjcfParser.readWorld, its defaults):
    every skeleton of the world it builds. Its parser ignores <inertial> (mass 1, identity
    inertia), which the comparison then names; it raises RuntimeError on a file it cannot read."""
    import dartpy

    world = dartpy.utils.MjcfParser.readWorld(Path(path).resolve().as_uri())  # its warnings: the caller's
    if world is None:
        raise ValueError(f"DART's MJCF parser returned no world for {path}")
    return merged(dart(world.getSkeleton(k)) for k in range(world.getNumSkeletons()))


def merged(parts) -> dict:
    """One compiled form from several (an engine's separate multibodies or skeletons)."""
    out: dict = {"bodies": {}, "joints": {}}
    for part in parts:
        out["bodies"].update(part["bodies"])
        out["joints"].update(part["joints"])
    return out


def fold_massless(c: dict) -> dict:
    """A twin comparison's view: a massless body with one child (a URDF's dummy link that
    carries one of several joints an MJCF body has) folded into that child, which takes its
    parent and its joints (their axes unchanged: the dummy link's frame is assumed the child's)."""
    bodies = {n: dict(b) for n, b in c["bodies"].items()}
    joints = {n: dict(j) for n, j in c["joints"].items()}
    for name in list(bodies):
        b = bodies[name]
        children = [n for n, x in bodies.items() if x["parent"] == name]
        if b["mass"] == 0.0 and not b["inertia"].any() and len(children) == 1:
            bodies[children[0]]["parent"] = b["parent"]
            for j in joints.values():
                j["body"] = children[0] if j["body"] == name else j["body"]
            del bodies[name]
    return {"bodies": bodies, "joints": joints}


# ---- the comparison


def close(a, b, tol: float) -> bool:
    if a is None or b is None or isinstance(a, str) or isinstance(b, str):
        return a == b
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(1.0, float(np.abs(a).max(initial=0.0)), float(np.abs(b).max(initial=0.0)))
    return a.shape == b.shape and float(np.abs(a - b).max(initial=0.0)) <= tol * scale


def body_values(b: dict, still: set) -> dict:
    return {"parent": WORLD if b["parent"] in still else b["parent"], "mass": b["mass"], "com": b["com"],
            "principal moments": np.linalg.eigvalsh(b["inertia"]), "principal axes": b["inertia"]}


def values(kind: str, item: dict, still: set) -> dict:
    """The compared fields; a parent welded to the world counts as the world."""
    return body_values(item, still) if kind == "body" else {f: item[f] for f in JOINT_FIELDS}


def shown(x):
    """A value as the report prints it."""
    if isinstance(x, np.ndarray):
        return np.round(x, 9).tolist()
    if isinstance(x, tuple):
        return [round(v, 9) for v in x]
    return round(x, 12) if isinstance(x, float) else x


def welded(c: dict) -> set:
    """The bodies welded to the world (no joint between them and it): with a fixed base they
    do not move, so their inertia does not enter the dynamics (engines drop or merge them)."""
    moving = {j["body"] for j in c["joints"].values()}
    out: set = set()
    for name in c["bodies"]:
        chain, x = [], name
        while x in c["bodies"] and x not in moving and x not in out:
            chain.append(x)
            x = c["bodies"][x]["parent"]
        if x == WORLD or x in out:
            out.update(chain)
    return out


def compare(a: dict, b: dict, tol: float = COMPILED_TOL) -> list[dict]:
    """One row per body and joint of either model: {"kind", "name", "match", "inert" (a body
    welded to the world in either, or massless, jointless and in one model only), "fields": [every differing field as {"field", "a", "b"}]};
    an element only one model has differs in the field "present"."""
    still = welded(a) | welded(b)
    moving = {j["body"] for c in (a, b) for j in c["joints"].values()}
    rows = []
    for kind, group in (("body", "bodies"), ("joint", "joints")):
        names = list(a[group]) + [n for n in b[group] if n not in a[group]]
        for name in names:
            x, y = a[group].get(name), b[group].get(name)
            if x is None or y is None:
                fields = [{"field": "present", "a": x is not None, "b": y is not None}]
                lone = x if x is not None else y
                inert = kind == "body" and (name in still or (not lone["mass"] and not lone["inertia"].any() and
                                                              name not in moving))
            else:
                vx, vy = values(kind, x, still), values(kind, y, still)
                fields = [{"field": f, "a": shown(vx[f]), "b": shown(vy[f])} for f in vx if not close(vx[f], vy[f], tol)]
                inert = kind == "body" and name in still
            rows.append({"kind": kind, "name": name, "match": not fields, "fields": fields, "inert": inert})
    return rows


def mismatches(rows: list[dict]) -> list[dict]:
    """Every differing field as {"kind", "name", "inert", "field", "a", "b"}."""
    return [{"kind": r["kind"], "name": r["name"], "inert": r["inert"], **f} for r in rows for f in r["fields"]]
