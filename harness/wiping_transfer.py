"""The wiping task's transfer gap: our controller, UC and DiffOSI on the arm as MuJoCo runs it.

The "real world" is MuJoCo running reference_models/wiping_arm.xml with the tool joint's
stiffness and damping set to the true mu (jnt_stiffness, dof_damping), its own contact
(solref/solimp constraints, pyramidal cone) and sensing: the controller
(`diffosi.Wiping.act`, the same law and code as ours) reads MuJoCo's tool-table normal
force (mj_contactForce after mj_forward) at every 1 ms step, and its torques go in through
qfrc_applied. Per run (true mu drawn uniformly in [1, 100]^2, seeded):

1. one episode with the canonical gains in MuJoCo; DiffOSI identifies mu from 50
   closed-loop segments of it in our engine (`Wiping.identify`), as Table 3 does;
2. the task metric (MSE of MuJoCo's sensed force against 3 N over its in-contact steps)
   in MuJoCo with the UC's gains at the true mu (UC-Oracle), at DiffOSI's estimate
   (UC-DiffOSI), at the middle of the box (UC-Average) and with DR's gains; the same
   gains in our engine beside them.

Writes <out>/transfer-wiping-mujoco.md and .json (the same seed gives the same json).

    python -m harness wiping-transfer --runs 5 --seed 0
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from harness.report import REPO, REPORTS, markdown_table, write_json, write_markdown

MODEL = REPO / "reference_models" / "wiping_arm.xml"
POLICIES = REPO / "policies" / "wiping"
STEPS, CONTACT, F_GOAL = 3000, 0.03, 3.0
METHODS = ("UC-Oracle", "UC-DiffOSI", "UC-Average", "DR")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--runs", type=int, default=5, help="true mu drawn (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


class MujocoArm:
    """The arm in MuJoCo as it runs the file (contacts and limits on), tool compliance at mu."""

    def __init__(self):
        import mujoco

        from harness.engines.mujoco import load_mjcf

        self.mujoco, self.m = mujoco, load_mjcf(MODEL)
        self.d = mujoco.MjData(self.m)
        self.tool = self.m.joint("tool").id
        o = self.m.opt
        self.settings = {"version": mujoco.__version__, "solver": mujoco.mjtSolver(o.solver).name,
                         "cone": mujoco.mjtCone(o.cone).name, "solref": self.m.geom_solref[0].tolist(),
                         "solimp": self.m.geom_solimp[0, :3].tolist(), "timestep": float(o.timestep),
                         "tau_applied_via": "qfrc_applied", "sensing": "mj_contactForce after mj_forward"}

    def force(self) -> float:
        from harness.engines.mujoco import contact_normal_forces

        self.mujoco.mj_forward(self.m, self.d)
        return float(contact_normal_forces(self.m, self.d).sum())

    def episode(self, wiping, mu, gains, start) -> dict:
        """One closed-loop episode: states, offsets xi and sensed forces per step."""
        m, d = self.m, self.d
        m.jnt_stiffness[self.tool] = 100.0 * mu[0]
        m.dof_damping[m.jnt_dofadr[self.tool]] = mu[1]
        self.mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = start
        xi, rows = 0.0, {"q": [], "v": [], "xi": [], "force": []}
        for k in range(STEPS + 1):
            f = self.force()
            for key, value in (("q", d.qpos.copy()), ("v", d.qvel.copy()), ("xi", xi), ("force", f)):
                rows[key].append(value)
            if k == STEPS:
                break
            tau, xi = wiping.act(k, d.qpos, d.qvel, xi, f, gains=gains)
            d.qfrc_applied[:] = tau
            self.mujoco.mj_step(m, d)
            if not np.all(np.isfinite(d.qpos)):
                raise FloatingPointError(f"MuJoCo diverged at step {k} (mu {mu}, gains {gains})")
        return {key: np.array(value) for key, value in rows.items()}


def metric(force: np.ndarray) -> float:
    touching = force[force > CONTACT]
    return float(np.mean((touching - F_GOAL) ** 2)) if len(touching) else float("inf")


def report(runs: int, seed: int) -> dict:
    import diffosi

    wiping, arm = diffosi.Wiping(), MujocoArm()
    uc = POLICIES / "uc.json"
    dr = json.loads((POLICIES / "dr.json").read_text())
    dr_gains = (dr["k_tau"], dr["k_xi"])
    start_ep = wiping.episode([50.0, 50.0], steps=600)  # the start state is the task's, whatever mu
    start = (start_ep["q"][0], start_ep["v"][0])
    lo, hi = wiping.mu_range
    rng = np.random.default_rng(seed)
    out = []
    for r in range(runs):
        mu = lo + (hi - lo) * rng.random(2)
        canonical = arm.episode(wiping, mu, wiping.canonical_gains, start)
        est = wiping.identify(canonical["q"], canonical["v"], canonical["xi"], seed=seed + r)
        mu_hat = np.clip(est["mu"], lo, hi)
        gains = {"UC-Oracle": wiping.uc_gains(uc, mu), "UC-DiffOSI": wiping.uc_gains(uc, mu_hat),
                 "UC-Average": wiping.uc_gains(uc, (lo + hi) / 2), "DR": dr_gains}
        tail = canonical["force"][-1000:]
        row = {"mu": mu, "mu_hat": mu_hat, "flags": est["flags"], "mu_abs_error": np.abs(mu_hat - mu),
               "canonical_last_second": {"mean_force": float(tail.mean()), "std_force": float(tail.std()),
                                         "in_contact": float((tail > CONTACT).mean())},
               "methods": {}}
        for name in METHODS:
            g = gains[name]
            row["methods"][name] = {"gains": g, "mujoco": metric(arm.episode(wiping, mu, g, start)["force"]),
                                    "ours": float(wiping.episode(mu, gains=g)["metric"])}
        out.append(row)
        print(f"run {r + 1}/{runs}: mu {np.round(mu, 2)}, DiffOSI from MuJoCo {np.round(mu_hat, 2)}")
    return {"runs": out, "seed": seed, "settings": arm.settings}


def summary(doc: dict) -> dict:
    rows = {}
    for name in METHODS:
        for engine in ("mujoco", "ours"):
            x = np.array([r["methods"][name][engine] for r in doc["runs"]])
            rows.setdefault(name, {})[engine] = (float(x.mean()), float(x.std()))
    return rows


def markdown(doc: dict) -> list[str]:
    s = summary(doc)
    err = np.array([r["mu_abs_error"] for r in doc["runs"]])
    lines = ["# Wiping transfer: our controllers and identifier on MuJoCo's arm", "",
             f"{len(doc['runs'])} runs (seed {doc['seed']}), true mu = (tool k_p in N/cm, k_d in N s/m) "
             "uniform in [1, 100]^2. Each method's gains run closed loop in MuJoCo (MuJoCo's contact, "
             "MuJoCo's sensed force) and in ours; task metric = MSE of the sensed normal force against 3 N "
             "over the steps in contact (N^2).", ""]
    lines += markdown_table(["method", "metric in MuJoCo", "metric in ours"],
                            [[n, f"{s[n]['mujoco'][0]:.3f} ± {s[n]['mujoco'][1]:.3f}",
                              f"{s[n]['ours'][0]:.3f} ± {s[n]['ours'][1]:.3f}"] for n in METHODS])
    last = [r["canonical_last_second"] for r in doc["runs"]]
    lines += ["", "With the canonical gains MuJoCo's sensed force averages "
              f"{np.mean([x['mean_force'] for x in last]):.2f} N over the last second (std "
              f"{np.mean([x['std_force'] for x in last]):.2f} N, in contact "
              f"{100 * np.mean([x['in_contact'] for x in last]):.0f}% of the steps): the loop regulates the "
              "mean, but the tool bounces on MuJoCo's stiffer contact."]
    lines += ["", f"DiffOSI from MuJoCo's canonical-gain episode (in our engine): mean |mu_hat - mu| "
              f"k_p {err[:, 0].mean():.2f} N/cm, k_d {err[:, 1].mean():.2f} N s/m; flags per run: "
              + ", ".join(str(r["flags"] or "none") for r in doc["runs"]) + ".", "", "## Runs", ""]
    lines += markdown_table(["mu", "DiffOSI mu_hat"] + [f"{n} (MuJoCo)" for n in METHODS],
                            [[np.round(r["mu"], 2).tolist(), np.round(r["mu_hat"], 2).tolist()]
                             + [f"{r['methods'][n]['mujoco']:.3f}" for n in METHODS] for r in doc["runs"]])
    lines += ["", "MuJoCo settings: " + "; ".join(f"{k} {v}" for k, v in doc["settings"].items())]
    return lines


def run(args) -> int:
    doc = report(args.runs, args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "transfer-wiping-mujoco.json", doc)
    lines = markdown(doc)
    write_markdown(args.out / "transfer-wiping-mujoco.md", lines)
    print("\n".join(lines[:12]))
    print(f"wrote {args.out / 'transfer-wiping-mujoco.md'} and .json")
    return 0
