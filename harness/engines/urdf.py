"""URDF facts PyBullet and DART need, read with the standard library (not by any engine).

Our URDF extensions live in the namespace urn:diffosi:urdf (see src/model/urdf.rs):
<diffosi:options timestep gravity integrator> and, on <dynamics>, diffosi:stiffness,
diffosi:springref, diffosi:armature. Neither PyBullet nor DART reads them.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.engines.base import label_of
from harness.engines.floating import rpy_quat

MOVABLE = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slide"}
DIFFOSI_NS = "{urn:diffosi:urdf}"
DEFAULT_GRAVITY = [0.0, 0.0, -9.81]
DEFAULT_TIMESTEP = 0.002  # s: MuJoCo's and our URDF loader's


@dataclass
class UrdfJoint:
    name: str
    kind: str  # hinge | slide
    limit: tuple | None
    damping: float
    friction: float
    extensions: dict  # our <dynamics> attributes (namespace urn:diffosi:urdf): stiffness, springref, ...


@dataclass
class FloatingJoint:
    """A free root: the floating joint from `world` to the link `child`; xyz and rpy are its
    <origin>, the base's pose at the reference configuration."""

    name: str
    child: str
    xyz: tuple
    rpy: tuple

    def reference(self) -> np.ndarray:
        """q[:7] at the reference configuration (ours and MuJoCo's convention)."""
        return np.r_[self.xyz, rpy_quat(self.rpy)]


def local_name(key: str) -> str:
    return key.split("}")[-1]


def read_urdf(path: Path, floating_base: bool = False) -> dict:
    """Movable one-dof joints in document order (asserted parent-first), the floating joint
    (a free root) if any, links without <inertial>, and the attributes of <diffosi:options>.
    floating_base=True: the root link (not `world`) floats, as diffosi's
    Model.load(path, floating_base=True) and PyBullet's useFixedBase=False read it: a free
    joint 'root_joint' at the world origin."""
    root = ET.parse(path).getroot()
    links = [link.get("name") for link in root.findall("link")]
    children = {j.find("child").get("link") for j in root.findall("joint")}
    roots = [link for link in links if link not in children]
    assert len(roots) == 1, f"{path}: expected one root link, got {roots}"
    placed, joints, floating = {roots[0]}, [], None
    if floating_base:
        assert roots[0] != "world", f"{path}: floating_base, but the root link is the world"
        floating = FloatingJoint("root_joint", roots[0], (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    for j in root.findall("joint"):
        parent, child = j.find("parent").get("link"), j.find("child").get("link")
        assert parent in placed, f"{path}: joint {j.get('name')} comes before its parent link"
        placed.add(child)
        kind = j.get("type")
        if kind == "fixed":
            continue
        if kind == "floating":
            assert floating is None and not joints and parent == roots[0] == "world", \
                f"{path}: a floating joint must be the first joint, from the root link 'world'"
            origin = j.find("origin")
            pose = [tuple(float(x) for x in (origin.get(k, "0 0 0") if origin is not None else "0 0 0").split())
                    for k in ("xyz", "rpy")]
            floating = FloatingJoint(j.get("name"), child, *pose)
            continue
        assert kind in MOVABLE, f"{path}: joint type {kind} is not supported"
        lim = j.find("limit")
        limit = None
        if kind != "continuous" and lim is not None:
            lo, hi = float(lim.get("lower", 0)), float(lim.get("upper", 0))
            limit = (lo, hi) if lo < hi else None  # lower = upper (= 0 by default): no limit
        dyn = j.find("dynamics")
        attrs = dyn.attrib if dyn is not None else {}
        # other attributes (a vendor's D, K, mu_viscous, ...) are no engine's: only ours are read
        ours = {local_name(k): float(v) for k, v in attrs.items() if k.startswith(DIFFOSI_NS)}
        joints.append(UrdfJoint(
            name=j.get("name"), kind=MOVABLE[kind], limit=limit,
            damping=float(attrs.get("damping", 0.0)), friction=float(attrs.get("friction", 0.0)), extensions=ours,
        ))
    massless = [link.get("name") for link in root.findall("link")
                if link.find("inertial") is None and (link.get("name") != roots[0] or floating_base)]
    options = root.find(f"{DIFFOSI_NS}options")
    return {"root": roots[0], "links": links, "joints": joints, "floating": floating, "floating_base": floating_base,
            "massless_links": massless, "options": dict(options.attrib) if options is not None else {}}


def mjcf_twin_facts(urdf: Path) -> dict | None:
    from harness.engines.mujoco import mjcf_facts

    twin = urdf.with_suffix(".xml")
    return mjcf_facts(twin) if twin.exists() else None


def timestep_gravity(urdf: Path, facts: dict) -> tuple[float, list, dict]:
    """From the URDF's <diffosi:options> (gravity default -9.81 z), else from the MJCF twin,
    else the defaults; when both exist they must agree."""
    twin = urdf.with_suffix(".xml")
    from_twin = mjcf_twin_facts(urdf)
    opts = facts["options"]
    if "timestep" in opts:
        h = float(opts["timestep"])
        g = [float(x) for x in opts["gravity"].split()] if "gravity" in opts else DEFAULT_GRAVITY
        source = {"timestep_gravity_from": f"<diffosi:options> of {label_of(urdf)}"}
        if from_twin:
            assert (h, g) == (from_twin["timestep"], from_twin["gravity"]), \
                f"{urdf}: timestep/gravity {h} {g} differ from the MJCF twin's"
            source["mjcf_twin_agrees"] = label_of(twin)
        return h, g, source
    if from_twin is None:  # a user's URDF: the defaults our loader and MuJoCo's importer use
        return DEFAULT_TIMESTEP, DEFAULT_GRAVITY, {
            "timestep_gravity_from": f"defaults (the file sets none): h = {DEFAULT_TIMESTEP} s, gravity {DEFAULT_GRAVITY}"}
    return from_twin["timestep"], from_twin["gravity"], {"timestep_gravity_from": label_of(twin)}


def ignored_extras(facts: dict, understood: set) -> dict:
    """Nonzero diffosi extension attributes of the URDF's <dynamics> (stiffness, armature, ...)
    that the engine did not simulate: {attribute: {joint: value}}. A comparison sets them to
    zero in our model first. (springref is left out: without stiffness it is no force.)"""
    out: dict = {}
    for j in facts["joints"]:
        for key, value in j.extensions.items():
            if value and key not in understood and key != "springref":
                out.setdefault(key, {})[j.name] = value
    return out


def twin_only(urdf: Path, facts: dict, keys=("stiffness", "armature")) -> dict:
    """Passive parameters the MJCF twin has and the URDF does not carry (information only:
    our engine loading the URDF has none of them either)."""
    twin = mjcf_twin_facts(urdf)
    out: dict = {}
    for j in facts["joints"]:
        for key in keys:
            if twin and twin[key].get(j.name) and not j.extensions.get(key):
                out.setdefault(key, {})[j.name] = twin[key][j.name]
    return out


def package_directories(urdf: Path, package_dirs=()) -> dict:
    """{NAME: directory} for each package://NAME/ the URDF names, found as our loader finds it
    (src/model/urdf/package.rs): in each of package_dirs, then in the URDF's directory and its
    ancestors, then in ROS_PACKAGE_PATH; in a directory D the package is D when D is named
    NAME, else D/NAME. A package found nowhere is left out (the engine's loader then says so)."""
    names = dict.fromkeys(re.findall(r"package://([^/\"'\s]+)", Path(urdf).read_text()))
    here = Path(urdf).resolve().parent
    ros = [Path(d) for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]
    places = [*map(Path, package_dirs), here, *here.parents, *ros]
    found = {}
    for name in names:
        dirs = [d for d in (p if p.name == name else p / name for p in places) if d.is_dir()]
        if dirs:
            found[name] = dirs[0]
    return found
