"""Check a robot file (MJCF .xml or URDF .urdf) in every engine that can read it: compiled models, steps, gradients.

    python -m harness check robot.urdf [--twin robot.xml] [--engines mujoco,pybullet,dart]
        [--timestep H] [--package-dir DIR ...] [--steps N] [--samples N] [--seed S]
        [--out DIR] [--max-error E]

1. Our engine loads MODEL (package:// paths resolved in each --package-dir). If it cannot,
   one line names the file and line, and the exit status is 2.
2. Each reference engine loads it through its harness adapter (harness/engines): MuJoCo
   reads MJCF and, through its importer, URDF; PyBullet and DART read and step URDF. An
   MJCF file goes to PyBullet's loadMJCF and DART's MjcfParser, their own readings compared
   compiled (3) but not stepped, so not gated (PyBullet's inertia from the geoms, DART's
   identity inertia: the rows name them). Each runs the file as replay runs a twin (its
   own timestep, integrator and passive-force mode; a URDF that sets none runs at the
   defaults h = 0.002 s, gravity -9.81 z, stated in the settings); --timestep overrides
   the timestep everywhere. An engine that cannot load the file gets a row with its own
   error message (and the last lines it printed).
3. Compiled models (harness/compiled.py): ours against each engine, per body (parent,
   mass, COM, principal moments and axes) and per joint (type, body, axis, range,
   damping, armature), each row matching or naming the differing fields and both values.
4. Steps, contact-free, ours configured as each engine runs the file (`engine.ours()`):
   replay's checks (harness/replay.py: --samples one steps from random states and
   torques, and a --steps rollout whose error is plotted), error max(|dq| / max(1, |q'|),
   |dv| / max(1, |v'|)).
5. Where MuJoCo loaded the file: for an MJCF file one step in contact from --samples
   states along MuJoCo's own trajectory under random controls, its solver converged
   (harness/agreement.py), and for either format our step Jacobians against central differences of ours and of MuJoCo's step at
   GRAD_STATES random states, with gradcheck's thresholds (harness/gradcheck.py). A model
   our engine cannot step in contact (a geom pair without a collider) gets the refusal as
   its row.
6. --twin OTHER: OTHER is the same robot in another format. Ours(MODEL) against
   ours(OTHER), and each engine's two loads, compiled field by field (a massless URDF link
   carrying one of an MJCF body's joints is folded into its child), and one step from the
   same --samples random states in ours(MODEL) and ours(OTHER), run with MODEL's options.
   Joints named differently get a table of the names, not a step.

Writes <out>/check-<stem>.md, .json and .png (the rollout error per engine). JSON:
engines.<engine>.loaded, .error (why not loaded), .one_step_error (contact-free, relative)
and .compiled (the rows of 3). Exit status: 0 when every engine that loaded the file agrees
with ours within --max-error (one step, contact-free; in contact against converged MuJoCo)
and the Jacobians pass, and the twin (if any) matches in every field that reaches the
dynamics; 1 otherwise; 2 when we cannot read MODEL (or OTHER). Reported, not gated: the
rollout (chaotic robots part exponentially), compiled differences between engines (the
one step says whether they matter), and a check our engine refuses (a contact pair
without a collider: the row gives the refusal).
"""

from __future__ import annotations

import argparse
import multiprocessing
import re
import signal
import sys
from pathlib import Path

import numpy as np

from harness import compiled, engines
from harness.engines.base import quiet_stdio
from harness.engines.numpy_step import step_error
from harness.golden import case_seed
from harness.report import REPORTS, markdown_table, plot_lines, write_json, write_markdown

READS = {"mujoco": (".xml", ".urdf"), "pybullet": (".urdf",), "dart": (".urdf",)}
# An MJCF file in PyBullet and DART: their own loaders, compiled comparison only (not stepped)
MJCF_READERS = {"pybullet": ("loadMJCF", compiled.pybullet_mjcf), "dart": ("MjcfParser", compiled.dart_mjcf)}
GRAD_STATES = 3
MAX_ERROR = 1e-9


class Unreadable(Exception):
    """Our engine cannot read a model file (exit status 2)."""


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("model", type=Path, nargs="?", help="an MJCF (.xml) or URDF (.urdf) file")
    ap.add_argument("--corpus", action="store_true",
                    help="check every model of harness/corpus.py's collections instead: reports/check-corpus.*")
    ap.add_argument("--twin", type=Path, help="the same robot in the other format: compare the two")
    ap.add_argument("--engines", default=",".join(engines.ENGINES), help="comma-separated (default %(default)s)")
    ap.add_argument("--timestep", type=float, help="override the file's (or the default) timestep, s")
    ap.add_argument("--package-dir", action="append", default=[], type=Path,
                    help="a directory package:// paths resolve in (repeatable)")
    ap.add_argument("--steps", type=int, default=200, help="rollout length (default %(default)s)")
    ap.add_argument("--samples", type=int, default=20, help="one-step samples (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")
    ap.add_argument("--max-error", type=float, default=MAX_ERROR,
                    help="largest one-step relative error that agrees (default %(default)s)")


def one_line(error: BaseException) -> str:
    return " ".join(f"{type(error).__name__}: {error}".split())


def printed_tail(printed: list) -> str:
    """The last three lines an engine printed (terminal colours removed), for its error row."""
    said = [re.sub(r"\x1b\[[0-9;]*m", "", line).strip() for line in printed]
    said = [line for line in said if line][-3:]
    return f" (printed: {' | '.join(said)})" if said else ""


def load_ours(path: Path, package_dirs: list):
    import diffosi

    if not path.exists():
        raise Unreadable(f"{path}: no such file")
    if path.suffix not in (".xml", ".urdf"):
        raise Unreadable(f"{path}: not an MJCF (.xml) or URDF (.urdf) file")
    try:
        return diffosi.Model.load(str(path), package_dirs=[str(d) for d in package_dirs])
    except (ValueError, OSError) as e:
        raise Unreadable(" ".join(str(e).split())) from e


def load_engine(name: str, path: Path, args) -> tuple:
    """(engine, None) or (None, why not): the engine's own error and what it printed."""
    if path.suffix not in READS[name]:
        return None, f"the harness steps {' and '.join(READS[name])} files in {name}"
    printed: list = []
    try:
        # DART's URDF loader takes package directories; PyBullet and MuJoCo's importer resolve
        # mesh paths relative to the file
        dirs = {"package_dirs": tuple(args.package_dir)} if name == "dart" else {}
        with quiet_stdio(printed):
            e = engines.load(name, path, **dirs)
        e.package_dirs = tuple(args.package_dir)
        if args.timestep:
            e.set_timestep(args.timestep)
        return e, None
    except Exception as error:  # noqa: BLE001 - a foreign engine's failure is that engine's row
        return None, one_line(error) + printed_tail(printed)


def engine_compiled(e) -> dict:
    if e.name == "mujoco":
        return compiled.mujoco(e.m)
    if e.name == "pybullet":
        return compiled.pybullet(e.model_path)
    return compiled.dart(e.skel)


def guarded(what, *args) -> dict:
    """what(*args), or {"error": its message} when our engine or the reference refuses."""
    try:
        return what(*args)
    except Exception as error:  # noqa: BLE001 - reported in the row, never a traceback
        return {"error": one_line(error)}


def steps_of(e, key: str, args) -> dict:
    from harness.replay import compare

    ours = e.ours().joint_names
    if list(ours) != list(e.joint_names):  # the states are compared index by index
        raise ValueError(f"the joint order differs: ours {ours}, {e.name} {e.joint_names}")
    _, results = compare([e], key, args.steps, args.samples, args.seed)
    r = results[e.name]
    return {"settings": {k: r[k] for k in ("version", "passive", "integrator", "timestep", "gravity", "settings",
                                           "ignored")},
            "one_step": r["one_step"], "rollout": r["rollout"]}


def contact_of(path: Path, args) -> dict:
    from harness.agreement import one_model

    r = one_model(path.stem, path, args.steps, args.samples, args.seed)
    return {"one_step": r["one_step"], "worst": r["worst"], "contact_states": r["contact_states"],
            "limit_states": r["limit_states"], "replay_first_parted": r["replay"]["first_parted"],
            "file_tolerance_gap": r["file_tolerance_gap"]}


def gradients_of(path: Path, args) -> dict:
    from harness.gradcheck import THRESHOLDS, gradcheck

    doc = gradcheck(str(path), GRAD_STATES, args.seed)
    worst = {k: max((r[k] for r in doc["rows"] if r[k] is not None), default=0.0) for k in THRESHOLDS}
    failed = [r["block"] for r in doc["rows"] if not r["pass"]]
    return {"states": GRAD_STATES, "thresholds": THRESHOLDS, "worst": worst, "failed": failed, "pass": doc["pass"]}


def read_in_child(read, path: str, conn) -> None:
    try:
        conn.send((read(path), None))
    except Exception as error:  # noqa: BLE001 - sent to the parent as the engine's row
        conn.send((None, one_line(error)))


def isolated(read, path: Path) -> tuple:
    """(read(path), None) or (None, why not), read in a process of its own: DART's MJCF
    parser crashes (segmentation fault, abort) on some files (dm_control's acrobot, dog)."""
    ctx = multiprocessing.get_context("spawn")
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=read_in_child, args=(read, str(path), send))
    child.start()
    send.close()
    try:
        result = receive.recv()
    except EOFError:  # it died without an answer
        result = None
    child.join()
    if result is None:
        code = child.exitcode
        how = f"signal {signal.Signals(-code).name}" if code is not None and code < 0 else f"exit code {code}"
        return None, f"the loader crashed ({how})"
    return result


def own_mjcf_row(name: str, path: Path, ours_compiled: dict, progress) -> dict:
    """PyBullet's or DART's own MJCF loader on the file: its compiled model against ours
    (massless joint links folded), or its error. Not stepped, so not gated (agrees None):
    their MJCF readings are their own (PyBullet's inertia from the geoms, DART's identity
    inertia), which the compiled rows name."""
    loader, read = MJCF_READERS[name]
    printed: list = []
    with quiet_stdio(printed):
        theirs, error = isolated(read, path)
    if error is not None:
        progress.tick(failed=True)
        return {"loaded": False, "loader": loader, "error": error + printed_tail(printed)}
    rows = compiled.compare(compiled.fold_massless(ours_compiled), compiled.fold_massless(theirs))
    progress.tick()
    return {"loaded": True, "loader": loader, "compiled": rows, "compiled_mismatches": compiled.mismatches(rows),
            "one_step_error": None, "agrees": None,
            "note": f"{name}'s {loader}: compiled model compared, not stepped (the harness steps URDF files in {name})"}


def engine_row(e, error, path: Path, ours_compiled: dict, args, progress) -> dict:
    row = {"loaded": e is not None}
    if e is None:
        row["error"] = error
        progress.tick(failed=True)
        return row
    rows = guarded(lambda: compiled.compare(ours_compiled, engine_compiled(e)))
    row["compiled"] = rows
    row["compiled_mismatches"] = compiled.mismatches(rows) if isinstance(rows, list) else rows
    if e.nv == 0:  # nothing moves: the compiled comparison is the check
        row.update(note="no degrees of freedom: nothing to step", one_step_error=None, agrees=True)
        progress.tick()
        return row
    steps = guarded(steps_of, e, str(path), args)
    row.update(steps)
    row["one_step_error"] = steps["one_step"]["max_error"] if "one_step" in steps else None
    row["agrees"] = row["one_step_error"] is not None and row["one_step_error"] <= args.max_error
    progress.tick(failed=not row["agrees"])
    return row


def mujoco_extras(path: Path, args, progress) -> dict:
    contact = guarded(contact_of, path, args) if path.suffix == ".xml" else {
        "error": "MJCF only (MuJoCo's URDF importer reads no <diffosi:options>, so its contacts and timestep "
                 "need not be ours')"}
    if "worst" in contact:
        contact["agrees"] = contact["worst"] <= args.max_error
    progress.tick(failed=not contact.get("agrees", False))
    gradients = guarded(gradients_of, path, args)
    progress.tick(failed=not gradients.get("pass", False))
    return {"contact": contact, "gradients": gradients}


# ---- the twin


def joint_table(a, b) -> list[list]:
    """Each joint name of either model and where it is (position in each, or '-')."""
    names = list(a.joint_names) + [n for n in b.joint_names if n not in a.joint_names]
    where = lambda m, n: str(m.joint_names.index(n)) if n in m.joint_names else "-"  # noqa: E731
    return [[n, where(a, n), where(b, n)] for n in names]


def twin_steps(a, b, args) -> dict:
    """One step from the same random states and tau in a and b, both with a's options,
    contacts and limits off; tau uniform in [-1, 1]."""
    options = dict(timestep=a.timestep, gravity=list(a.gravity), integrator=a.integrator, passive=a.passive,
                   contact=False, limits=False)
    a, b = a.with_options(**options), b.with_options(**options)
    rng, worst = case_seed(args.seed, "check_twin"), 0.0
    for _ in range(args.samples):
        q = a.reference_q() + rng.uniform(-0.5, 0.5, a.nq)
        v, tau = rng.uniform(-1.0, 1.0, a.nv), rng.uniform(-1.0, 1.0, a.nv)
        worst = max(worst, step_error(*a.step(q, v, tau), *b.step(q, v, tau)))
    return {"samples": args.samples, "max_error": worst}


def twin_of(ours, other, loaded: dict, other_loaded: dict, args) -> dict:
    fold = compiled.fold_massless
    doc: dict = {"ours": compiled.mismatches(compiled.compare(fold(compiled.ours(ours)), fold(compiled.ours(other))))}
    for name, e in loaded.items():
        if e is not None and other_loaded.get(name) is not None:
            rows = guarded(lambda a, b: compiled.compare(fold(engine_compiled(a)), fold(engine_compiled(b))),
                           e, other_loaded[name])
            doc[name] = compiled.mismatches(rows) if isinstance(rows, list) else rows
    if list(ours.joint_names) != list(other.joint_names) or ours.nq != other.nq:
        doc["joints_differ"] = joint_table(ours, other)
        doc["steps"] = None
    else:
        doc["steps"] = guarded(twin_steps, ours, other, args)
    step_ok = doc["steps"] is not None and doc["steps"].get("max_error", np.inf) <= args.max_error
    compared = [doc[k] for k in doc if k not in ("steps", "joints_differ")]  # lists, or {"error"}
    doc["differs"] = not step_ok or any(isinstance(c, dict) or any(not m["inert"] for m in c) for c in compared)
    return doc


# ---- the whole check


class Silent:
    """A progress bar that shows nothing (the corpus shows one per model instead)."""

    def tick(self, failed: bool = False) -> None:
        pass


def check(args, progress=None) -> dict:
    from harness.sweep import Progress

    path = args.model.resolve()
    names = [n.strip() for n in args.engines.split(",") if n.strip()]
    unknown = sorted(set(names) - set(engines.ENGINES))
    if unknown or not names:
        raise ValueError(f"unknown engines {unknown}; choose from {', '.join(engines.ENGINES)}")
    ours = load_ours(path, args.package_dir)
    other = load_ours(args.twin.resolve(), args.package_dir) if args.twin else None
    loaded = {n: load_engine(n, path, args) for n in names}
    progress = progress or Progress(len(names) + 2, 0)
    ours_compiled = compiled.ours(ours)
    doc: dict = {"model": str(args.model), "twin": str(args.twin) if args.twin else None, "seed": args.seed,
                 "steps": args.steps, "samples": args.samples, "max_error": args.max_error,
                 "ours": {"nq": ours.nq, "nv": ours.nv, "nu": ours.nu, "timestep": ours.timestep,
                          "integrator": ours.integrator, "passive": ours.passive,
                          "bodies": len(ours_compiled["bodies"]), "joints": len(ours_compiled["joints"])},
                 "engines": {}}
    try:
        for name, (e, error) in loaded.items():
            own = path.suffix == ".xml" and name in MJCF_READERS
            doc["engines"][name] = (own_mjcf_row(name, path, ours_compiled, progress) if own
                                    else engine_row(e, error, path, ours_compiled, args, progress))
        if loaded.get("mujoco", (None,))[0] is not None:
            doc.update(mujoco_extras(path, args, progress))
        else:
            progress.tick(failed=True)
            progress.tick(failed=True)
        if other is not None:
            other_loaded = {n: load_engine(n, args.twin.resolve(), args)[0] for n in names}
            try:
                doc["twin_check"] = twin_of(ours, other, {n: e for n, (e, _) in loaded.items()}, other_loaded, args)
            finally:
                for e in other_loaded.values():
                    if e is not None:
                        e.close()
    finally:
        if not isinstance(progress, Silent):
            print(file=sys.stderr)  # end the progress line
        for e, _ in loaded.values():
            if e is not None:
                e.close()
    doc["pass"] = verdict(doc)
    return doc


def verdict(doc: dict) -> bool:
    rows = [r for r in doc["engines"].values() if r["loaded"] and r["agrees"] is not None]  # stepped
    ok = all(r["agrees"] for r in rows)
    if "contact" in doc:
        ok = ok and doc["contact"].get("agrees", True) and doc["gradients"].get("pass", True)
    return ok and not doc.get("twin_check", {}).get("differs", False)


# ---- the report


def fmt(x) -> str:
    return "-" if x is None else f"{x:.1e}"


def field_text(m: dict) -> str:
    return f"{m['kind']} `{m['name']}`: {m['field']} {m['a']} vs {m['b']}"


def engine_lines(doc: dict) -> list[str]:
    rows = []
    for name, r in doc["engines"].items():
        if not r["loaded"]:
            loader = f"its own {r['loader']}: " if "loader" in r else ""
            rows.append([name, "no", loader + r["error"].replace("|", "/"), "-", "-", "-", "-"])
            continue
        mism = r["compiled_mismatches"]
        n = f"{len(mism)} fields" if isinstance(mism, list) else mism["error"]
        if r["agrees"] is None:
            rows.append([name, "yes", f"its own {r['loader']}: compiled only", n, "-", "-", "not stepped"])
            continue
        s = r.get("settings", {})
        rows.append([name, "yes", f"h = {s.get('timestep', '-')} s, {s.get('integrator', '-')}, passive "
                     f"{s.get('passive', '-')}", n, fmt(r["one_step_error"]),
                     fmt(r["rollout"]["max_error"]) if "rollout" in r else r.get("error", "-"),
                     "agrees" if r["agrees"] else "**differs**"])
    return markdown_table(["engine", "loaded", "settings (or why not loaded)", "compiled mismatches",
                           "one-step error", "rollout max error", "result"], rows)


def mismatch_lines(doc: dict) -> list[str]:
    lines = []
    for name, r in doc["engines"].items():
        mism = r.get("compiled_mismatches")
        if isinstance(mism, list) and mism:
            lines += [f"### ours vs {name}: what differs (ours first)", ""]
            lines += [f"- {field_text(m)}" for m in mism if not m["inert"]]
            inert = [f"{m['name']} ({m['field']})" for m in mism if m["inert"]]
            if inert:
                lines.append("- bodies welded to the world, or massless without joints (no effect on the "
                             f"dynamics): {', '.join(inert)}")
            lines.append("")
    return lines or ["Every body and joint matches in every engine that loaded the file.", ""]


def mujoco_lines(doc: dict) -> list[str]:
    if "contact" not in doc:
        return ["MuJoCo did not load the file: no contact step and no gradient check.", ""]
    c, g = doc["contact"], doc["gradients"]
    contact = (f"worst {fmt(c['worst'])} over {doc['samples']} states ({c['contact_states']} of {doc['steps']} "
               f"in contact); {'agrees' if c['agrees'] else '**differs**'}" if "worst" in c
               else f"not checked: {c['error']}")
    grads = (f"worst vs ours-FD {fmt(g['worst']['ours_fd'])}, vs MuJoCo-FD {fmt(g['worst']['mujoco_fd'])} at "
             f"{g['states']} states; {'PASS' if g['pass'] else '**FAIL** ' + ', '.join(g['failed'])}"
             if "pass" in g else f"not checked: {g['error']}")
    return [f"- One step in contact vs converged MuJoCo, along MuJoCo's trajectory: {contact}",
            f"- Step Jacobians (gradcheck's thresholds): {grads}", ""]


def twin_lines(doc: dict) -> list[str]:
    t = doc.get("twin_check")
    if t is None:
        return []
    lines = [f"## Twin: `{doc['model']}` vs `{doc['twin']}`", "",
             f"Result: {'**differs**' if t['differs'] else 'same robot'}.", ""]
    for name, mism in t.items():
        if name in ("steps", "joints_differ", "differs"):
            continue
        if isinstance(mism, dict):
            lines.append(f"- {name}: not compared: {mism['error']}")
        elif mism:
            lines += [f"- {name}: {field_text(m)}" for m in mism]
        else:
            lines.append(f"- {name}: every body and joint matches")
    if t.get("joints_differ"):
        lines += ["", "Joints differ (position in each model's joint order):", ""]
        lines += markdown_table(["joint", doc["model"], doc["twin"]], t["joints_differ"])
    elif t["steps"] is not None:
        s = t["steps"]
        lines.append(f"- one step, ours on each file: " + (f"worst {fmt(s['max_error'])} over {s['samples']} states"
                                                          if "max_error" in s else s["error"]))
    return lines + [""]


def markdown(doc: dict, png: str) -> list[str]:
    o = doc["ours"]
    return [
        f"# Check: `{doc['model']}`", "",
        f"Result: {'PASS' if doc['pass'] else '**FAIL**'} (one-step error <= {doc['max_error']:.0e}; "
        "error max(|dq| / max(1, |q'|), |dv| / max(1, |v'|)); what each check does: harness/check.py).", "",
        f"Ours: nq {o['nq']}, nv {o['nv']}, nu {o['nu']}, {o['bodies']} bodies, {o['joints']} joints; as loaded "
        f"h = {o['timestep']} s, {o['integrator']}, passive {o['passive']}. Each engine runs the file its own way "
        "(below), ours the same way.", "",
        *engine_lines(doc), "",
        f"![rollout error vs step]({png})", "",
        "## Compiled models", "", *mismatch_lines(doc),
        "## MuJoCo: contact and gradients", "", *mujoco_lines(doc),
        *twin_lines(doc),
    ]


# ---- the corpus


def corpus_row(case, args) -> dict:
    """One corpus model's row: per engine loaded, one-step error and the compiled mismatches
    that reach the dynamics (not inert), or why we could not read or check it."""
    row: dict = {"model": case.name, "kind": case.kind}
    one = argparse.Namespace(**{**vars(args), "model": case.path, "twin": None, "package_dir": case.package_dirs})
    try:
        doc = check(one, Silent())
    except Unreadable as e:
        return {**row, "ours": str(e).replace(str(case.root), f"<{case.source}>"), "pass": False}
    row["ours"] = "ok"
    row["engines"] = {n: {"loaded": r["loaded"], "one_step_error": r.get("one_step_error"),
                          "error": r.get("error"),
                          "compiled_mismatches": [m for m in r.get("compiled_mismatches") or [] if not m["inert"]]
                          if isinstance(r.get("compiled_mismatches"), list) else r.get("compiled_mismatches")}
                      for n, r in doc["engines"].items()}
    row["pass"] = doc["pass"]
    return row


def corpus_cell(r: dict) -> str:
    if not r["loaded"]:
        return "not loaded"
    mism = r["compiled_mismatches"]
    count = len(mism) if isinstance(mism, list) else "?"
    return f"{fmt(r['one_step_error'])}, {count} mismatches"


def corpus_markdown(doc: dict) -> list[str]:
    names = doc["engines"]
    rows = [[r["model"], r["ours"]] + [corpus_cell(r["engines"][n]) if "engines" in r else "-"
                                                           for n in names]
            + ["PASS" if r["pass"] else "**FAIL**"] for r in doc["models"]]
    loaded = {n: sum(1 for r in doc["models"] if r.get("engines", {}).get(n, {}).get("loaded")) for n in names}
    return [
        "# Check over the corpus", "",
        f"`python -m harness check --corpus --steps {doc['steps']} --samples {doc['samples']} --seed {doc['seed']}`"
        " (harness/check.py on every model of harness/corpus.py). Per engine: the one-step error against ours "
        f"(contact-free) and the compiled mismatches that reach the dynamics; PASS as the check's exit status 0 "
        f"(one-step error <= {doc['max_error']:.0e}).", "",
        "Loaded: " + ", ".join(f"{n} {k} of {len(doc['models'])}" for n, k in loaded.items()) + "; pass: "
        f"{sum(r.get('pass') is True for r in doc['models'])}.", "",
        *markdown_table(["model", "ours", *names, "result"], [[str(c).replace("|", "/") for c in row] for row in rows]),
    ]


def run_corpus(args) -> int:
    from harness.corpus import discover
    from harness.sweep import Progress

    cases = discover()
    progress = Progress(len(cases), 0)
    rows = []
    for case in cases:
        rows.append(corpus_row(case, args))
        progress.tick(failed=rows[-1].get("pass") is False)
    print(file=sys.stderr)
    names = [n.strip() for n in args.engines.split(",") if n.strip()]
    doc = {"seed": args.seed, "steps": args.steps, "samples": args.samples, "max_error": args.max_error,
           "engines": names, "models": rows}
    write_json(args.out / "check-corpus.json", doc)
    md = write_markdown(args.out / "check-corpus.md", corpus_markdown(doc))
    print(f"wrote {md}, {md.with_suffix('.json')}")
    return 0 if all(r.get("pass") is not False for r in rows) else 1


def run(args) -> int:
    if args.corpus:
        return run_corpus(args)
    if args.model is None:
        print("check: give a model file (or --corpus)")
        return 2
    try:
        doc = check(args)
    except Unreadable as e:
        print(f"check: {e}")
        return 2
    except ValueError as e:
        print(f"check: {e}")
        return 2
    stem = f"check-{args.model.stem}"
    series = {n: r["rollout"]["error"] for n, r in doc["engines"].items() if "rollout" in r}
    png = plot_lines(args.out / f"{stem}.png", series or {"(no engine stepped)": [0.0]},
                     title=f"{args.model.name}: ours vs each engine, seed {args.seed}", xlabel="step",
                     ylabel="relative state error (0 drawn at 1e-18)")
    write_json(args.out / f"{stem}.json", doc)
    md = write_markdown(args.out / f"{stem}.md", markdown(doc, png.name))
    for name, r in doc["engines"].items():
        print(f"{name:9s} " + (f"one step {fmt(r['one_step_error'])}, {len(r['compiled_mismatches'])} compiled "
                                f"mismatches" if r["loaded"] and isinstance(r["compiled_mismatches"], list)
                                else f"not loaded: {r.get('error')}" if not r["loaded"] else "compiled: error"))
    print(f"{'PASS' if doc['pass'] else 'FAIL'}; wrote {md}, {md.with_suffix('.json')}, {png}")
    return 0 if doc["pass"] else 1
