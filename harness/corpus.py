"""The corpus: real robot files from three collections, each loaded, stepped and checked against its engine.

The collections are test data installed by `make setup` (requirements-data.txt, pip --no-deps):
- dm_control: every suite model (dm_control/suite/*.xml).
- example-robot-data: every URDF (cmeel.prefix/share/example-robot-data/robots) that
  PyBullet loads.
- pybullet_data: every robot URDF, where a robot is a URDF that PyBullet loads and in which
  PyBullet finds at least one joint that is not fixed.
"PyBullet loads" means loadURDF(useFixedBase=True, flags URDF_USE_INERTIA_FROM_FILE,
URDF_IGNORE_VISUAL_SHAPES, URDF_IGNORE_COLLISION_SHAPES) returns a body: no shape is needed
(contacts are off in every comparison) and meshes would take half a minute to read. A URDF's
base is fixed, in PyBullet and in ours (our default, as MuJoCo's importer and Pinocchio).

The checks of a model (each "ok", an error message, or "-" when it does not apply):
1. load: diffosi.Model.load(path), a URDF with the collection's package directories
   (`package_dirs`) and our default reading of <inertial> (as written: Pinocchio's).
2. one step: SAMPLES seeded random states and generalized forces tau (q: the reference
   configuration +- 0.5, quaternions normalised, as golden_free; URDF: a limited joint's q in
   its range, else +- 1; v uniform in [-1, 1]; tau uniform in [-1, 1] times 10 M_ii at the
   reference configuration, M_ii at least 1e-3), one step in ours and in the engine, ctrl = 0.
   MJCF: MuJoCo's mj_step with the file's options but contacts and joint limits disabled, ours
   with contact=False, limits=False. URDF: PyBullet as the harness runs a URDF twin (no link
   damping or velocity cap, limits and collisions off, velocity motors at force 0, explicit
   joint damping), at our timestep and gravity; ours loaded with inertial="pybullet" (PyBullet's
   reading of <inertial>: mass 1 and unit inertia where a link has none, each tensor in the
   principal axes of Bullet's Jacobi iteration, off the file by up to ~1e-8 relative, and
   tensors with negative or triangle-violating moments zeroed) and run with passive="explicit",
   contact=False, limits=False. Joints are matched by name. Error as replay's:
   max(|dq| / max(1, |q'|), |dv| / max(1, |v'|)), PASS at <= 1e-12. Where PyBullet's reading
   departs from the file, the row's notes say how (pybullet_inertia_notes).
3. Pinocchio (example-robot-data): the acceleration at SAMPLES random states and tau (q and v
   uniform in [-1, 1], tau in [-5, 5], as harness/tests/test_pinocchio.py) vs pinocchio.aba
   on buildModelFromUrdf (ours as loaded in 1., Pinocchio's reading; fixed base; no damping,
   friction or armature in Pinocchio's ABA, so
   ours has damping and dry friction zeroed and runs one explicit step of h = 1 s: a = v' - v),
   relative error max|a - a_pin| / max|a_pin|, PASS at <= 1e-12.
4. rest: 1000 steps of the model as loaded (the file's defaults: contacts, limits and options
   on) from the reference configuration at rest under zero tau: no step raises (our engine
   refuses a non-finite state) and every velocity is finite.

    python -m harness corpus --seed 0      # writes reports/corpus.md and reports/corpus.json
    python -m harness corpus --known-failures   # also prints test_corpus.py's KNOWN_FAILURES entries
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
import sysconfig
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from harness.engines.base import quiet_stdio
from harness.engines.numpy_step import step_error
from harness.report import REPORTS, markdown_table, write_json, write_markdown

ONE_STEP_TOL = 1e-12
PINOCCHIO_TOL = 1e-12
SAMPLES = 5
REST_STEPS = 1000
SOURCES = ("dm_control", "example-robot-data", "pybullet_data")
NOT_RUN = "-"


@dataclass
class Case:
    """One model of the corpus: `name` is <source>:<path in the collection>."""

    source: str
    path: Path
    root: Path
    reference: str  # nq/nv/nu in the engine (MuJoCo; PyBullet: its movable joints, no actuators)
    package_dirs: list = field(default_factory=list)

    @property
    def name(self) -> str:
        return f"{self.source}:{self.path.relative_to(self.root)}"

    @property
    def kind(self) -> str:
        return "mjcf" if self.path.suffix == ".xml" else "urdf"


def dm_control_suite() -> Path:
    spec = importlib.util.find_spec("dm_control")
    if spec is None:  # outside the checkout's venv: the data packages are not diffosi[harness]'s
        sys.exit("python -m harness corpus: the corpus is the files of requirements-data.txt's packages, "
                 "and dm_control is not installed (pip install --no-deps -r requirements-data.txt)")
    return Path(spec.submodule_search_locations[0]) / "suite"


def example_robot_data() -> Path:
    return Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


def pybullet_data() -> Path:
    import pybullet_data as data

    return Path(data.getDataPath())


# ---- PyBullet


PYBULLET_FLAGS = ("URDF_USE_INERTIA_FROM_FILE", "URDF_IGNORE_VISUAL_SHAPES", "URDF_IGNORE_COLLISION_SHAPES")


def pybullet_client():
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    return BulletClient(connection_mode=pybullet.DIRECT)


def pybullet_body(p, path: Path) -> int | None:
    """PyBullet's fixed-base load of a URDF (see the module doc) into client p, or None if it fails."""
    import pybullet

    flags = 0
    for name in PYBULLET_FLAGS:
        flags |= getattr(pybullet, name)
    try:
        return p.loadURDF(str(path), useFixedBase=True, flags=flags)
    except pybullet.error:
        return None


def pybullet_movable(p, body: int) -> list:
    import pybullet

    return [i for i in range(p.getNumJoints(body)) if p.getJointInfo(body, i)[2] != pybullet.JOINT_FIXED]


def pybullet_cases(source: str, root: Path, package_dirs: list, robots_only: bool) -> list:
    cases = []
    with quiet_stdio():
        p = pybullet_client()
        for path in sorted(root.rglob("*.urdf")):
            body = pybullet_body(p, path)
            if body is None:
                continue
            n = len(pybullet_movable(p, body))
            p.removeBody(body)
            if n or not robots_only:
                cases.append(Case(source, path, root, f"{n}/{n}/-", package_dirs))
        p.disconnect()
    return cases


def discover() -> list:
    """Every model of the corpus, in a fixed order (see the module doc)."""
    from harness.engines.mujoco import load_mjcf

    cases = []
    suite = dm_control_suite()
    for path in sorted(suite.glob("*.xml")):
        with quiet_stdio():  # MuJoCo prints compiler warnings (settotalmass is deprecated)
            m = load_mjcf(path)
        cases.append(Case("dm_control", path, suite, f"{m.nq}/{m.nv}/{m.nu}"))
    erd = example_robot_data()
    cases += pybullet_cases("example-robot-data", erd, [erd.parent.parent, erd], robots_only=False)
    cases += pybullet_cases("pybullet_data", pybullet_data(), [pybullet_data()], robots_only=True)
    return cases


# ---- ours


def load_ours(case: Case, inertial: str = "pinocchio"):
    """diffosi.Model.load; a URDF with the collection's package_dirs and `inertial`, whose reading of
    <inertial>: "pinocchio" (as written, our default) or "pybullet" (PyBullet's importer)."""
    import diffosi

    if case.kind == "urdf":
        dirs = [str(d) for d in case.package_dirs]
        return diffosi.Model.load(str(case.path), package_dirs=dirs, inertial=inertial)
    return diffosi.Model.load(str(case.path))


def message(error: BaseException, case: Case) -> str:
    """An error as one line, the collection's directory shortened to <source>."""
    text = f"{type(error).__name__}: {error}".replace(str(case.root), f"<{case.source}>")
    return " ".join(text.split())


def seeded(seed: int, case: Case, check: str):
    return np.random.default_rng([seed, zlib.crc32(f"{case.name}/{check}".encode())])


def torque_scale(M: np.ndarray) -> np.ndarray:
    return 10.0 * np.maximum(np.diag(M), 1e-3)


# ---- check 2, MJCF: MuJoCo


def mujoco_one_step(case: Case, ours, seed: int) -> tuple[float, dict]:
    import mujoco

    from harness.engines.mujoco import load_mjcf
    from harness.golden_free import full_mass, sample_q

    printed: list = []
    with quiet_stdio(printed):
        m = load_mjcf(case.path)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    d = mujoco.MjData(m)
    if (ours.nq, ours.nv) != (m.nq, m.nv):
        raise ValueError(f"ours has nq, nv = {ours.nq}, {ours.nv}; MuJoCo {m.nq}, {m.nv}")
    ours = ours.with_options(contact=False, limits=False)
    rng, scale = seeded(seed, case, "one_step"), torque_scale(full_mass(m, mujoco.MjData(m), m.qpos0))
    worst = 0.0
    for _ in range(SAMPLES if m.nv else 0):
        q, v = sample_q(m, rng), rng.uniform(-1.0, 1.0, m.nv)
        tau = rng.uniform(-1.0, 1.0, m.nv) * scale
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:], d.ctrl[:] = q, v, tau, 0.0
        mujoco.mj_step(m, d)
        worst = max(worst, step_error(*ours.step(q, v, tau)[:2], d.qpos, d.qvel))
    notes = {"engine": f"MuJoCo {mujoco.__version__}", "disabled": ["contact", "limit"],
             "integrator": mujoco.mjtIntegrator(m.opt.integrator).name}
    return worst, {**notes, "mujoco_output": printed} if printed else notes


# ---- check 2, URDF: PyBullet


def inertia_tensor(inertial) -> np.ndarray:
    """A URDF <inertial>'s inertia about its COM, in the link frame."""
    from harness.engines.floating import quat_matrix, rpy_quat

    a = {k: float(inertial.find("inertia").get(k, 0.0)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    tensor = np.array([[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]], [a["ixz"], a["iyz"], a["izz"]]])
    origin = inertial.find("origin")
    R = quat_matrix(rpy_quat([float(x) for x in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0")
                              .split()]))
    return R @ tensor @ R.T


def pybullet_inertia_notes(path: Path, p, body: int) -> dict:
    """Where PyBullet's link inertias differ from the file: links without <inertial> (PyBullet: mass
    1, unit inertia), and the largest relative error of PyBullet's principal-axes form R diag R^T of
    a link's inertia (its importer diagonalises the tensor iteratively: up to 6e-8 measured on this corpus)."""
    import xml.etree.ElementTree as ET

    try:
        links = ET.parse(path).getroot().findall("link")
    except ET.ParseError as e:
        return {"urdf_not_xml": str(e)}
    index = {p.getJointInfo(body, i)[12].decode(): i for i in range(p.getNumJoints(body))}
    no_inertial, worst = [], 0.0
    for link in links:
        name, inertial = link.get("name"), link.find("inertial")
        if name not in index:  # the base: fixed, so its inertia does not matter
            continue
        if inertial is None:
            no_inertial.append(name)
            continue
        if inertial.find("inertia") is None:
            continue
        exact = inertia_tensor(inertial)
        info = p.getDynamicsInfo(body, index[name])
        R = np.array(p.getMatrixFromQuaternion(info[4])).reshape(3, 3)
        if np.abs(exact).max() > 0:
            worst = max(worst, float(np.abs(R @ np.diag(info[2]) @ R.T - exact).max() / np.abs(exact).max()))
    notes = {"pybullet_inertia_diagonalisation_error": worst}
    if no_inertial:
        notes["links_without_inertial"] = no_inertial
    return notes


def pybullet_one_step(case: Case, ours, seed: int) -> tuple[float, dict]:
    import pybullet

    warnings: list = []
    with quiet_stdio(warnings):
        p = pybullet_client()
        body = pybullet_body(p, case.path)
    try:
        with quiet_stdio(warnings):
            try:
                error, notes = pybullet_steps(case, ours, seed, p, body)
            except pybullet.error as e:  # a call PyBullet refuses on this model: the check's error
                raise ValueError(f"PyBullet: {e}") from e
        zeroed = sorted({w.split(":")[-1].strip() for w in warnings if "setting inertia to zero" in w})
        if zeroed:
            notes["pybullet_zeroed_inertia"] = zeroed
        return error, {**notes, **pybullet_inertia_notes(case.path, p, body)}
    finally:
        p.disconnect()


def pybullet_steps(case: Case, ours, seed: int, p, body: int) -> tuple[float, dict]:
    import pybullet

    from harness.engines.pybullet import strip

    movable = pybullet_movable(p, body)
    info = [p.getJointInfo(body, i) for i in movable]
    other = [j[1].decode() for j in info if j[2] not in (pybullet.JOINT_REVOLUTE, pybullet.JOINT_PRISMATIC)]
    if other:
        raise ValueError(f"PyBullet joints with more than one dof: {other}")
    names = [j[1].decode() for j in info]
    if sorted(names) != sorted(ours.joint_names) or ours.nq != ours.nv:
        raise ValueError(f"joints differ: PyBullet {names}, ours {ours.joint_names} (nq {ours.nq})")
    order = [names.index(n) for n in ours.joint_names]  # PyBullet's index of each of our joints
    p.setGravity(*ours.gravity)
    p.setTimeStep(ours.timestep)
    p.setPhysicsEngineParameter(numSubSteps=0)
    settings: dict = {}
    strip(p, body, list(range(p.getNumJoints(body))), movable, settings)
    ours = ours.with_options(passive="explicit", contact=False, limits=False)
    for joint in ours.joint_names:  # PyBullet has no dry joint friction (MuJoCo's frictionloss rows)
        ours.set_param(f"joint/{joint}/frictionloss", 0.0)
    n = len(names)
    rng = seeded(seed, case, "one_step")
    M = np.array(p.calculateMassMatrix(body, [0.0] * n)) if n else np.zeros((0, 0))
    scale = torque_scale(M)[order]
    limits = [(info[k][8], info[k][9]) for k in order]
    worst = 0.0
    for _ in range(SAMPLES if n else 0):
        q = np.array([rng.uniform(lo, hi) if lo < hi else rng.uniform(-1.0, 1.0) for lo, hi in limits])
        v, tau = rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n) * scale
        for k, i in enumerate(order):
            p.resetJointState(body, movable[i], q[k], v[k])
        forces = np.zeros(n)
        forces[order] = tau
        p.setJointMotorControlArray(body, movable, pybullet.TORQUE_CONTROL, forces=forces.tolist())
        p.stepSimulation()
        states = p.getJointStates(body, movable)
        q1, v1 = (np.array([states[i][k] for i in order]) for k in (0, 1))
        worst = max(worst, step_error(*ours.step(q, v, tau), q1, v1))
    return worst, {"engine": f"PyBullet {pybullet.getAPIVersion()}", **settings}


# ---- check 3: Pinocchio


def pinocchio_error(case: Case, ours, seed: int) -> float:
    import pinocchio

    model = pinocchio.buildModelFromUrdf(str(case.path))
    data = model.createData()
    pin_names = list(model.names)[1:]
    if sorted(pin_names) != sorted(ours.joint_names) or ours.nq != ours.nv or model.nv != ours.nv:
        raise ValueError(f"joints differ: Pinocchio {pin_names} (nv {model.nv}), ours {ours.joint_names}")
    index = [model.joints[model.getJointId(n)].idx_v for n in ours.joint_names]  # Pinocchio's v index
    ours = ours.with_options(passive="explicit", timestep=1.0, contact=False, limits=False)
    for joint in ours.joint_names:  # the dry friction's constraint rows too (MuJoCo's frictionloss)
        for name in ("damping", "frictionloss"):
            ours.set_param(f"joint/{joint}/{name}", 0.0)
    rng, n = seeded(seed, case, "pinocchio"), ours.nv
    worst = 0.0
    for _ in range(SAMPLES if n else 0):
        q, v, tau = rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n), rng.uniform(-5.0, 5.0, n)
        dq, pv, ptau = np.zeros(n), np.zeros(n), np.zeros(n)
        dq[index], pv[index], ptau[index] = q, v, tau
        a_pin = pinocchio.aba(model, data, pinocchio.integrate(model, pinocchio.neutral(model), dq), pv, ptau)[index]
        a = ours.step(q, v, tau)[1] - v
        worst = max(worst, float(np.abs(a - a_pin).max() / max(np.abs(a_pin).max(), 1e-300)))
    return worst


# ---- check 4: rest


def rest(ours) -> float:
    """max |v| over REST_STEPS steps at rest under zero tau; raises if a step diverges."""
    V = ours.rollout(ours.reference_q(), np.zeros(ours.nv), np.zeros((REST_STEPS, ours.nv)))[1]
    if not np.all(np.isfinite(V)):
        raise ValueError("a velocity is not finite")
    return float(np.abs(V).max()) if V.size else 0.0


# ---- one model


def check(case: Case, seed: int) -> dict:
    """The row of one model: sizes, each check's result ("ok", an error, or NOT_RUN), numbers, pass."""
    row = {"model": case.name, "source": case.source, "kind": case.kind, "reference": case.reference,
           "ours": NOT_RUN, "load": NOT_RUN, "one_step": NOT_RUN, "one_step_error": None, "pinocchio": NOT_RUN,
           "pinocchio_error": None, "rest": NOT_RUN, "rest_max_speed": None, "notes": {}}
    try:
        ours = load_ours(case)
    except (ValueError, OSError) as e:
        row.update({"load": message(e, case), "pass": False})
        return row
    row.update(load="ok", ours=f"{ours.nq}/{ours.nv}/{ours.nu}")
    try:
        if case.kind == "mjcf":
            error, row["notes"] = mujoco_one_step(case, ours, seed)
        else:
            error, row["notes"] = pybullet_one_step(case, load_ours(case, inertial="pybullet"), seed)
        row["one_step_error"] = error
        row["one_step"] = "ok" if error <= ONE_STEP_TOL else f"error {error:.1e} > {ONE_STEP_TOL:.0e}"
    except (ValueError, OSError) as e:
        row["one_step"] = message(e, case)
    if case.source == "example-robot-data":
        try:
            error = row["pinocchio_error"] = pinocchio_error(case, ours, seed)
            row["pinocchio"] = "ok" if error <= PINOCCHIO_TOL else f"error {error:.1e} > {PINOCCHIO_TOL:.0e}"
        except (ValueError, OSError) as e:
            row["pinocchio"] = message(e, case)
    try:
        row["rest_max_speed"] = rest(ours)
        row["rest"] = "ok"
    except (ValueError, OSError) as e:
        row["rest"] = message(e, case)
    row["pass"] = all(row[c] in ("ok", NOT_RUN) for c in ("one_step", "pinocchio", "rest"))
    return row


CHECKS = ("load", "one_step", "pinocchio", "rest")


def brief(text: str) -> str:
    """A check's message without the file, line and long number lists."""
    text = re.sub(r"^ValueError: (<[^>]+>/\S+?:(\d+:)? )?", "", text)
    return re.sub(r" \[[^\]]*\]| \(eigenvalues \[[^\]]*\]\)| \(timestep too large\?\)", "", text)


def pybullet_differences(notes: dict) -> list[str]:
    """Where PyBullet's reading departs from the file (see pybullet_inertia_notes); ours follows it
    under inertial="pybullet"."""
    out = []
    if "links_without_inertial" in notes:
        out.append(f"{len(notes['links_without_inertial'])} links without <inertial> (PyBullet: mass 1)")
    if "pybullet_zeroed_inertia" in notes:
        out.append(f"PyBullet zeroed the inertia of {', '.join(notes['pybullet_zeroed_inertia'])}")
    if notes.get("pybullet_inertia_diagonalisation_error", 0.0) > ONE_STEP_TOL:
        out.append(f"PyBullet's inertia diagonalisation off by {notes['pybullet_inertia_diagonalisation_error']:.0e}")
    return out


def reason(row: dict) -> str:
    """Why a model fails, in one line: each failed check's message (brief) and, for a one-step
    mismatch with PyBullet, what PyBullet models differently."""
    parts = []
    for check in CHECKS:
        if row[check] in ("ok", NOT_RUN):
            continue
        extra = pybullet_differences(row["notes"]) if check == "one_step" and row["one_step_error"] else []
        parts.append(f"{check}: " + "; ".join([brief(row[check]), *extra]))
    return " | ".join(parts)


# ---- report


def summary(rows: list) -> list[list]:
    """Per source: models, passed, failed."""
    out = []
    for source in SOURCES:
        mine = [r for r in rows if r["source"] == source]
        out.append([source, len(mine), sum(r["pass"] for r in mine), sum(not r["pass"] for r in mine)])
    return out


SUMMARY_HEADER = ["source", "models", "pass", "fail"]
HEADER = ["model", "nq/nv/nu (engine)", "nq/nv/nu (ours)", "load", "one step", "Pinocchio",
          f"{REST_STEPS} steps at rest (max abs v)", "result"]


def cell(status: str, number: float | None, width: int = 60) -> str:
    """A check's table cell: its number where it ran, else its brief message."""
    text = status if status == NOT_RUN else f"{number:.1e}" if number is not None else brief(status)
    text = text.replace("|", "\\|")
    return text if len(text) <= width else text[:width - 3] + "..."


def table_rows(rows: list) -> list[list]:
    return [[r["model"], r["reference"], r["ours"], cell(r["load"], None),
             cell(r["one_step"], r["one_step_error"]), cell(r["pinocchio"], r["pinocchio_error"]),
             cell(r["rest"], r["rest_max_speed"]),
             "PASS" if r["pass"] else "**FAIL**"] for r in rows]


def failure_lines(rows: list) -> list[str]:
    return [f"- {r['model']}: {reason(r)}" for r in rows if r["pass"] is False]


def markdown(doc: dict) -> list[str]:
    return [
        "# Corpus: real robot files, loaded and stepped",
        "",
        f"`python -m harness corpus --seed {doc['seed']}`",
        "",
        "What each check does is in harness/corpus.py's docstring. One step: ours vs MuJoCo (MJCF, contacts "
        "and limits disabled) or PyBullet (URDF, fixed base, explicit damping, limits and collisions off), "
        f"{SAMPLES} random states and tau, error max(|dq| / max(1, |q'|), |dv| / max(1, |v'|)) <= "
        f"{ONE_STEP_TOL:.0e}. Pinocchio (example-robot-data): acceleration vs pinocchio.aba, relative "
        f"<= {PINOCCHIO_TOL:.0e}. At rest: {REST_STEPS} steps from the reference configuration, zero tau, the "
        "file's defaults, no divergence. Engine versions: " + ", ".join(doc["versions"]) + ".",
        "",
        "## Summary",
        "",
        *markdown_table(SUMMARY_HEADER, summary(doc["models"])),
        "",
        "## Models",
        "",
        *markdown_table(HEADER, table_rows(doc["models"])),
        "",
        "## Why each failing model fails",
        "",
        *failure_lines(doc["models"]),
    ]


def versions() -> list[str]:
    import importlib.metadata

    return [f"{name} {importlib.metadata.version(name)}"
            for name in ("mujoco", "pybullet", "pin", "dm-control", "example-robot-data")]


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")
    ap.add_argument("--known-failures", action="store_true",
                    help="also print the failing models as entries of test_corpus.py's KNOWN_FAILURES")


def run(args) -> int:
    rows = [check(case, args.seed) for case in discover()]
    if args.known_failures:
        for r in rows:
            if r["pass"] is False:
                print(f'    "{r["model"]}":\n        "{reason(r)}",')
    doc = {"seed": args.seed, "samples": SAMPLES, "rest_steps": REST_STEPS, "versions": versions(),
           "thresholds": {"one_step": ONE_STEP_TOL, "pinocchio": PINOCCHIO_TOL}, "models": rows}
    md = write_markdown(args.out / "corpus.md", markdown(doc))
    write_json(args.out / "corpus.json", doc)
    for line in markdown_table(SUMMARY_HEADER, summary(rows)):
        print(line)
    print(f"wrote {md}, {md.with_suffix('.json')}")
    return 0 if all(r["pass"] is not False for r in rows) else 1
