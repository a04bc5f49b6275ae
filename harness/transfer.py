"""Transfer gaps: our controllers and DiffOSI run against MuJoCo, PyBullet and DART (paper Table 5), every task.

--task all runs the cartpole, the half cheetah and the wiping task (harness/wiping_transfer.py)
in turn, each with its summary for --target all. --task half_cheetah_contact runs the half
cheetah whose mu adds leg armature and friction (policies/half_cheetah_contact/): each
engine's own settings fill mu[1:] (TaskSpec.environment), a reference engine is given the
torso mass only, and it runs DR, UC-Average, UC-DiffOSI-joint (fed all three components) and
UC-Oracle (see NO_DIFFOSI).

The paper (Section 4.6, Table 5) trains in one engine (NimblePhysics) and tests in
another (PyBullet). Here the controllers were trained in ours (policies/cartpole/) and
the target environment is a reference engine (harness/engines/) left where a user would
leave it (`native=True`): PyBullet with its default link damping (0.04) and velocity cap
(100), MuJoCo with its implicit Euler damping, DART with its implicit passive forces;
contacts and limits off, the file's gravity and timestep, generalized forces applied
directly. The cartpole has no joint damping, so MuJoCo and DART run the same dynamics as
ours (to ~1e-13); PyBullet's link damping is a real gap (a force -0.04 (1 + |v|) m v per
link: at the 5-7 m/s of a recovering swing, one-step residuals 30-100 times DiffOSI's
residual scale). `--unmodelled` widens the gap: `friction` adds Coulomb friction on the
slider (--friction N, each engine's own mechanism), `delay` applies the previous control
step's force (zero on the first step). Neither is in our model, and DiffOSI is told the
commanded force.

Each episode: the target runs with the episode's true mu (Task.mu_params(mu): the pole
COM at (mu, 0, 0.5 + 0.2 mu)) from its initial state; every control step the policy
acts on the target's state, the target steps under the resulting force, and the metric
counts the steps that end with |theta| <= pi/2 and |x| <= 2.5 (the episode ends at the
first that does not). Methods (diffosi.Task / Policy / OnlineOsi, the Rust task,
shipped policies and identifier):
- DR: the domain-randomised policy (no mu);
- UC-DiffOSI: the Universal Controller fed DiffOSI's current estimate; each observed
  transition (q, v, tau, q', v') of the target is pushed to OnlineOsi (bounded
  Levenberg-Marquardt on our engine, warm start, mu in [-0.6, 0.6]) on the --window most
  recent transitions (default 4: the paper's largest context window, N = 5 in its Fig. 4;
  in PyBullet it cuts the mu error about 3x against a window of 1); the first step is
  fed the prior, the middle of the range (0);
- UC-Oracle: the Universal Controller fed the true mu (the oracle in the target engine).
Episodes: --episodes (mu, initial state) pairs drawn with --seed by Task.episodes (the
ones `diffosi eval --seed` meets), each run with every shipped policy seed (--seeds), so
every method and target meets the same episodes; a fresh engine per episode. Per
episode: the metric, and for the UC methods the mean over control steps of |mu_fed - mu|
(MAE) and of |mu_fed - mu| / |mu| (MARE). Tables give mean +- population std over all
episodes and seeds. Our engine itself runs the same episodes first (the source: no gap,
no unmodelled effects), so each table shows the transfer gap next to the target's numbers.

The half cheetah (--task half_cheetah, every target; no --unmodelled): MuJoCo runs
gymnasium's half_cheetah.xml as HalfCheetah-v5 does (harness/engines/mujoco.py
GymMujocoEngine: frame_skip 5 at dt 0.01, ctrl = the action on the file's motors, its own
constraint-based contact and joint limits), with the torso mass (mu, kg) in body_mass;
PyBullet runs the URDF twin on a plane as `harness contact` does (harness/contact.py
PybulletContact: stable substeps, no armature), the torso mass by changeDynamics; DART runs
the URDF twin on a ground box (harness/contact.py DartContact: its LCP contact, the URDF's
limits, no armature), the torso mass by BodyNode.setMass. In all three, like our
body/torso/mass, the COM and the inertia about the COM stay. Its methods add UC-Average (the
UC fed the middle of the mass range at every step): what an identifier that cannot explain
the target's transitions should at least match; and UC-DiffOSI-joint (JointOsi): the torso mass
identified with the leg armature, the target's contact, limit and dry-friction impulses
unknown, on a window of --joint-window transitions. A control step is
the task's `substeps` physics steps under one force; DiffOSI is pushed the last of them
(as the task's estimators see it in `diffosi eval`: Env::last_transition), on our model
with its constraint contact (MuJoCo's, to 1e-9 per step); per episode the signed `bias`
(mean of mu_fed - mu) is kept besides MAE and MARE. The metric is the task's reward
summed (the return): forward speed of the torso minus 0.1 |a|^2 per control step,
HalfCheetah-v5's reward, computed by the same function in every engine. Defaults: 10 episodes per policy seed, the full 1000 steps. To
show where the bias comes from, the report adds DiffOSI on one transition at a time along
the UC-Oracle episodes, split by whether the target's physics step had constraints
(MuJoCo: contacts or joint limits; PyBullet: contact points) or none
(single_transition_estimates).

The quadruped (--task quadruped, --target mujoco; issue 41): the Go1 carrying a payload, mu =
(payload mass kg, COM offset m), in MuJoCo loading the same URDF through its importer
(harness/engines/go1.py MujocoGo1: fusestatic off, the floor added, the servos as MuJoCo position
actuators with the task's kp 20 and kd 0.5, mu set on the payload body by its named parameters).
A control step holds its servo targets (ctrl) for the task's substeps; DiffOSI is pushed the last
physics step with the forces task.held_forces gives at its start state (the servos' forces at the
targets, as ours reads them), identifies both components, and the errors and plots read the mass,
mu[0]. Not in --task all until its policies (policies/quadruped/{uc,dr}-seed<s>.json) ship.
Episodes end at a fall; each method's summary gives the fraction that fell (`fall_fraction`).

Writes <out>/transfer-<task>-<target>[-<unmodelled>].{md,json,png} per target and, for
--target all, transfer-<task>-summary[-<unmodelled>].{md,json,png}.

    python -m harness transfer --task cartpole --target all
    python -m harness transfer --task cartpole --target pybullet --unmodelled friction,delay
    python -m harness transfer --task half_cheetah --target mujoco
    python -m harness transfer --task half_cheetah --target all
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import diffosi
from harness import engines, wiping_transfer
from harness.engines.base import REPO
from harness.report import REPORTS, markdown_table, write_json, write_markdown

METHODS = ("DR", "UC-DiffOSI", "UC-Oracle")  # the paper's Table 5; the half cheetah adds UC-Average
JOINT = "UC-DiffOSI-joint"  # the half cheetah's identifier for a contact law not ours (JointOsi)
SOURCE = "ours"  # our engine as the environment: the training engine, no transfer gap
# ours with every joint's armature 0: what the half cheetah's armature is worth (DART and PyBullet have none)
NO_ARMATURE = "ours without armature"
UNMODELLED = ("friction", "delay")
POLICIES = REPO / "policies"
GOAL = 0.95  # issue 7: UC-DiffOSI reaches 95% of UC-Oracle's task performance in every target
# Table 5 of the paper (NimblePhysics -> PyBullet): (MAE, MARE, task performance), mean and std
PAPER = {
    "DR": (None, None, (297.26, 197.85)),
    "UC-DiffOSI": ((0.02, 0.04), (0.03, 0.06), (434.10, 110.88)),
    "UC-Oracle": ((0.0, 0.0), (0.0, 0.0), (451.00, 73.81)),
}


@dataclass(frozen=True)
class TaskSpec:
    """What differs between the tasks a transfer runs."""

    targets: tuple  # the engines it transfers to (--target all)
    episodes: int  # default episodes per policy seed
    score: str  # what an episode's score counts
    mu: str  # mu's meaning and unit
    mu_limits: tuple  # plot range of mu
    unmodelled: bool  # whether --unmodelled applies
    goals: dict  # UC-DiffOSI's goal per target, a share of UC-Oracle's score there
    methods: tuple = METHODS  # UC-Average: the UC fed the middle of mu's range
    # half_cheetah_contact: mu[1:] (leg armature, friction) are each environment's own
    # settings, not drawn; a reference engine is given the torso mass only.
    environment: dict | None = None
    # the quadruped: mu[1:] (the payload's COM offset) identified and fed, not scored
    scored_first: bool = False


TASKS = {
    "cartpole": TaskSpec(engines.ENGINES, 20, "steps in bounds", "mu (m)", (-0.65, 0.65), True,
                         dict.fromkeys(engines.ENGINES, GOAL)),
    # issue 19: 97% in MuJoCo (the same contact law), 95% in the engines with their own
    "half_cheetah": TaskSpec(engines.ENGINES, 10, "return", "torso mass (kg)", (0.0, 52.0), False,
                             {"mujoco": 0.97, "pybullet": GOAL, "dart": GOAL},
                             ("DR", "UC-Average", "UC-DiffOSI", JOINT, "UC-Oracle")),
    # The file's (armature 0.1, friction 0.4) in ours and MuJoCo; PyBullet and DART have no
    # armature, friction 0.4 as their URDF twin says.
    "half_cheetah_contact": TaskSpec(engines.ENGINES, 10, "return", "torso mass (kg)", (0.0, 52.0), False,
                                     {"mujoco": 0.97, "pybullet": GOAL, "dart": GOAL},
                                     ("DR", "UC-Average", JOINT, "UC-Oracle"),
                                     {"ours": (0.1, 0.4), "mujoco": (0.1, 0.4), "pybullet": (0.0, 0.4),
                                      "dart": (0.0, 0.4)}),
    "quadruped": TaskSpec(("mujoco",), 10, "return", "payload mass (kg)", (-0.5, 8.5), False,
                          {"mujoco": GOAL}, scored_first=True),
}
# --task all: the tasks with shipped policies (the quadruped's are to come, issue 41)
ALL = ("cartpole", "half_cheetah", "half_cheetah_contact", "wiping")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--task", default="cartpole", choices=[*TASKS, "wiping", "all"],
                    help="task, or all of them (default %(default)s)")
    ap.add_argument("--target", required=True, choices=[*engines.ENGINES, "all"],
                    help="target engine, or all of them")
    ap.add_argument("--episodes", type=int, default=None,
                    help="episodes per policy seed (default: cartpole 20, half_cheetah 10)")
    ap.add_argument("--runs", type=int, default=5, help="the wiping task's runs (true mu) per target "
                    "(default %(default)s)")
    ap.add_argument("--seeds", default="0,1,2", help="shipped policy seeds (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the episodes (default %(default)s)")
    ap.add_argument("--horizon", type=int, default=None, help="control steps per episode (default: the task's)")
    ap.add_argument("--window", type=int, default=4, help="DiffOSI window in transitions (default %(default)s)")
    ap.add_argument("--joint-window", type=int, default=20,
                    help=f"{JOINT}'s window in transitions (the half cheetah; default %(default)s)")
    ap.add_argument("--unmodelled", default="", help=f"comma-separated effects from {', '.join(UNMODELLED)}")
    ap.add_argument("--friction", type=float, default=1.0,
                    help="Coulomb friction on the cart's slider, N (default %(default)s)")
    ap.add_argument("--plot-episodes", type=int, default=3, help="episodes whose mu_hat is plotted and kept")
    ap.add_argument("--policies", type=Path, default=None,
                    help="directory of {uc,dr}-seed<s>.json (default policies/<task>/)")
    ap.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


class Setup:
    """What every episode of one run shares: the task, policies, episodes and target options."""

    def __init__(self, args, unmodelled: list[str]):
        self.task = diffosi.Task(args.task)
        self.spec = TASKS[args.task]
        assert self.task.nmu == 1 or self.spec.environment or self.spec.scored_first, \
            "the errors and plots read mu[0] alone"
        self.horizon = min(args.horizon or self.task.horizon, self.task.horizon)
        self.seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
        self.mu, self.q0, self.v0 = self.task.episodes(args.episodes or self.spec.episodes, args.seed)
        self.prior = np.mean(self.task.mu_range, axis=0)  # the middle of mu's box
        self.window, self.delay = args.window, "delay" in unmodelled
        self.joint_window = args.joint_window
        self.friction = {"slider": args.friction} if "friction" in unmodelled else {}
        folder = args.policies or POLICIES / args.task
        self.policies = {(kind, s): diffosi.Policy.load(folder / f"{kind}-seed{s}.json")
                         for kind in ("uc", "dr") for s in self.seeds}

    def episode_mu(self, target: str, k: int) -> np.ndarray:
        """Episode k's true mu in `target`: the drawn mu, its environment's settings in mu[1:]."""
        mu = self.mu[k].copy()
        if self.spec.environment:
            mu[1:] = self.spec.environment[target]
        return mu

    def target(self, name: str):
        """A fresh environment: a reference engine, or SOURCE (our engine, no gap)."""
        if name in (SOURCE, NO_ARMATURE):
            return Source(self.task, armature=name == SOURCE)
        if self.task.name == "quadruped":
            from harness.engines.go1 import MujocoGo1

            return MujocoGo1()
        cheetah = self.task.name.startswith("half_cheetah")
        if cheetah and name in ("pybullet", "dart"):
            from harness.contact import CHEETAH_URDF, DartContact, PybulletContact

            twin = {"pybullet": PybulletContact, "dart": DartContact}[name]
            return twin(CHEETAH_URDF, self.task.model().timestep)
        if cheetah:
            from harness.contact import GYM_CHEETAH
            from harness.engines.mujoco import GymMujocoEngine

            return GymMujocoEngine(GYM_CHEETAH)
        return engines.load(name, self.task.name, native=True, friction=self.friction)


class JointOsi:
    """The half cheetah's torso mass identified jointly with what another engine may do
    differently, online: half_cheetah_contact's mu (torso mass, the six leg joints' armature
    tied, every geom's friction) by OnlineOsi with constraints="unknown", so the target's
    contact, limit and dry-friction impulses are eliminated from every transition whatever its
    contact law, and friction, felt through them alone, keeps its prior. LM without restarts:
    the residual is linear in the mass and the armature. `mu` is what the UC reads: the torso
    mass alone for the half cheetah's, all three for half_cheetah_contact's (`full`)."""

    def __init__(self, window: int, seed: int, full: bool):
        self.osi = diffosi.OnlineOsi(diffosi.Task("half_cheetah_contact"), window=window, seed=seed,
                                     constraints="unknown", restarts=0)
        self.full = full

    @property
    def mu(self) -> np.ndarray:
        return self.osi.mu if self.full else self.osi.mu[:1]

    def push(self, q, v, tau, q_next, v_next) -> dict:
        return self.osi.push(q, v, tau, q_next, v_next)


class Source:
    """Our engine as the environment, the one the policies were trained in: the task's model
    (the half cheetah's with its contact and limits), stepped by diffosi.Model, behind the
    adapters' interface (no friction, no delay); armature=False: every joint's armature 0."""

    def __init__(self, task, armature: bool = True):
        self.model, self.state = task.model(), None
        for joint in [] if armature else self.model.joint_names:
            self.model.set_param(f"joint/{joint}/armature", 0.0)

    def set_param(self, name: str, value) -> None:
        self.model.set_param(name, value)

    def set_state(self, q, v) -> None:
        self.state = (q, v)

    def get_state(self) -> tuple:
        return self.state

    def step(self, tau, ctrl=None) -> None:
        self.state = self.model.step(*self.state, tau, ctrl=ctrl)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        pass


def run_episode(setup: Setup, target: str, method: str, seed: int, k: int, keep_trace: bool,
                transitions: list | None = None) -> dict:
    """One episode of one method in a fresh target engine. A control step holds its force (and
    a servo task's ctrl) for the task's substeps physics steps; DiffOSI sees the last of them,
    under the forces it held (task.held_forces at its start for a servo task), which is appended
    to `transitions` (if given) as (q, v, tau, q', v', constrained): constrained whether the
    target had constraint rows in it (an engine without the flag: None)."""
    task, mu = setup.task, setup.episode_mu(target, k)
    policy = setup.policies[("dr" if method == "DR" else "uc", seed)]
    osi = {"UC-DiffOSI": lambda: diffosi.OnlineOsi(task, window=setup.window, seed=seed),
           JOINT: lambda: JointOsi(setup.joint_window, seed, task.nmu > 1)}.get(method, lambda: None)()
    fed_trace, score, flags, fell = [], 0.0, 0, False
    with setup.target(target) as env:
        for name, value in task.mu_params(mu).items():
            if target == SOURCE or not setup.spec.environment or name == "body/torso/mass":
                env.set_param(name, value)
        q, v = setup.q0[k], setup.v0[k]
        env.set_state(q, v)
        previous, peak = np.zeros(len(v)), np.abs(q)
        for _ in range(setup.horizon):
            fed = osi.mu if osi else {"DR": None, "UC-Average": setup.prior, "UC-Oracle": mu}[method]
            action = policy.act(task, q, v, fed)
            tau, ctrl = task.inputs(action)
            applied = previous if setup.delay and target != SOURCE else tau
            servo = (ctrl,) if ctrl.size else ()
            start = (q, v)
            env.step(applied, *servo)
            for _ in range(task.substeps - 1):
                start = env.get_state()
                env.step(applied, *servo)
            previous = tau
            q1, v1 = env.get_state()
            if servo:
                tau = task.held_forces(*start, action)
            if osi is not None:
                flags += "at_bound" in osi.push(*start, tau, q1, v1)["flags"]
            if transitions is not None:
                transitions.append((*start, tau, q1, v1, getattr(env, "constrained", None)))
            if fed is not None:
                fed_trace.append(float(fed[0]))
            score += task.metric(q, v, action, q1, v1)
            q, v, peak = q1, v1, np.maximum(peak, np.abs(q1))
            fell = task.terminated(q, v)
            if fell:
                break
    out = {"policy_seed": seed, "episode": k, "mu": float(mu[0]), "score": score, "peak_abs_q": peak,
           "fell": fell}
    if method != "DR":
        err = np.array(fed_trace) - mu[0]
        out.update(mae=float(np.abs(err).mean()), mare=float((np.abs(err) / abs(mu[0])).mean()),
                   bias=float(err.mean()))
    if osi is not None:
        out.update(mu_hat_final=float(osi.mu[0]), steps_at_bound=flags)
    if keep_trace and osi is not None:
        out["mu_fed"] = fed_trace
    return out


def mean_std(x) -> list:
    x = np.asarray(x, float)
    return [float(x.mean()), float(x.std())]


def summarize(episodes: list[dict]) -> dict:
    out = {"score": mean_std([e["score"] for e in episodes]),
           "fall_fraction": float(np.mean([e["fell"] for e in episodes]))}
    if "mae" in episodes[0]:
        out.update({k: mean_std([e[k] for e in episodes]) for k in ("mae", "mare", "bias")})
    out["per_seed_score"] = {str(s): mean_std([e["score"] for e in episodes if e["policy_seed"] == s])
                             for s in sorted({e["policy_seed"] for e in episodes})}
    return out


def run_batch(setup: Setup, target: str, method: str, seed: int, plot_episodes: int) -> list[dict]:
    """One method with one policy seed on one target (or SOURCE): every episode, the first
    `plot_episodes` with their fed-mu traces. (A sweep runs these as its units.)"""
    return [run_episode(setup, target, method, seed, k, k < plot_episodes) for k in range(len(setup.mu))]


def run_methods(setup: Setup, target: str, plot_episodes: int, batch=run_batch) -> dict:
    """Every method on one target (or SOURCE), with progress per (method, policy seed) batch;
    the first policy seed's first `plot_episodes` episodes keep their traces."""
    results = {}
    for method in setup.spec.methods:
        episodes = []
        for seed in setup.seeds:
            start = time.perf_counter()
            batch_episodes = batch(setup, target, method, seed, plot_episodes if seed == setup.seeds[0] else 0)
            episodes += batch_episodes
            print(f"  {target:8s} {method:10s} policy seed {seed}: {len(batch_episodes)} episodes, task performance "
                  f"{np.mean([e['score'] for e in batch_episodes]):6.1f}  ({time.perf_counter() - start:.1f} s)",
                  flush=True)
        results[method] = {"summary": summarize(episodes), "episodes": episodes}
    return results


def run_target(setup: Setup, target: str, plot_episodes: int, source: dict, batch=run_batch) -> dict:
    """Every method on one target; `source` holds the same episodes' results in our engine
    (kept: the summaries, and UC-DiffOSI's episodes without their traces)."""
    results = run_methods(setup, target, plot_episodes, batch)
    oracle = results["UC-Oracle"]["summary"]["score"][0]
    identified = "UC-DiffOSI" in results
    ratio = (results["UC-DiffOSI"]["summary"]["score"][0] / oracle if oracle else float("nan")) if identified else None
    goal = setup.spec.goals[target]
    with setup.target(target) as env:
        engine = {"name": env.name, "version": env.version, "model": env.label, "passive": env.passive,
                  "integrator": env.integrator, "timestep": env.timestep, "gravity": env.gravity,
                  "settings": env.settings}
    diffosi_source = [{k: x for k, x in e.items() if k != "mu_fed"}
                      for e in source.get("UC-DiffOSI", {"episodes": []})["episodes"]]
    doc = {"target": target, "engine": engine, "methods": results,
           "source": {m: r["summary"] for m, r in source.items()}, "source_diffosi": diffosi_source,
           "diffosi_over_oracle": ratio, "goal": goal, "meets_goal": bool(ratio >= goal) if identified else None}
    if JOINT in results:  # the same goal for the identifier that assumes no contact law
        joint = results[JOINT]["summary"]["score"][0] / oracle
        doc.update(joint_over_oracle=joint, joint_meets_goal=bool(joint >= goal))
    if setup.task.name == "half_cheetah" and target == "dart":  # what the armature DART lacks is worth in ours
        from harness.contact import dart_cheetah_contact

        doc["dart_contact"] = dart_cheetah_contact()
        doc["without_armature"] = {
            m: summarize([e for seed in setup.seeds for e in batch(setup, NO_ARMATURE, m, seed, 0)])
            for m in ("DR", "UC-Average", "UC-Oracle")}
    if setup.task.name.startswith("half_cheetah") and identified:
        # the cheetah in DART: also ours without armature, DiffOSI's model keeping the file's
        compared = (target, SOURCE, NO_ARMATURE) if "without_armature" in doc else (target, SOURCE)
        doc["single_transition"] = {name: single_transition_estimates(setup, name) for name in compared}
    return doc


def single_transition_estimates(setup: Setup, target: str) -> dict:
    """Where DiffOSI's bias comes from: the mu identified from one transition at a time (window
    1, from the prior, on our nominal model) along the UC-Oracle episodes of the first policy
    seed, split by whether the target's physics step had constraint rows (MuJoCo: contacts or
    joint limits, nefc > 0). Per kind: the count, and the median and quartiles of the relative
    error (mu_hat - mu) / mu and the share of estimates at a bound of mu's range."""
    task, seed = setup.task, setup.seeds[0]
    lo, hi = (float(b[0]) for b in task.mu_range)
    param = next(iter(task.mu_params(setup.mu[0])))  # mu[0]'s parameter (identity map: the torso mass)
    osi = diffosi.DiffOsi(task.model(), params=[param], lower=[lo], upper=[hi], method="lm")
    kinds: dict = {}
    for k, mu in enumerate(setup.mu[:, 0]):
        transitions: list = []
        run_episode(setup, target, "UC-Oracle", seed, k, False, transitions)
        for *x, constrained in transitions:
            est = osi.identify(*(np.atleast_2d(a) for a in x), init=[(lo + hi) / 2])["params"][0]
            kind = {True: "constrained", False: "free", None: "all"}[constrained]
            kinds.setdefault(kind, []).append(((est - mu) / mu, est in (lo, hi)))
    out = {}
    for kind, rows in sorted(kinds.items()):
        errors, at_bound = np.array(rows).T
        out[kind] = {"count": len(rows), "relative_error_quartiles": np.percentile(errors, [25, 50, 75]).tolist(),
                     "at_bound": float(at_bound.mean())}
    return out


def fmt(pair, digits: int = 3) -> str:
    return f"{pair[0]:.{digits}f} ± {pair[1]:.{digits}f}"


def paper_cells(method: str) -> list[str]:
    mae, mare, score = PAPER[method]
    na = "N/A"
    return [fmt(mae, 2) if mae else na, fmt(mare, 2) if mare else na, fmt(score, 2)]


def method_rows(doc: dict) -> list[list]:
    rows = []
    for method, r in doc["methods"].items():
        s = r["summary"]
        rows.append([method, fmt(s["mae"]) if "mae" in s else "N/A", fmt(s["mare"]) if "mare" in s else "N/A",
                     fmt(s["score"], 1), fmt(doc["source"][method]["score"], 1), *paper_cells(method)])
    return rows


def partings(doc: dict) -> tuple[list[str], list[list]]:
    """The episodes where UC-DiffOSI and UC-Oracle score differently: a sentence and table rows."""
    oracle = {(e["policy_seed"], e["episode"]): e for e in doc["methods"]["UC-Oracle"]["episodes"]}
    rows, lost, won = [], 0, 0
    for e in doc["methods"]["UC-DiffOSI"]["episodes"]:
        o = oracle[(e["policy_seed"], e["episode"])]
        if e["score"] != o["score"]:
            lost, won = lost + (e["score"] < o["score"]), won + (e["score"] > o["score"])
            rows.append([e["policy_seed"], e["episode"], f"{e['mu']:.3f}", f"{e['score']:.0f}", f"{e['mae']:.3f}",
                         f"{o['score']:.0f}", ", ".join(f"{x:.2f}" for x in o["peak_abs_q"])])
    n = len(oracle)
    words = [f"UC-DiffOSI and UC-Oracle score alike in {n - lost - won} of {n} episodes; UC-DiffOSI scores "
             f"lower in {lost} and higher in {won}. Those episodes (peak |q| = max over the episode of |x| "
             "(m) and |theta| (rad); the bounds are 2.5 and pi/2 = 1.571):"]
    return words, rows


def gap_words(meta: dict) -> str:
    effects = []
    if meta["friction"]:
        effects.append(f"Coulomb friction {meta['friction']['slider']} N on the slider")
    if meta["delay"]:
        effects.append("a one-control-step actuator delay")
    return ", plus unmodelled " + " and ".join(effects) if effects else ", no unmodelled effects"


def markdown(doc: dict, meta: dict, png: str) -> list[str]:
    e = doc["engine"]
    ratio = doc["diffosi_over_oracle"]
    verdict = "meets" if doc["meets_goal"] else f"**misses by {100 * (doc['goal'] - ratio):.1f} points**"
    lines = [
        f"# Transfer: {meta['task']} controllers from our engine to {e['name']} {e['version']}",
        "",
        f"`{meta['command']}`",
        "",
        f"Target: {e['name']} {e['version']} running `{e['model']}` as a user would leave it (`native=True`), "
        f"{e['passive']} passive forces, {e['integrator']}, h = {e['timestep']:g} s{gap_words(meta)}. "
        f"The policies and DiffOSI run on our engine. {meta['episodes']} episodes (mu, initial state; "
        f"seed {meta['seed']}) x policy seeds {meta['seeds']} = {meta['episodes'] * len(meta['seeds'])} "
        f"per method, horizon {meta['horizon']} control steps; DiffOSI window {meta['window']}.",
        "",
        f"UC-DiffOSI reaches {100 * ratio:.1f}% of UC-Oracle's task performance in this target "
        f"(goal {100 * doc['goal']:.0f}%: {verdict}; the paper: 96.3% in PyBullet).",
        "",
    ]
    lines += markdown_table(["Approach", "MAE (mu)", "MARE (mu)", "Task performance", "in our engine",
                             "paper MAE", "paper MARE", "paper task performance"], method_rows(doc))
    lines += ["", "Paper: Table 5, NimblePhysics -> PyBullet, 20 models. Mean ± population std over episodes; "
              "MAE and MARE average |mu fed to the UC - mu| (divided by |mu| for MARE) over an episode's "
              "control steps. \"In our engine\": the same episodes and policies with our engine as the "
              "environment (the training engine: no gap, no unmodelled effects); the transfer gap is the "
              "difference.", "", "Task performance per policy seed:", ""]
    seeds = list(doc["methods"]["DR"]["summary"]["per_seed_score"])
    lines += markdown_table(["Approach", *[f"seed {s}" for s in seeds]],
                            [[m, *[fmt(r["summary"]["per_seed_score"][s], 1) for s in seeds]]
                             for m, r in doc["methods"].items()])
    words, rows = partings(doc)
    lines += ["", *words, ""]
    lines += markdown_table(["policy seed", "episode", "mu", "UC-DiffOSI", "its MAE", "UC-Oracle",
                             "UC-Oracle peak abs q"], rows)
    lines += ["", f"![task performance and mu estimates]({png})", "", f"## What {e['name']} ran", ""]
    lines += [f"- {key}: {value}" for key, value in e["settings"].items()]
    if meta["delay"]:
        lines.append("- actuator delay (harness): each step applies the previous control step's force, "
                     "zero on the first; DiffOSI is given the commanded force")
    return lines


def bias_fit(episodes: list[dict]) -> tuple[float, float]:
    """Least-squares (slope, intercept) of the mean mu fed per episode against the true mu
    (NaN with fewer than two distinct true mu)."""
    mu = np.array([e["mu"] for e in episodes])
    if len(set(mu)) < 2:
        return float("nan"), float("nan")
    slope, intercept = np.polyfit(mu, mu + np.array([e["bias"] for e in episodes]), 1)
    return float(slope), float(intercept)


ENGINE_NAMES = {"mujoco": "MuJoCo", "pybullet": "PyBullet", "dart": "DART"}
# What a target's `constrained` flag means (single_transition_estimates).
CONSTRAINED = {"mujoco": "constraint rows (contacts or joint limits)", "pybullet": "a contact point",
               "dart": "a contact"}
GAP_WORDS = {
    "mujoco": "Both engines run the same model with the same contact law: MuJoCo's soft constraints (pyramidal "
              "cones, solref/solimp impedance, Newton solver), ours to 1e-9 per step against converged MuJoCo "
              "(reports/contact-half_cheetah.md). What remains is rounding and the solvers' stopping rules, "
              "amplified over an episode's contact-rich, chaotic gait: single episodes part, the means agree. "
              "The controllers' earlier versions, trained on our smooth penalty contact, reached 39% of their "
              "own return here and DiffOSI's torso mass was 16 kg off: the gap was the contact law.",
    "pybullet": "The articulated model is the same (the URDF twin of our file), but PyBullet has no armature "
                "(0.1 on every leg joint in the file: the feet are much lighter to turn), integrates joint "
                "damping explicitly (hence its substeps) and solves contacts as hard constraints of its own "
                "(lateral friction 1 against MuJoCo's 0.4, no solref/solimp softness). UC-DiffOSI explains "
                "PyBullet's transitions with MuJoCo's contact law: where the contact forces differ, the torso "
                "mass absorbs part of the difference, which is the bias above. Identifying the armature and "
                "MuJoCo's contact parameters jointly with the mass does not remove it "
                "(reports/joint-osi-half_cheetah.md): no solref or solimp makes MuJoCo's soft law a hard "
                f"contact. {JOINT} assumes no contact law: PyBullet's contact and limit impulses are "
                "eliminated from each transition and the armature is identified with the mass. What it cannot "
                "remove is PyBullet's other integration (explicit damping over 5 substeps against our one step "
                "with implicit damping), which leaves the mass a few kilograms low on average (its bias above).",
    "dart": "The articulated model is the same (the URDF twin of our file), but DART has no armature (0.1 on "
            "every leg joint in the file) and solves contacts as hard constraints of its own (an LCP with "
            "lateral friction 0.4, no solref/solimp softness). UC-DiffOSI explains DART's transitions with "
            "MuJoCo's contact law and the file's armature: the torso mass absorbs what differs, which is the "
            "bias above, and identifying the armature and MuJoCo's contact parameters jointly with it does not "
            f"remove it (reports/joint-osi-half_cheetah.md). {JOINT} assumes no contact law (DART's impulses "
            "eliminated, the armature identified). What stays is a convention: DART applies its constraint "
            "impulses through the mass matrix alone, its implicit spring and damper terms taken before them, "
            "while our residual has MuJoCo's (through M + h D); with the file's stiff leg springs that leaves "
            "the mass about 10 kg off in the heavy-torso episodes, where the cheetah squats on its legs. "
            "DART's returns barely depend on the mass fed to the UC (UC-Average above), so the return is "
            "UC-Oracle's all the same.",
}


def cheetah_target_words(e: dict, s: dict, meta: dict) -> str:
    """The report's paragraph on what the target runs and how DiffOSI is fed."""
    if e["name"] == "mujoco":
        target = (f"Target: {e['name']} {e['version']} running `{e['model']}` as gymnasium's HalfCheetah-v5 does: "
                  f"{e['integrator']} at h = {e['timestep']:g} s with {e['passive']} passive forces, 5 physics steps "
                  f"per control step (frame_skip), ctrl = the action on the motors (gears {s['gear']}), its own "
                  f"contact (soft constraints solref {s['solref']}, solimp {s['solimp']}, {s['cone']} friction "
                  f"cones, friction {s['friction'][0]:g}, solver {s['solver']}) and joint limits. Each episode's "
                  "torso mass mu is written to body_mass (its COM and inertia about the COM kept, as our "
                  "body/torso/mass does; then mj_setConst).")
    elif e["name"] == "dart":
        target = (f"Target: {e['name']} {e['version']} running the URDF twin `{e['model']}` on {s['ground']}: "
                  f"{e['integrator']} at h = {e['timestep']:g} s with {e['passive']} damping and springs, 5 "
                  f"physics steps per control step, the task's joint torques by setForces, its own contact "
                  f"({s['contact']}) and the URDF's joint limits; no armature ({s.get('missing_armature', {})} in "
                  "our file). Each episode's torso mass mu is set by BodyNode.setMass (its COM and inertia about "
                  "the COM kept, as our body/torso/mass does).")
    else:
        target = (f"Target: {e['name']} {e['version']} running the URDF twin `{e['model']}` on a plane: "
                  f"{s['substeps']} substeps of {s['substep']:g} s per physics step of {e['timestep']:g} s, "
                  f"{e['passive']} joint damping, 5 physics steps per control step, the task's joint torques by "
                  f"TORQUE_CONTROL, its own contact ({s['ground']}) and the URDF's joint limits; no armature "
                  f"({s.get('missing_armature', {})} in our file). Each episode's torso mass mu is set by "
                  "changeDynamics (its COM and inertia about the COM kept, as our body/torso/mass does).")
    if env := meta.get("environment"):
        target += (" Task half_cheetah_contact: mu = (torso mass, leg armature, friction); the last two are "
                   f"each environment's own settings (ours {env['ours']}, {e['name']} {env[e['name']]}), fed "
                   "to UC-Oracle with the true mass; the policies were trained over all three.")
    return (target + " The policies and DiffOSI run on our engine (its constraint contact, MuJoCo's soft "
            f"constraints); DiffOSI (bounded Levenberg-Marquardt, window {meta['window']}) is fed the target's "
            f"last physics step of each control step. {meta['episodes']} episodes (mu, initial state; seed "
            f"{meta['seed']}) x policy seeds {meta['seeds']} = {meta['episodes'] * len(meta['seeds'])} per method, "
            f"horizon {meta['horizon']} control steps ({meta['horizon'] * 0.05:g} s; the task's episode is 1000).")


def cheetah_markdown(doc: dict, meta: dict, png: str) -> list[str]:
    """The half cheetah's report: returns in the target next to ours, and DiffOSI's torso-mass bias."""
    e, s = doc["engine"], doc["engine"]["settings"]
    E = ENGINE_NAMES[e["name"]]
    lines = [
        f"# Transfer: {meta['task']} controllers from our engine to {e['name']} {e['version']} "
        "(gymnasium HalfCheetah-v5)",
        "",
        f"`{meta['command']}`",
        "",
        cheetah_target_words(e, s, meta),
        "",
        "Return: the sum over control steps of (x' - x) / 0.05 s - 0.1 |a|^2 (HalfCheetah-v5's reward: the "
        "torso's forward speed minus the control cost), computed by the task's own function from each "
        "engine's states. MAE, MARE and bias average |mu fed - mu|, |mu fed - mu| / mu and mu fed - mu (kg) "
        f"over an episode's control steps (the first step is fed the prior, {meta['prior']:g} kg). \"in ours\": "
        "the same episodes and policies in our engine (the source, no gap).",
        "",
    ]
    rows = []
    for method, r in doc["methods"].items():
        t, o = r["summary"], doc["source"][method]
        cells = [fmt(t[k], 2) if k in t else "N/A" for k in ("mae", "mare", "bias")]
        rows.append([method, *cells, fmt(t["score"], 0), fmt(o["score"], 0), f"{t['score'][0] - o['score'][0]:.0f}",
                     fmt(o["mae"], 2) if "mae" in o else "N/A", fmt(o["bias"], 2) if "bias" in o else "N/A"])
    lines += markdown_table(["Approach", "MAE (kg)", "MARE", "bias (kg)", f"return in {E}", "return in ours",
                             f"{E} - ours", "MAE in ours (kg)", "bias in ours (kg)"], rows)
    if "UC-DiffOSI" in doc["methods"]:
        source_ratio = doc["source"]["UC-DiffOSI"]["score"][0] / doc["source"]["UC-Oracle"]["score"][0]
        lines += ["", f"UC-DiffOSI reaches {100 * doc['diffosi_over_oracle']:.1f}% of UC-Oracle's return in {E} "
                  f"({100 * source_ratio:.1f}% in ours; the paper, in its own engine: 3931 vs 3936, 99.9%)."]
    else:
        lines += ["", NO_DIFFOSI]
    if JOINT in doc["methods"]:
        lines += ["", f"{JOINT} reaches {100 * doc['joint_over_oracle']:.1f}% of UC-Oracle's return in {E} "
                  f"(goal {100 * doc['goal']:.0f}%): {JOINT_WORDS}"]
    lines += ["", f"Return per policy seed in {E}:", ""]
    seeds = list(doc["methods"]["DR"]["summary"]["per_seed_score"])
    lines += markdown_table(["Approach", *[f"seed {x}" for x in seeds]],
                            [[m, *[fmt(r["summary"]["per_seed_score"][x], 0) for x in seeds]]
                             for m, r in doc["methods"].items()])
    lines += diffosi_lines(doc, meta, E) + ["", f"![returns and torso-mass estimates]({png})", "",
                                            *armature_lines(doc, E), *dart_contact_lines(doc),
                                            "## Where the gap comes from", "", GAP_WORDS[e["name"]], "",
                                            f"## What {e['name']} ran", ""]
    lines += [f"- {key}: {value}" for key, value in s.items()]
    return lines


def dart_contact_lines(doc: dict) -> list[str]:
    """The collision shapes, coefficients and the friction DART applies (contact.dart_cheetah_contact)."""
    if "dart_contact" not in doc:
        return []
    c = doc["dart_contact"]
    return ["## DART's contact, as loaded and as measured", "",
            *[f"- {body}: {shapes}" for body, shapes in c["shapes"].items()],
            "- (friction, restitution) per skeleton: " + "; ".join(
                f"{skel} {', '.join(f'({mu:g}, {e:g})' for mu, e in pairs)}"
                for skel, pairs in c["friction_restitution"].items()),
            f"- collision detector: {c['detector']}",
            f"- sliding: the cheetah settled on its floor, then pushed to 2 m/s along x, the horizontal force on it "
            f"over the total normal force over the next 100 steps of 1 ms (median): {c['sliding_friction']:.4f}. "
            "DART applies the smaller coefficient, 0.4, our file's.", "",
            "The shapes are the URDF twin's (each capsule of our file a cylinder and its two end spheres, the same "
            "surface), restitution 0, friction 0.4: the contact geometry and coefficients are the ones we think.", ""]


def armature_lines(doc: dict, E: str) -> list[str]:
    """What the file's leg armature, which the target lacks, is worth: the same episodes and
    policies in ours with and without it, and in the target."""
    if "without_armature" not in doc:
        return []
    rows = []
    for method, without in doc["without_armature"].items():
        ours, target = doc["source"][method]["score"][0], doc["methods"][method]["summary"]["score"][0]
        rows.append([method, f"{ours:.0f}", f"{without['score'][0]:.0f}", f"{target:.0f}",
                     f"{without['score'][0] - ours:.0f}", f"{target - without['score'][0]:.0f}"])
    return ["## What the missing armature costs", "",
            f"Mean return of the same episodes and policies: in ours (the file's armature 0.1 on the six leg "
            f"joints), in ours with every armature 0 (`{NO_ARMATURE}`, our contact), and in {E} (no armature). "
            f"The first difference is what the armature is worth in our physics; the second is what remains "
            f"{E}'s own (its contact, limits and implicit passive forces).", "",
            *markdown_table(["Approach", "ours", "ours without armature", E, "armature's worth in ours",
                             f"{E} - ours without armature"], rows), "",
            f"{E} 6.20 has no armature (no joint property, no dartpy setter). Raising each joint's damping by "
            f"a / h and adding the torque a / h v puts it into {E}'s implicit step exactly (a contact-free step "
            f"equals ours to 5e-16), but {E}'s contact and joint-limit impulses act through its mass matrix "
            f"without it; run so, the cheetah's returns fell further, so the target is left without armature, "
            f"as a user of {E} would run it.", "",
            f"The row `{NO_ARMATURE}` of the one-transition table above is DiffOSI (its model with the file's "
            f"armature) on our own engine without armature: it is biased and at a bound as in {E}, so the "
            "missing armature alone puts DiffOSI's mass at a bound, without any contact law of "
            f"{E}'s.", ""]


JOINT_WORDS = ("DiffOSI identifying the torso mass jointly with the leg armature, with the target's contact, "
               "limit and dry-friction impulses unknown: each transition's residual is the generalized force our "
               "smooth dynamics leaves unexplained, less any impulse on a body within 2 cm of touching or on a "
               "joint within 0.02 rad of its range's ends (eliminated in closed form), so no contact law is "
               "assumed (`OnlineOsi(Task(\"half_cheetah_contact\"), constraints=\"unknown\")`, window "
               "--joint-window transitions).")

NO_DIFFOSI = ("No UC-DiffOSI (the paper's residual through our contact law) here: `python -m harness joint-osi` "
              "shows that identifying the armature and the contact's parameters that way leaves the mass 11-18 kg "
              f"off in PyBullet and DART. {JOINT} feeds the UC the torso mass and the leg armature identified "
              "with the target's constraints unknown, and the friction's prior (the middle of its range).")


def diffosi_lines(doc: dict, meta: dict, E: str) -> list[str]:
    """The half cheetah report's section on DiffOSI's torso mass (none without UC-DiffOSI)."""
    if "UC-DiffOSI" not in doc["methods"]:
        return []
    e = doc["engine"]
    ours = {(x["policy_seed"], x["episode"]): x for x in doc["source_diffosi"]}
    fits = {name: bias_fit(eps) for name, eps in ((E, doc["methods"]["UC-DiffOSI"]["episodes"]),
                                                   ("ours", doc["source_diffosi"]))}
    lines = ["", f"## DiffOSI's torso mass under {E}'s contact", "",
              f"Per episode: the true torso mass, the mean mass fed to the UC and its bias in {E} and in ours, "
              f"the final estimate in {E}, and the returns of UC-DiffOSI and UC-Oracle in {E}. A least-squares "
              "line through the mean fed mass against the true mass: "
              + "; ".join(f"{n} {a:.3f} mu {b:+.2f} kg" for n, (a, b) in fits.items()) + ".", ""]
    oracle = {(x["policy_seed"], x["episode"]): x for x in doc["methods"]["UC-Oracle"]["episodes"]}
    rows = []
    for x in doc["methods"]["UC-DiffOSI"]["episodes"]:
        key = (x["policy_seed"], x["episode"])
        rows.append([*key, f"{x['mu']:.2f}", f"{x['mu'] + x['bias']:.2f}", f"{x['bias']:+.2f}",
                     f"{100 * x['bias'] / x['mu']:+.1f}%", f"{x['mu_hat_final']:.2f}", x["steps_at_bound"],
                     f"{ours[key]['bias']:+.3f}", f"{x['score']:.0f}", f"{oracle[key]['score']:.0f}"])
    lines += markdown_table(["policy seed", "episode", "mu (kg)", "mean fed", "bias", "bias / mu", "final",
                             "steps at a bound", "bias in ours", "UC-DiffOSI return", "UC-Oracle return"], rows)
    lines += ["", "One transition at a time (window 1, from the prior, on our model) along the UC-Oracle episodes of "
              f"policy seed {meta['seeds'][0]}, split by whether {E}'s physics step had {CONSTRAINED[e['name']]} "
              "(\"free\": none; \"all\": our engine, not split): the relative error "
              "(mu_hat - mu) / mu of the estimates, and the share at a bound of [1, 50] kg.", ""]
    rows = [[name, kind, r["count"], " / ".join(f"{100 * x:+.2g}%" for x in r["relative_error_quartiles"]),
             f"{100 * r['at_bound']:.1f}%"]
            for name, kinds in doc["single_transition"].items() for kind, r in kinds.items()]
    lines += markdown_table(["engine", "transitions", "count", "relative error: quartiles 25 / 50 / 75",
                             "at a bound"], rows)
    return lines


def plot(path: Path, doc: dict, meta: dict) -> Path:
    """Left: task performance per episode and method (open circles: the same episode in our
    engine for UC-DiffOSI); middle: mu fed by DiffOSI vs true mu over the kept episodes;
    right: per episode, the mean mu fed by DiffOSI against the true mu, in the target and in
    our engine (on the diagonal: no bias)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spec = TASKS[meta["task"]]
    identified = "UC-DiffOSI" in doc["methods"]  # else the performance panel alone
    fig, axes = plt.subplots(1, 3 if identified else 1, figsize=(15 if identified else 6, 4), dpi=110,
                             squeeze=False)
    left = axes[0, 0]
    for i, (method, r) in enumerate(doc["methods"].items()):
        scores = [e["score"] for e in r["episodes"]]
        jitter = np.linspace(-0.25, 0.25, len(scores))
        left.scatter(i + jitter, scores, s=8, alpha=0.6)
        left.errorbar(i, *r["summary"]["score"], fmt="k_", capsize=6, ms=20)
        left.errorbar(i + 0.35, *doc["source"][method]["score"], fmt="o", mfc="none", color="gray", capsize=4,
                      label=f"{SOURCE} (mean ± std)" if i == 0 else None)
    left.set_xticks(range(len(doc["methods"])), list(doc["methods"]))
    left.set(title=f"{doc['target']}: task performance per episode", ylabel=spec.score)
    if meta["task"] == "cartpole":
        left.set_ylim(-10, meta["horizon"] * 1.05)
    left.legend(fontsize=7)
    if identified:
        diffosi_panels(axes[0, 1], axes[0, 2], doc, spec)
    for ax in axes[0]:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path


def diffosi_panels(middle, right, doc: dict, spec: TaskSpec) -> None:
    """mu fed by DiffOSI over the kept episodes; its mean per episode against the true mu."""
    identified = doc["methods"]["UC-DiffOSI"]["episodes"]
    for e in (e for e in identified if "mu_fed" in e):
        line, = middle.plot(e["mu_fed"], lw=1.2, label=f"episode {e['episode']}: mu_hat")
        middle.axhline(e["mu"], color=line.get_color(), ls="--", lw=0.8)
    middle.set(title="UC-DiffOSI: mu fed to the UC (dashed: true mu)", xlabel="control step", ylabel=spec.mu,
               ylim=spec.mu_limits)
    middle.legend(fontsize=7)
    for name, episodes in ((doc["target"], identified), (SOURCE, doc["source_diffosi"])):
        right.scatter([e["mu"] for e in episodes], [e["mu"] + e["bias"] for e in episodes], s=12, label=name)
    right.plot(spec.mu_limits, spec.mu_limits, "k:", lw=0.8)
    right.set(title="UC-DiffOSI: mean mu fed per episode", xlabel=f"true {spec.mu}", ylabel=f"mean fed {spec.mu}",
              xlim=spec.mu_limits, ylim=spec.mu_limits)
    right.legend(fontsize=7)


def summary_blocks(docs: dict) -> dict:
    """{environment: {method: summary}}: our engine (the source) first, then every target."""
    source = next(iter(docs.values()))["source"]
    return {f"{SOURCE} (source, no gap)": source,
            **{t: {m: r["summary"] for m, r in d["methods"].items()} for t, d in docs.items()}}


def summary_markdown(docs: dict, meta: dict, png: str) -> list[str]:
    identified = all(d["meets_goal"] is not None for d in docs.values())
    rows = []
    for target, methods in summary_blocks(docs).items():
        for method, s in methods.items():
            rows.append([target, method, fmt(s["mae"]) if "mae" in s else "N/A", fmt(s["score"], 1),
                         f"{100 * s['score'][0] / methods['UC-Oracle']['score'][0]:.1f}%"])
    lines = [f"# Transfer summary: {meta['task']} controllers from our engine to every reference engine",
             "", f"`{meta['command']}`", "",
             f"Targets left as a user would leave them{gap_words(meta)}; {meta['episodes']} episodes x policy "
             f"seeds {meta['seeds']} per method and target. Per-target reports: "
             + ", ".join(f"[{t}]({stem}.md)" for t, stem in meta["stems"].items()) + ".", ""]
    lines += markdown_table(["Target", "Approach", "MAE (mu)", "Task performance", "of UC-Oracle"], rows)
    lines += ["", "UC-DiffOSI against its goal (a share of UC-Oracle in the same target): "
              + "; ".join(f"{t} {100 * d['diffosi_over_oracle']:.1f}% (goal {100 * d['goal']:.0f}%: "
                          f"{'meets' if d['meets_goal'] else 'misses'})" for t, d in docs.items()) + "."
              if identified else NO_DIFFOSI]
    if all("joint_over_oracle" in d for d in docs.values()):
        lines += ["", f"{JOINT} against the same goal: "
                  + "; ".join(f"{t} {100 * d['joint_over_oracle']:.1f}% "
                              f"({'meets' if d['joint_meets_goal'] else 'misses'})" for t, d in docs.items())
                  + f". {JOINT_WORDS}"]
    if identified:
        lines += ["", "Where a target misses, its report lists the episodes where UC-DiffOSI and UC-Oracle part."]
    lines += ["", f"![task performance per target]({png})"]
    return lines


def summary_plot(path: Path, docs: dict, score: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    blocks = summary_blocks(docs)
    fig, ax = plt.subplots(figsize=(8, 4), dpi=110)
    methods = list(next(iter(blocks.values())))
    width = 0.8 / len(methods)
    for i, method in enumerate(methods):
        stats = [block[method]["score"] for block in blocks.values()]
        ax.bar(np.arange(len(blocks)) + (i - (len(methods) - 1) / 2) * width, [s[0] for s in stats], width,
               yerr=[s[1] for s in stats], capsize=3, label=method)
    ax.set_xticks(range(len(blocks)), list(blocks))
    ax.set(title="Task performance per environment (mean ± std over episodes)", ylabel=score)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path


def parse_unmodelled(text: str) -> list[str]:
    effects = [u.strip() for u in text.split(",") if u.strip()]
    unknown = sorted(set(effects) - set(UNMODELLED))
    if unknown:
        raise ValueError(f"unknown unmodelled effects {unknown}; choose from {', '.join(UNMODELLED)}")
    return [u for u in UNMODELLED if u in effects]


def command(args, unmodelled: list[str]) -> str:
    parts = [f"python -m harness transfer --task {args.task} --target {args.target}"]
    defaults = {"episodes": None, "seeds": "0,1,2", "seed": 0, "horizon": None, "window": 4, "joint_window": 20,
                "policies": None}
    parts += [f"--{k.replace('_', '-')} {getattr(args, k)}" for k, d in defaults.items() if getattr(args, k) != d]
    if unmodelled:
        parts.append(f"--unmodelled {','.join(unmodelled)}")
        if "friction" in unmodelled and args.friction != 1.0:
            parts.append(f"--friction {args.friction:g}")
    return " ".join(parts)


def check_task(args, unmodelled: list[str]) -> list[str]:
    """The targets of the run; ValueError if the task does not go to --target or take --unmodelled."""
    if args.task == "wiping":
        if unmodelled:
            raise ValueError("--unmodelled applies to the cartpole, not wiping")
        return list(wiping_transfer.TARGETS) if args.target == "all" else [args.target]
    spec = TASKS[args.task]
    if unmodelled and not spec.unmodelled:
        raise ValueError(f"--unmodelled applies to the cartpole, not {args.task}")
    if args.target != "all" and args.target not in spec.targets:
        raise ValueError(f"{args.task} transfers to {', '.join(spec.targets)}, not {args.target}")
    return list(spec.targets) if args.target == "all" else [args.target]


def run(args) -> int:
    """One task, or (--task all) every task in turn, each with its summary."""
    if args.task != "all":
        return run_task(args)
    status = 0
    for task in ALL:
        status = max(status, run_task(argparse.Namespace(**{**vars(args), "task": task})))
    return status


def run_task(args) -> int:
    try:
        unmodelled = parse_unmodelled(args.unmodelled)
        targets = check_task(args, unmodelled)
    except ValueError as e:
        print(f"transfer: {e}")
        return 2
    if args.task == "wiping":
        line = f"python -m harness transfer --task wiping --target {args.target} --runs {args.runs}"
        wiping_transfer.run_targets(targets, args.runs, args.seed, args.out,
                                    line + (f" --seed {args.seed}" if args.seed else ""))
        return 0
    run_targets(args, targets, run_batch, unmodelled)
    return 0


def run_targets(args, targets: list[str], batch=run_batch, unmodelled: list[str] = ()) -> None:
    """The reports of one task: our engine (the source), then each target, then the summary;
    `batch` gives a (target, method, policy seed)'s episodes (run here, or a sweep's)."""
    unmodelled = list(unmodelled)
    setup = Setup(args, unmodelled)
    suffix = "".join(f"-{u}" for u in unmodelled)
    meta = {"task": args.task, "command": command(args, unmodelled), "episodes": len(setup.mu),
            "seeds": setup.seeds, "seed": args.seed, "horizon": setup.horizon, "window": setup.window,
            "joint_window": setup.joint_window,
            "unmodelled": unmodelled, "friction": setup.friction, "delay": setup.delay,
            "prior": float(setup.prior[0]), "environment": setup.spec.environment,
            "stems": {t: f"transfer-{args.task}-{t}{suffix}" for t in targets}}
    print(f"transfer: {args.task} in our engine (the source: no gap)", flush=True)
    source = run_methods(setup, SOURCE, 0, batch)
    write_report = cheetah_markdown if args.task.startswith("half_cheetah") else markdown
    docs = {}
    for target in targets:
        print(f"transfer: {args.task} -> {target}{gap_words(meta)}", flush=True)
        doc = docs[target] = run_target(setup, target, args.plot_episodes, source, batch)
        stem = args.out / meta["stems"][target]
        png = plot(stem.with_suffix(".png"), doc, meta)
        write_json(stem.with_suffix(".json"), {"meta": meta, **doc})
        write_markdown(stem.with_suffix(".md"), write_report(doc, meta, png.name))
        if doc["diffosi_over_oracle"] is not None:
            print(f"  UC-DiffOSI / UC-Oracle = {100 * doc['diffosi_over_oracle']:.1f}%")
        print(f"  wrote {stem}.md, .json, .png")
    if len(targets) > 1:
        stem = args.out / f"transfer-{args.task}-summary{suffix}"
        png = summary_plot(stem.with_suffix(".png"), docs, setup.spec.score)
        summary = {t: {"diffosi_over_oracle": d["diffosi_over_oracle"], "meets_goal": d["meets_goal"],
                       **{k: d[k] for k in ("joint_over_oracle", "joint_meets_goal") if k in d},
                       **{m: r["summary"] for m, r in d["methods"].items()}} for t, d in docs.items()}
        write_json(stem.with_suffix(".json"), {"meta": meta, "source": next(iter(docs.values()))["source"],
                                               "targets": summary})
        write_markdown(stem.with_suffix(".md"), summary_markdown(docs, meta, png.name))
        print(f"wrote {stem}.md, .json, .png")
