"""The wiping episode's torques replayed in MuJoCo, PyBullet and DART: force and trajectory gaps.

`diffosi wipe --mu KP,KD` runs the wiping task in our engine (the KUKA iiwa 14 pressing
its compliant tool on the table with the admittance controller, 1 ms steps) and writes
the episode: states, the torques the controller applied at every step, the normal
force it sensed at each (the force over the step into that row); `--model-out` writes
the arm with that mu's tool compliance as MJCF. Here those torques are replayed in each
engine, contacts on, as the engine runs the model:

- ours: diffosi.Model on the same MJCF (must reproduce the record to round-off: a check
  of the record itself);
- MuJoCo: the same MJCF, its own soft-constraint contact (solref/solimp defaults,
  pyramidal cone; ours runs the same law), torques through qfrc_applied;
- PyBullet: the URDF twin on a plane at z = 0 (harness/contact.py's PybulletContact),
  the tool spring added as an explicit torque and the tool damping set to mu's;
- DART: the URDF twin on a ground box (DartContact), its own springs and damping at mu.

Two comparisons against our record:
1. open loop: from the record's first state, every recorded torque in turn. The torques
   were computed in closed loop by our controller, so another engine drifts; reported
   per step: the joint gap max |q - q_ours| (rad or m), the tool-tip gap (m, MuJoCo's
   forward kinematics of each q) and the normal-force gap, and the time to drift past
   1 mm at the tip;
2. one step: each engine reset to the record's state at every --every-th row, one
   recorded torque, then the next state and the normal force of that step against the
   record: the contact models' difference without the drift. Median / p95 / max, split
   into rows by the force of our recorded step: free of contact (below 1e-9 N), near
   (a touch, below the task's threshold) and in contact.

Writes <out>/wiping-replay.md, .json and .png (tip height and normal force against time,
ours and each engine open loop; gaps against time); the same arguments give the same
json. Exit status 1 if ours does not reproduce its record or MuJoCo differs from it by more
than 1e-9 in v at one step from any row (free, near or in contact: the same contact law).

    python -m harness wiping-replay --mu 50,50 --steps 3000
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from harness.contact import MujocoContact, OursContact
from harness.report import REPO, REPORTS, markdown_table, write_json, write_markdown
from harness.wiping_transfer import arm

BINARY = REPO / "target" / "release" / "diffosi"
OWN_TOL = 1e-12
STEP_TOL = 1e-9
# Rows of the record by the force of our step from them: "free" below FREE (its effect on a
# step, h F / m_tool, under 1e-14 m/s), "contact" above the task's threshold CONTACT, "near"
# between.
FREE, CONTACT = 1e-9, 0.03
N_DOF = 8


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--mu", default="50,50", help="the tool's k_p (N/cm), k_d (N s/m) (default %(default)s)")
    ap.add_argument("--steps", type=int, default=3000, help="episode length, 1 ms steps (default %(default)s)")
    ap.add_argument("--every", type=int, default=10, help="one-step comparison every n-th row (default %(default)s)")
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


def record(mu: str, steps: int, tmp: Path) -> tuple[dict, Path]:
    """Runs `diffosi wipe`; returns the columns of its CSV and the MJCF of the arm at mu."""
    csv, xml = tmp / "episode.csv", tmp / "arm.xml"
    subprocess.run([str(BINARY), "wipe", "--mu", mu, "--steps", str(steps), "--model-out", str(xml),
                    "-o", str(csv)], check=True, capture_output=True, text=True)
    header = csv.read_text().splitlines()[0].split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    return {"t": data[:, 0], "q": data[:, 1:9], "v": data[:, 9:17], "tau": data[:, 17:25],
            "force": data[:, header.index("fn_tip_table")], "xi": data[:, -1]}, xml


class Tip:
    """The tool tip's world position from q, by MuJoCo's forward kinematics."""

    def __init__(self, xml: Path):
        import mujoco

        from harness.engines.mujoco import load_mjcf

        self.mujoco, self.m = mujoco, load_mjcf(xml)
        self.d = mujoco.MjData(self.m)
        self.geom = self.m.geom("tip").id

    def __call__(self, q) -> np.ndarray:
        self.d.qpos[:] = q
        self.mujoco.mj_kinematics(self.m, self.d)
        return self.d.geom_xpos[self.geom].copy()


def open_loop(engine, rec: dict, tip: Tip) -> dict:
    """The recorded torques from the first recorded state; gaps per step against the record."""
    engine.set_state(rec["q"][0], rec["v"][0])
    n = len(rec["t"])
    q_gap, tip_gap, z, force = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    force[0] = 0.0  # sensed at the start: no step yet
    z[0] = tip(rec["q"][0])[2]
    for k in range(n - 1):
        engine.step(rec["tau"][k])
        force[k + 1] = engine.normal_force  # the force over the step into row k + 1, as recorded
        q, _ = engine.get_state()
        q_gap[k + 1] = np.max(np.abs(q - rec["q"][k + 1]))
        here = tip(q)
        tip_gap[k + 1] = np.linalg.norm(here - tip(rec["q"][k + 1]))
        z[k + 1] = here[2]
    return {"q_gap": q_gap, "tip_gap": tip_gap, "tip_z": z, "force": force}


def one_step(engine, rec: dict, every: int) -> dict:
    """From every `every`-th recorded state, one recorded torque: gaps of the next state
    and of the step's normal force against the record."""
    rows = np.arange(0, len(rec["t"]) - 1, every)
    q_gap, v_gap, f_gap = [], [], []
    for k in rows:
        engine.set_state(rec["q"][k], rec["v"][k])
        engine.step(rec["tau"][k])
        q, v = engine.get_state()
        q_gap.append(np.max(np.abs(q - rec["q"][k + 1])))
        v_gap.append(np.max(np.abs(v - rec["v"][k + 1])))
        f_gap.append(abs(engine.normal_force - rec["force"][k + 1]))
    return {"rows": rows, "q_gap": np.array(q_gap), "v_gap": np.array(v_gap), "force_gap": np.array(f_gap)}


def stats(x: np.ndarray) -> dict:
    if len(x) == 0:
        return {"median": None, "p95": None, "max": None}
    return {"median": float(np.median(x)), "p95": float(np.percentile(x, 95)), "max": float(np.max(x))}


def report(mu: str, steps: int, every: int) -> dict:
    mu_values = [float(x) for x in mu.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        rec, xml = record(mu, steps, Path(tmp))
        tip = Tip(xml)
        ours, mj = OursContact(xml), MujocoContact(xml)
        engines = [ours, mj, arm("pybullet", mu_values), arm("dart", mu_values)]
        for e in (ours, mj):  # a temporary file: name what it holds instead
            e.settings["model"] = f"wiping_arm.xml at mu = {mu_values} (diffosi wipe --model-out)"
        step_force = np.append(rec["force"][1:], 0.0)  # the force of the step from each row
        contact = step_force > CONTACT  # the task's in-contact threshold (N)
        free = step_force < FREE
        first_contact = int(np.argmax(contact)) if contact.any() else len(contact)
        free_until = int(np.argmax(~free)) if (~free).any() else len(free)
        doc = {"mu": mu_values, "steps": steps, "every": every, "first_contact_step": first_contact,
               "free_until_step": free_until,
               "recorded_force": rec["force"], "recorded_tip_z": [float(tip(q)[2]) for q in rec["q"]],
               "engines": {}}
        for e in engines:
            loop = open_loop(e, rec, tip)
            step = one_step(e, rec, every)
            phases = {"free": free[step["rows"]], "near": ~free[step["rows"]] & ~contact[step["rows"]],
                      "contact": contact[step["rows"]]}
            drift = np.flatnonzero(loop["tip_gap"] > 1e-3)
            approach = slice(0, max(free_until + 1, 1))
            doc["engines"][e.name] = {
                "settings": e.settings,
                "open_loop": {
                    "approach_max_q_gap": float(loop["q_gap"][approach].max()),
                    "approach_max_tip_gap": float(loop["tip_gap"][approach].max()),
                    "max_q_gap": float(loop["q_gap"].max()),
                    "max_tip_gap": float(loop["tip_gap"].max()),
                    "first_tip_gap_above_1mm_s": float(rec["t"][drift[0]]) if len(drift) else None,
                    "force_gap_in_contact": stats(np.abs(loop["force"] - rec["force"])[rec["force"] > CONTACT]),
                    "q_gap": loop["q_gap"], "tip_gap": loop["tip_gap"], "tip_z": loop["tip_z"],
                    "force": loop["force"],
                },
                "one_step": {phase: {"rows": int(rows.sum()),
                                     **{k: stats(step[k][rows]) for k in ("q_gap", "v_gap", "force_gap")}}
                             for phase, rows in phases.items()},
            }
        for e in engines:
            e.close()
    return doc


def plot(path: Path, doc: dict) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.arange(doc["steps"] + 1) * 1e-3
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), dpi=110, sharex=True)
    axes[0].plot(t, doc["recorded_tip_z"], color="k", lw=1.6, label="record (ours, closed loop)")
    axes[1].plot(t, doc["recorded_force"], color="k", lw=1.6, label="record (ours, closed loop)")
    for (name, e), colour in zip(doc["engines"].items(), ("C0", "C3", "C2", "C1")):
        loop = e["open_loop"]
        axes[0].plot(t, loop["tip_z"], color=colour, lw=0.9, label=f"{name}, open loop")
        axes[1].plot(t, loop["force"], color=colour, lw=0.9, label=f"{name}, open loop")
        axes[2].plot(t, np.maximum(loop["tip_gap"], 1e-16), color=colour, lw=0.9, label=f"{name}: tip gap")
    axes[0].set_ylabel("tip centre z (m)")
    axes[1].set_ylabel("normal force (N)")
    axes[1].axhline(3.0, color="grey", ls="--", lw=0.8, label="F_goal")
    axes[2].set_yscale("log")
    axes[2].set_ylabel("|tip - tip_record| (m)")
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"Wiping torques replayed open loop, mu = {doc['mu']}")
    fig.tight_layout()
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path


def fmt(x) -> str:
    return "-" if x is None else f"{x:.2e}"


def markdown(doc: dict, png: str) -> list[str]:
    lines = [f"# Wiping: our torques replayed in MuJoCo, PyBullet and DART (mu = {doc['mu']})", "",
             f"{doc['steps']} steps of 1 ms; our contact force is exactly 0 or below {FREE} N (free) up to step "
             f"{doc['free_until_step']}, above {CONTACT} N (in contact, the task's threshold) from step "
             f"{doc['first_contact_step']}. "
             "Open loop: the recorded torques from the recorded start; one step: from every "
             f"{doc['every']}-th recorded state. Gaps against our record.", "", f"![replay]({png})", "",
             "## Open loop", ""]
    rows = []
    for name, e in doc["engines"].items():
        o = e["open_loop"]
        f = o["force_gap_in_contact"]
        rows.append([name, fmt(o["approach_max_q_gap"]), fmt(o["approach_max_tip_gap"]), fmt(o["max_tip_gap"]),
                     "-" if o["first_tip_gap_above_1mm_s"] is None else f"{o['first_tip_gap_above_1mm_s']:.3f} s",
                     fmt(f["median"]), fmt(f["max"])])
    lines += markdown_table(["engine", "approach max joint gap", "approach max tip gap (m)", "max tip gap (m)",
                             "tip gap > 1 mm from", "force gap in contact, median (N)", "max (N)"], rows)
    lines += ["", "## One step from recorded states", ""]
    rows = []
    for name, e in doc["engines"].items():
        for phase in ("free", "near", "contact"):
            s = e["one_step"][phase]
            rows.append([name, f"{phase} ({s['rows']})", fmt(s["q_gap"]["median"]), fmt(s["q_gap"]["max"]),
                         fmt(s["v_gap"]["median"]), fmt(s["v_gap"]["max"]), fmt(s["force_gap"]["median"]),
                         fmt(s["force_gap"]["max"])])
    lines += markdown_table(["engine", "rows", "q gap median", "q gap max", "v gap median", "v gap max",
                             "force gap median (N)", "force gap max (N)"], rows)
    lines += ["", "## Settings", ""]
    for name, e in doc["engines"].items():
        lines.append(f"- {name}: " + "; ".join(f"{k} {v}" for k, v in e["settings"].items()))
    return lines


def run(args) -> int:
    doc = report(args.mu, args.steps, args.every)
    args.out.mkdir(parents=True, exist_ok=True)
    png = plot(args.out / "wiping-replay.png", doc)
    write_json(args.out / "wiping-replay.json", doc)
    write_markdown(args.out / "wiping-replay.md", markdown(doc, png.name))
    print("\n".join(markdown(doc, png.name)[:16]))
    ours = doc["engines"]["ours"]["open_loop"]
    gaps = [s["v_gap"]["max"] for s in doc["engines"]["mujoco"]["one_step"].values()]
    ok = ours["max_q_gap"] <= OWN_TOL and all(g is None or g <= STEP_TOL for g in gaps)
    print(f"wrote {args.out / 'wiping-replay.md'}, .json, .png; {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1
