"""Time our step and step Jacobians against MuJoCo and Pinocchio, all from Python; write reports/bench.md.

`make bench` runs `cargo bench` and then this, so criterion's native numbers for
our engine (target/criterion/*/new/estimates.json) come from the same machine and
run; without them their cells read "—".

Every Python-side number comes from one timer (`medians`): a function is called
many times in a Python for-loop (enough calls for ~10 ms), the loop is repeated,
interleaved with the other functions' loops, and the median time per call over
the repeats is kept (wall clock,
time.perf_counter, seconds; the report shows µs). So each includes the cost of
one call from Python. Work that loops in native code (MuJoCo's mj_step with
nstep = N, our rollout over N steps) is timed with the same helper and divided
by N: the engine without that cost. The report states the cost two ways: a
trivial call into each library (getattr(model, "nv")), and a step call minus
the per-step time of the same library's native loop (argument conversion
included).

Compared on the contact-free cartpole and half cheetah (MuJoCo: the MJCF files
with contacts disabled; Pinocchio: the URDF twins, fixed base), at one fixed
state (the one benches/common uses): q = q0 + 0.1 sin(i + 1), v = 0.5 cos(i + 2),
tau = sin(i + 3) for dof i, tau as generalized forces (MuJoCo's qfrc_applied).
Our calls restart from that state; MuJoCo's state advances with its steps
(without contacts the cost of a step does not depend on the state).

- step: ours `Model.step`; MuJoCo `mj_step`; Pinocchio `aba` (the acceleration
  only, no integration: a lower bound for a step);
- step Jacobian d(x')/d(x, u): ours `Model.transition_jacobians` (exact; the A and B of
  MuJoCo's layout, like for like; `step_jacobians` returns the same blocks as a dict of
  eight arrays); MuJoCo `mjd_transitionFD` (forward finite differences, eps 1e-6); Pinocchio
  `computeABADerivatives` (analytic derivatives of the acceleration, no step);
- step + one-parameter Jacobian: ours only (pole mass, torso mass). The paper's
  engine, NimblePhysics, needed 52 µs (cartpole) and 395 µs (half cheetah) per
  Gauss-Newton update (shared/notes/reference-engines.md).

With floor contact (target: at least as fast as MuJoCo): the half cheetah standing on its
floor, contacts and joint limits on, ours on reference_models/half_cheetah.xml under the
constraint model (MuJoCo's contact, the file's default) and, in a row of its own, under the
smooth penalty model, and MuJoCo on gymnasium's half_cheetah.xml (same dt 0.01), each first
settled by SETTLE_STEPS steps without forces from its reference pose; all then step on from
there (zero forces, so they keep standing and the contact count stays put).

Gymnasium's humanoid (a free joint, 23 dofs; target: at least as fast as MuJoCo): contacts and
limits off at the fixed state above (its quaternion normalised), and as the file runs it (RK4,
contacts and limits on; MuJoCo's PGS solver at the file's 50 iterations, ours to convergence),
both from MuJoCo's state after HUMANOID_FALL steps without forces from the reference pose
(lying on the floor), put back before every call (MuJoCo's warm start with it), so that both
engines step the same stretch of motion: the humanoid settling on the floor.

Convex scenes (target: at least as fast as MuJoCo), each settled by MuJoCo from its initial state
and then stepped by both engines from MuJoCo's state (put back before every call, with MuJoCo's warm
start), zero forces: dm_control's quadruped standing on its height field made bumpy (`quadruped_on_bumps`,
tendons, actuators and sensors removed), a pile of mixed convex shapes on a floor (`pile`), and a
few shapes resting on a field of several hundred static geoms (`rubble`: thousands of candidate
pairs, so our broad phase sweeps and prunes). A scene whose step we refuse (a pair without a
collider) reads "refused" with the reason.

Ratio = their time / ours: > 1 means we are faster. An OSI table from
benches/osi.rs follows (criterion only): one DiffOSI identification (LM from
the prior until a tolerance stops it), the warm-started online update, and one
evaluation of the window's residuals and exact Jacobian (one Gauss-Newton step)
at windows W = 1, 2, 5, 10, 50, next to NimblePhysics' Gauss-Newton step where
measured (ratio Nimble / ours).
"""

import json
import os
import re
import struct
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np
import pinocchio

import diffosi
from harness.engines.base import gym_assets_dir
from harness.engines.mujoco import load_mjcf

ROOT = Path(__file__).resolve().parent.parent
MODELS = {"cartpole": "body/pole/mass", "half_cheetah": "body/torso/mass"}  # name -> the one parameter
NATIVE_STEPS = 1000  # steps per call of the native loops (mj_step nstep, our rollout)
REPEATS = 15
TARGET_SECONDS = 0.01  # a repeat calls the function until about this long
FD_EPS = 1e-6
CONTACT = "half_cheetah, floor contact"  # the row of the contact step
SETTLE_STEPS = 300  # from rest at the reference pose to standing on the floor
HUMANOID = "humanoid (gymnasium)"  # the rows of the humanoid's step
HUMANOID_FALL = 200  # steps from the reference pose to lying on the floor

# NimblePhysics Gauss-Newton DiffOSI step, thread-CPU seconds per update
# (shared/notes/reference-engines.md): (model, W) -> seconds.
NIMBLE_GN_STEP = {
    ("cartpole", 1): 52e-6,
    ("cartpole", 10): 523e-6,
    ("cartpole", 50): 2.7e-3,
    ("half_cheetah", 1): 395e-6,
}
OSI_WINDOWS = [1, 2, 5, 10, 50]


def add_arguments(parser):
    parser.add_argument("--out", type=Path, default=ROOT / "reports" / "bench.md",
                        help="Markdown report path")


def calls_for(fn, args):
    """How many calls of fn(*args) last about TARGET_SECONDS (doubling from one)."""
    calls = 1
    while loop_seconds(fn, args, calls) < TARGET_SECONDS:
        calls *= 2
    return calls


def loop_seconds(fn, args, calls):
    start = time.perf_counter()
    for _ in range(calls):
        fn(*args)
    return time.perf_counter() - start


def medians(jobs, repeats=REPEATS):
    """Seconds per call (per step for native loops) of each job {key: (fn, args, steps)}.

    Each repeat runs every job's loop once, in turn, so a slow spell of the
    shared machine hits all libraries alike; the median over `repeats` is kept.
    """
    calls = {key: calls_for(fn, args) for key, (fn, args, _) in jobs.items()}
    times = {key: [] for key in jobs}
    for _ in range(repeats):
        for key, (fn, args, steps) in jobs.items():
            times[key].append(loop_seconds(fn, args, calls[key]) / (calls[key] * steps))
    return {key: float(np.median(t)) for key, t in times.items()}


def fixed_state(q0, nv=None):
    """q0 + 0.1 sin(i + 1) over q's coordinates, v = 0.5 cos(i + 2) and tau = sin(i + 3) over the
    nv dofs (nv = len(q0) unless given)."""
    i, k = np.arange(len(q0)), np.arange(len(q0) if nv is None else nv)
    return q0 + 0.1 * np.sin(i + 1.0), 0.5 * np.cos(k + 2.0), np.sin(k + 3.0)


def ours_jobs(name):
    m = diffosi.Model.load(str(ROOT / "reference_models" / f"{name}.xml")).with_options(
        contact=False, limits=False)
    q, v, tau = fixed_state(np.zeros(m.nq))
    taus = np.tile(tau, (NATIVE_STEPS, 1))
    return {
        "overhead": (getattr, (m, "nv"), 1),
        "step": (m.step, (q, v, tau), 1),
        "loop": (m.rollout, (q, v, taus), NATIVE_STEPS),
        "jacobian": (m.transition_jacobians, (q, v, tau), 1),
        "param": (m.step_jacobians, (q, v, tau, [MODELS[name]]), 1),
    }


def mujoco_jobs(name):
    model = load_mjcf(ROOT / "reference_models" / f"{name}.xml")
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT  # contact-free, like ours
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.qfrc_applied[:] = fixed_state(model.qpos0)
    n = 2 * model.nv + model.na
    a, b = np.zeros((n, n)), np.zeros((n, model.nu))
    return {
        "overhead": (getattr, (model, "nv"), 1),
        "step": (mujoco.mj_step, (model, data), 1),
        "loop": (mujoco.mj_step, (model, data, NATIVE_STEPS), NATIVE_STEPS),
        "jacobian": (mujoco.mjd_transitionFD, (model, data, FD_EPS, False, a, b, None, None), 1),
    }


def pinocchio_jobs(name):
    model = pinocchio.buildModelFromUrdf(str(ROOT / "reference_models" / f"{name}.urdf"))
    data = model.createData()
    q, v, tau = fixed_state(np.zeros(model.nv))
    q = pinocchio.integrate(model, pinocchio.neutral(model), q)  # (cos, sin) for unbounded hinges
    return {
        "overhead": (getattr, (model, "nv"), 1),
        "step": (pinocchio.aba, (model, data, q, v, tau), 1),
        "jacobian": (pinocchio.computeABADerivatives, (model, data, q, v, tau), 1),
    }


def contact_jobs():
    """{(library, what): job}: ours (constraint and smooth models) and MuJoCo's half cheetah
    stepping while standing on the floor."""
    m = diffosi.Model.load(str(ROOT / "reference_models" / "half_cheetah.xml"))
    smooth = m.with_options(contact_model="smooth")
    rest = np.zeros((SETTLE_STEPS, m.nv))
    Q, V = m.rollout(np.zeros(m.nq), np.zeros(m.nv), rest)
    q, v = Q[-1], V[-1]
    Q, V = smooth.rollout(np.zeros(m.nq), np.zeros(m.nv), rest)
    qs, vs = Q[-1], V[-1]
    model = load_mjcf(gym_assets_dir() / "half_cheetah.xml")  # its settotalmass warning kept quiet
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, SETTLE_STEPS)
    n = 2 * model.nv + model.na
    a, b = np.zeros((n, n)), np.zeros((n, model.nu))
    return {
        ("diffosi", "step"): (m.step, (q, v, rest[0]), 1),
        ("diffosi", "jacobian"): (m.transition_jacobians, (q, v, rest[0]), 1),
        ("diffosi", "param"): (m.step_jacobians, (q, v, rest[0], [MODELS["half_cheetah"]]), 1),
        ("MuJoCo", "jacobian"): (mujoco.mjd_transitionFD, (model, data, FD_EPS, False, a, b, None, None), 1),
        ("diffosi", "loop"): (m.rollout, (q, v, np.zeros((NATIVE_STEPS, m.nv))), NATIVE_STEPS),
        ("diffosi smooth", "step"): (smooth.step, (qs, vs, rest[0]), 1),
        ("diffosi smooth", "loop"): (smooth.rollout, (qs, vs, np.zeros((NATIVE_STEPS, m.nv))), NATIVE_STEPS),
        ("MuJoCo", "step"): (mujoco.mj_step, (model, data), 1),
        ("MuJoCo", "loop"): (mujoco.mj_step, (model, data, NATIVE_STEPS), NATIVE_STEPS),
    }


def humanoid_jobs():
    """{(library, what): job}: gymnasium's humanoid, ours and MuJoCo's, contact-free at the fixed
    state ("free ...") and as the file runs it after falling ("step", "loop")."""
    path = gym_assets_dir() / "humanoid.xml"
    m = diffosi.Model.load(str(path))
    free = m.with_options(contact=False, limits=False)
    q, v, tau = fixed_state(m.reference_q(), m.nv)
    q[3:7] /= np.linalg.norm(q[3:7])
    rest = np.zeros((NATIVE_STEPS, m.nv))
    model, filed = load_mjcf(path), load_mjcf(path)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    data, lying = mujoco.MjData(model), mujoco.MjData(filed)
    data.qpos[:], data.qvel[:], data.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(filed, lying, HUMANOID_FALL)
    ql, vl, warm = lying.qpos.copy(), lying.qvel.copy(), lying.qacc_warmstart.copy()

    def lie_down_and_step(nstep=1):
        lying.qpos[:], lying.qvel[:], lying.qacc_warmstart[:] = ql, vl, warm
        mujoco.mj_step(filed, lying, nstep)

    loop = np.tile(tau, (NATIVE_STEPS, 1))
    return {
        ("diffosi", "free step"): (free.step, (q, v, tau), 1),
        ("diffosi", "free loop"): (free.rollout, (q, v, loop), NATIVE_STEPS),
        ("MuJoCo", "free step"): (mujoco.mj_step, (model, data), 1),
        ("MuJoCo", "free loop"): (mujoco.mj_step, (model, data, NATIVE_STEPS), NATIVE_STEPS),
        ("diffosi", "step"): (m.step, (ql, vl, rest[0]), 1),
        ("diffosi", "loop"): (m.rollout, (ql, vl, rest), NATIVE_STEPS),
        ("MuJoCo", "step"): (lie_down_and_step, (), 1),
        ("MuJoCo", "loop"): (lie_down_and_step, (NATIVE_STEPS,), NATIVE_STEPS),
    }


def quadruped_on_bumps(directory: Path) -> Path:
    """dm_control's quadruped over its terrain field, made bumpy (smooth bumps up to 0.15,
    fixed seed, MuJoCo's binary format); its tendons, tendon equalities, actuators and
    sensors removed. The MJCF file's path, written in `directory`."""
    import dm_control

    suite = os.path.join(os.path.dirname(dm_control.__file__), "suite")
    xml = open(os.path.join(suite, "quadruped.xml")).read()
    for tag in ["tendon", "actuator", "sensor", "equality"]:
        xml = re.sub(rf"<{tag}>.*?</{tag}>", "", xml, flags=re.S)
    xml = xml.replace('file="./', f'file="{suite}/')
    n, rng = 201, np.random.default_rng(3)
    x, y = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n))
    h = sum(rng.uniform(0.2, 1) * np.exp(-((x - rng.uniform(-.05, .05)) ** 2
                                          + (y - rng.uniform(-.05, .05)) ** 2)
                                         / rng.uniform(1e-4, 1e-3)) for _ in range(20))
    terrain = directory / "terrain.bin"
    terrain.write_bytes(struct.pack("<ii", n, n) + h.astype("<f4").tobytes())
    field = '<hfield name="terrain" ncol="201" nrow="201" size="30 30 5 .1"/>'
    assert field in xml
    xml = xml.replace(field, f'<hfield name="terrain" file="{terrain}" size="30 30 .15 .1"/>')
    path = directory / "quadruped.xml"
    path.write_text(xml)
    return path


SHAPES = ['type="sphere" size="0.05"', 'type="capsule" size="0.03 0.05"',
          'type="ellipsoid" size="0.06 0.04 0.03"', 'type="cylinder" size="0.04 0.04"',
          'type="box" size="0.05 0.04 0.03"']


def pile(directory: Path, count=20) -> Path:
    """`count` free bodies of the SHAPES in turn, dropped in a column over a floor (they fall
    into a pile)."""
    rng = np.random.default_rng(5)
    bodies = "".join(
        f'<body pos="{rng.uniform(-0.05, 0.05):.3f} {rng.uniform(-0.05, 0.05):.3f} {0.1 + 0.12 * k:.2f}" '
        f'euler="{" ".join(f"{a:.0f}" for a in rng.uniform(0, 180, 3))}"><freejoint/>'
        f'<geom {SHAPES[k % len(SHAPES)]}/></body>' for k in range(count))
    path = directory / "pile.xml"
    path.write_text(f'<mujoco><worldbody><geom type="plane" size="2 2 0.1"/>{bodies}</worldbody></mujoco>')
    return path


def rubble(directory: Path, side=18, count=6) -> Path:
    """A side x side grid of static geoms (the SHAPES in turn, turned), with `count` free
    shapes dropped onto it."""
    rng = np.random.default_rng(6)
    spacing = 0.1
    fixed = "".join(
        f'<geom pos="{spacing * (i - side / 2):.2f} {spacing * (j - side / 2):.2f} 0" '
        f'euler="{" ".join(f"{a:.0f}" for a in rng.uniform(0, 180, 3))}" {SHAPES[(i + j) % len(SHAPES)]}/>'
        for i in range(side) for j in range(side))
    bodies = "".join(
        f'<body pos="{rng.uniform(-0.5, 0.5):.3f} {rng.uniform(-0.5, 0.5):.3f} 0.3"><freejoint/>'
        f'<geom {SHAPES[k % len(SHAPES)]}/></body>' for k in range(count))
    path = directory / "rubble.xml"
    path.write_text(f'<mujoco><worldbody>{fixed}{bodies}</worldbody></mujoco>')
    return path


# The convex scenes: name -> (MJCF writer, initial qpos changes {index: value}, settling steps).
CONVEX = {
    "quadruped (dm_control) on its height field": (quadruped_on_bumps, {2: 0.8}, 600),
    "pile of 20 mixed convex shapes on a floor": (pile, {}, 800),
    "6 shapes on 324 static geoms (broad phase)": (rubble, {}, 400),
}


def settled_jobs(path: Path, start: dict, settle: int):
    """{(library, what): job} of the scene `path`, settled by MuJoCo for `settle` steps from
    qpos0 changed at `start`, then stepped from there by both engines; or the refusal's
    message when our step refuses the scene."""
    model = load_mjcf(path)
    data = mujoco.MjData(model)
    for k, x in start.items():
        data.qpos[k] = x
    mujoco.mj_step(model, data, settle)
    q, v, warm = data.qpos.copy(), data.qvel.copy(), data.qacc_warmstart.copy()
    m = diffosi.Model.load(str(path))
    rest = np.zeros((NATIVE_STEPS, m.nv))
    try:
        m.step(q, v, rest[0])
    except ValueError as e:
        return str(e)

    def step_from_rest(nstep=1):
        data.qpos[:], data.qvel[:], data.qacc_warmstart[:] = q, v, warm
        mujoco.mj_step(model, data, nstep)

    return {
        ("diffosi", "step"): (m.step, (q, v, rest[0]), 1),
        ("diffosi", "loop"): (m.rollout, (q, v, rest), NATIVE_STEPS),
        ("MuJoCo", "step"): (step_from_rest, (), 1),
        ("MuJoCo", "loop"): (step_from_rest, (NATIVE_STEPS,), NATIVE_STEPS),
    }


def convex_jobs(directory: Path):
    """{scene: jobs or refusal} of the CONVEX scenes, their files written in `directory`."""
    return {name: settled_jobs(write(directory), start, settle)
            for name, (write, start, settle) in CONVEX.items()}


LIBRARIES = {"diffosi": ours_jobs, "MuJoCo": mujoco_jobs, "Pinocchio": pinocchio_jobs}


def measure():
    """{model: {library: {what: seconds}}} for every job of every library on every model,
    the contact jobs under CONTACT and HUMANOID, and the CONVEX scenes' (a refused one's
    message instead of its times)."""
    jobs = {}
    for name in MODELS:
        for library, make_jobs in LIBRARIES.items():
            jobs.update({(name, library, what): job for what, job in make_jobs(name).items()})
    jobs.update({(CONTACT, library, what): job for (library, what), job in contact_jobs().items()})
    jobs.update({(HUMANOID, library, what): job for (library, what), job in humanoid_jobs().items()})
    result = {}
    with tempfile.TemporaryDirectory() as directory:  # read when the models load
        scenes = convex_jobs(Path(directory))
    for scene, scene_jobs in scenes.items():
        if isinstance(scene_jobs, str):
            result[scene] = scene_jobs
        else:
            jobs.update({(scene, library, what): job for (library, what), job in scene_jobs.items()})
    for (name, library, what), seconds in medians(jobs).items():
        result.setdefault(name, {}).setdefault(library, {})[what] = seconds
    return result


def criterion(bench):
    """Our native median (seconds) from criterion, None if `cargo bench` has not run."""
    path = ROOT / "target" / "criterion" / bench / "new" / "estimates.json"
    return json.loads(path.read_text())["median"]["point_estimate"] * 1e-9 if path.exists() else None


def us(seconds):
    return "—" if seconds is None else f"{seconds * 1e6:.2f}"


def versus(theirs, ours):
    return "—" if theirs is None else f"{us(theirs)} ({theirs / ours:.1f}x)"


def speed_table():
    lines = [
        "| what | model | diffosi from Python (µs) | diffosi native, criterion (µs) "
        "| MuJoCo (µs, ratio) | Pinocchio (µs, ratio) |",
        "|---|---|---|---|---|---|",
    ]
    overheads = [
        "| model | library | trivial call: getattr(model, \"nv\") (µs) "
        "| a step call beyond its native loop (µs) |",
        "|---|---|---|---|",
    ]
    times = measure()
    for name in MODELS:
        ours, mj, pin = (times[name][library] for library in LIBRARIES)
        rows = [
            ("step, one Python call", ours["step"], f"step_{name}", mj["step"], pin["step"]),
            (f"step, loop of {NATIVE_STEPS} in native code (rollout; mj_step nstep)", ours["loop"],
             f"step_{name}", mj["loop"], None),
            ("step Jacobian d(x')/d(x,u)", ours["jacobian"], f"jacobian_full_{name}", mj["jacobian"],
             pin["jacobian"]),
            ("step + 1-parameter Jacobian", ours["param"], f"jacobian_param_{name}", None, None),
        ]
        for what, mine, bench, theirs_mj, theirs_pin in rows:
            cells = [what, name, us(mine), us(criterion(bench)),
                     versus(theirs_mj, mine), versus(theirs_pin, mine)]
            lines.append("| " + " | ".join(cells) + " |")
        for library, t in times[name].items():
            beyond = t["step"] - t["loop"] if "loop" in t else None
            overheads.append(f"| {name} | {library} | {us(t['overhead'])} | {us(beyond)} |")
    ours, mj = times[CONTACT]["diffosi"], times[CONTACT]["MuJoCo"]
    native = criterion("step_contact_half_cheetah")
    for label, key, bench in [("constraint", "diffosi", "step_contact_half_cheetah"),
                              ("smooth", "diffosi smooth", "step_contact_smooth_half_cheetah")]:
        t = times[CONTACT][key]
        for what, mine, theirs in [("step, one Python call", t["step"], mj["step"]),
                                   (f"step, loop of {NATIVE_STEPS} in native code (rollout; mj_step nstep)",
                                    t["loop"], mj["loop"])]:
            cells = [f"{what} ({label} model)", CONTACT, us(mine), us(criterion(bench)), versus(theirs, mine), "—"]
            lines.append("| " + " | ".join(cells) + " |")
    for what, mine, bench, theirs in [
            ("step Jacobian d(x')/d(x,u) (constraint model)", ours["jacobian"],
             "constraint_jacobian_full_half_cheetah", mj["jacobian"]),
            ("step + 1-parameter Jacobian (constraint model)", ours["param"],
             "constraint_jacobian_param_half_cheetah", None)]:
        cells = [what, CONTACT, us(mine), us(criterion(bench)), versus(theirs, mine), "—"]
        lines.append("| " + " | ".join(cells) + " |")
    ours_h, mj_h = times[HUMANOID]["diffosi"], times[HUMANOID]["MuJoCo"]
    for what, key in [("step, one Python call, contacts and limits off", "free step"),
                      (f"step, loop of {NATIVE_STEPS} in native code, contacts and limits off", "free loop"),
                      ("step, one Python call, as the file runs it, lying on the floor", "step"),
                      (f"step, loop of {NATIVE_STEPS} in native code, as the file runs it", "loop")]:
        cells = [what, HUMANOID, us(ours_h[key]), "—", versus(mj_h[key], ours_h[key]), "—"]
        lines.append("| " + " | ".join(cells) + " |")
    for scene in CONVEX:
        lines += convex_rows(scene, times[scene])
    param, step = (criterion(f"constraint_{b}_half_cheetah") for b in ("jacobian_param", "step"))
    param_steps = "—" if None in (param, step) else (
        f"{us(param)} µs, {param / step:.1f} steps of {us(step)} µs")
    target = (f"ours {us(ours['loop'])} µs per step (rollout) vs MuJoCo's {us(mj['loop'])} µs (mj_step "
              f"nstep), interleaved in one run: MuJoCo / ours = {mj['loop'] / ours['loop']:.1f}x "
              f"(criterion, native: {us(native)} µs). Step Jacobian in contact (target: 10x "
              f"faster than mjd_transitionFD): ours {us(ours['jacobian'])} µs from Python vs "
              f"{us(mj['jacobian'])} µs, {mj['jacobian'] / ours['jacobian']:.1f}x; the torso mass's "
              f"Jacobian alone (target: at most 3 steps; criterion, native) {param_steps}")
    return "\n".join(lines), "\n".join(overheads), target


def convex_rows(scene, times):
    """The table rows of a CONVEX scene: its step and native loop against MuJoCo's, or the refusal."""
    if isinstance(times, str):
        return [f"| step (refused: {' '.join(times.split())}) | {scene} | — | — | — | — |"]
    ours, mj = times["diffosi"], times["MuJoCo"]
    return ["| " + " | ".join([what, scene, us(ours[key]), "—", versus(mj[key], ours[key]), "—"]) + " |"
            for what, key in [("step, one Python call, settled", "step"),
                              (f"step, loop of {NATIVE_STEPS} in native code, settled", "loop")]]


def osi_table():
    def ratio(nimble, ours):
        return "—" if nimble is None or ours is None else f"{nimble / ours:.1f}x"

    def per(seconds, w):
        return None if seconds is None else seconds / w

    lines = [
        "| model | W | identification, cold (µs) | per transition (µs) "
        "| warm update (µs) | per transition (µs) "
        "| one GN step (µs) | per transition (µs) | Nimble GN step (µs) "
        "| ratio Nimble step / our cold identification | ratio Nimble step / our warm update "
        "| ratio Nimble step / our step |",
        "|---" * 12 + "|",
    ]
    for name in MODELS:
        for w in OSI_WINDOWS:
            cold = criterion(f"osi_lm_{name}_W{w}")
            warm = criterion(f"osi_lm_warm_{name}_W{w}")
            step = criterion(f"osi_fit_{name}_W{w}")
            nimble = NIMBLE_GN_STEP.get((name, w))
            times = [cold, per(cold, w), warm, per(warm, w), step, per(step, w)]
            cells = [name, str(w)] + [us(x) for x in times]
            cells += [us(nimble)] + [ratio(nimble, x) for x in [cold, warm, step]]
            lines.append("| " + " | ".join(cells) + " |")
    cold, warm = (criterion(f"osi_lm{kind}_half_cheetah_contact_W4") for kind in ("", "_warm"))
    lines += ["", f"In contact (the half cheetah standing on its floor, constraint model; torso mass from "
              f"W = 4 consecutive transitions; target: well under 1 ms, the paper's update 2-3 ms): "
              f"identification, cold {us(cold)} µs; warm update {us(warm)} µs (criterion, native)."]
    return "\n".join(lines)


def run(args):
    table, overhead, target = speed_table()
    osi = osi_table()
    report = f"""# Speed, measured in one run

{table}

Medians of {REPEATS} repeats of a Python loop of many calls (~{TARGET_SECONDS * 1e3:g} ms each, wall
clock), the libraries' loops interleaved so that the shared machine's slow spells hit all alike;
native loops divided by their {NATIVE_STEPS} steps. Ratio = their time / ours from Python (> 1: we are
faster); in the native-loop row, MuJoCo's nstep loop / our rollout. Contacts off in MuJoCo but in
the floor-contact rows (gymnasium's half_cheetah.xml, both engines standing on the floor).

Half cheetah step with floor contact (target: at least as fast as MuJoCo): {target}.
Pinocchio's rows are its ABA and ABA derivatives, without the integration step. MuJoCo's Jacobian is
forward finite differences (mjd_transitionFD, eps {FD_EPS:g}); ours and Pinocchio's are exact.

diffosi native = criterion's median of the same Rust call (`cargo bench`, same machine, same run).

### Python call overhead

Included in every one-call number above. A trivial call into each library (a property read) costs
the first column; a real call also converts its arguments and results, which the second column
measures as the one-call step minus the per-step time of the same library's native loop.

{overhead}

mujoco {mujoco.__version__}, pinocchio {pinocchio.__version__}, diffosi {diffosi.__version__}.

## Online system identification (DiffOSI)

{osi}

Identification, cold: LM from the prior to convergence; warm update: from the previous window's
estimate, the parameter unchanged (cartpole pole COM offset, true 0.3 from 0; half cheetah torso mass,
true 7.0 from 4.9; noise-free, contact-free, seeded random states and forces). One GN step: residuals
and exact parameter Jacobian of the whole window. Nimble: its Gauss-Newton step (forward + parameter
Jacobian + solve), thread-CPU time. Criterion medians (benches/osi.rs). Evaluations to tolerance, LM vs
Adam: `cargo run --release --example osi_evals`.
"""
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    print(report)
    print(f"wrote {args.out}")
    return 0
