"""Sweeps on Ray: train policies over seeds and evaluate them in our engine and the reference engines.

A sweep is a TOML file naming the work (sweeps/*.toml has examples):

    name = "cartpole-seeds"          # the default output directory: sweeps/out/<name>/

    [train]                          # PPO: every task x kind x seed
    tasks = ["cartpole"]             # the transfer tasks, or "quadruped" (training only, for now)
    kinds = ["uc", "dr"]
    seeds = [0, 1, 2, 3, 4]
    steps = 300000                   # environment steps (default: the shipped policies' budget)

    [transfer]                       # every task x target x method x policy seed
    tasks = ["cartpole"]
    targets = ["ours", "mujoco", "pybullet", "dart"]   # "ours": our engine, no transfer gap
    methods = ["DR", "UC-DiffOSI", "UC-Oracle"]        # default: the task's (harness transfer)
    policy_seeds = [0, 1, 2, 3, 4]
    policies = "trained"             # this sweep's [train] results, or "shipped" (policies/<task>/)
    episodes = 20                    # per policy seed (default: the task's)
    seed = 0                         # the episodes' seed
    window = 4                       # DiffOSI's window
    horizon = 500                    # control steps per episode (default: the task's)

Each unit of work (one training run; one method with one policy seed on one target, every
episode) is a pure function of its parameters: the same spec gives the same numbers run
serially, on a local Ray runtime or on a cluster. The driver writes each unit's result to
<out>/units/<unit>.json as it arrives (workers need the diffosi wheel and the reference
engines, not this checkout's files), and trained policies to <out>/policies/<task>/; a
rerun skips finished units. A unit that raises is retried (--retries), then reported in
<out>/failed.json, with the units that needed it; the exit status is then 1. --report
writes into <out>/reports/ harness transfer's reports from the transfer units, and `diffosi
reproduce`'s tables over the trained policies (UC and DR of seeds 0..n-1 of the cartpole or
the half cheetah): the same files the main job writes, over the sweep's seeds.

    python -m harness sweep sweeps/small.toml                  # local Ray, every core
    python -m harness sweep sweeps/small.toml --workers 1      # local Ray, one worker
    python -m harness sweep sweeps/small.toml --address 10.0.0.5:6379   # a running cluster
    python -m harness sweep sweeps/small.toml --serial         # no Ray: in this process
    python -m harness sweep sweeps/small.toml --report         # and the transfer reports
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import traceback
from dataclasses import dataclass
from pathlib import Path

from harness.engines.base import REPO
from harness.report import jsonable

OUT = REPO / "sweeps" / "out"
KINDS = ("uc", "dr")
TRAIN_KEYS = {"tasks", "kinds", "seeds", "steps"}
TRANSFER_KEYS = {"tasks", "targets", "methods", "policy_seeds", "policies", "episodes", "seed", "window",
                 "horizon", "plot_episodes"}
# Tasks a sweep trains without transferring them yet (issue 41: the quadruped's transfer is to come).
TRAIN_ONLY = ("quadruped",)
TABLES = {"cartpole": "cartpole", "half_cheetah": "cheetah"}  # diffosi reproduce's name of a task's tables
PLOT_EPISODES = 3  # episodes per unit that keep their fed-mu trace (harness transfer plots them)
# What a worker does not need of the checkout (it needs harness/ and reference_models/).
WORKER_EXCLUDES = [".git", ".venv", "target", "reports", "policies", "sweeps", "src", "tests", "benches",
                   "examples", "fuzz", "bindings", "scripts", "*.pyc", "__pycache__"]


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("spec", type=Path, help="the sweep's TOML file")
    ap.add_argument("--out", type=Path, default=None, help="output directory (default sweeps/out/<name>/)")
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--address", default=None, help="a running Ray cluster's address (ray start --head)")
    where.add_argument("--serial", action="store_true", help="run every unit in this process, without Ray")
    ap.add_argument("--workers", type=int, default=os.cpu_count(),
                    help="the local Ray runtime's CPUs (default: every core)")
    ap.add_argument("--retries", type=int, default=2, help="retries of a unit that raises (default %(default)s)")
    ap.add_argument("--report", action="store_true",
                    help="then write the main job's transfer reports and tables into <out>/reports/")


# ---- the spec


@dataclass(frozen=True)
class Unit:
    """One unit of work: `kind` "train" or "transfer" and its parameters (JSON values)."""

    kind: str
    params: tuple  # sorted (key, value) pairs

    @property
    def p(self) -> dict:
        return dict(self.params)

    @property
    def name(self) -> str:
        p = self.p
        if self.kind == "train":
            return f"train-{p['task']}-{p['policy']}-seed{p['seed']}"
        return f"transfer-{p['task']}-{p['target']}-{p['method']}-seed{p['policy_seed']}"

    def needs(self) -> list[Unit]:
        """The training units whose policies this unit runs (none for shipped policies)."""
        p = self.p
        if self.kind == "train" or p["policies"] != "trained":
            return []
        return [unit("train", task=p["task"], policy=k, seed=p["policy_seed"], steps=p["steps"]) for k in KINDS]


def unit(kind: str, **params) -> Unit:
    return Unit(kind, tuple(sorted(params.items())))


def load_spec(path: Path) -> tuple[str, list[Unit]]:
    """The sweep's name and units (training first); ValueError naming what is wrong."""
    from harness import transfer

    try:
        spec = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise ValueError(f"{path}: {e}") from e
    unknown = set(spec) - {"name", "train", "transfer"}
    if unknown or "name" not in spec:
        raise ValueError(f"{path}: a sweep has a name, [train] and/or [transfer]; unknown: {sorted(unknown)}")

    def section(name: str, keys: set) -> dict:
        s = spec.get(name, {})
        if set(s) - keys:
            raise ValueError(f"{path}: [{name}] does not take {sorted(set(s) - keys)} (it takes {sorted(keys)})")
        return s

    train, move = section("train", TRAIN_KEYS), section("transfer", TRANSFER_KEYS)
    trainable = (*transfer.TASKS, *TRAIN_ONLY)
    for task in train.get("tasks", []):
        if task not in trainable:
            raise ValueError(f"{path}: [train] task {task!r}: one of {', '.join(trainable)}")
    if bad := set(train.get("kinds", KINDS)) - set(KINDS):
        raise ValueError(f"{path}: [train] kinds are {' and '.join(KINDS)}, not {sorted(bad)}")
    units = [unit("train", task=t, policy=k, seed=int(s), steps=train.get("steps"))
             for t in train.get("tasks", []) for k in train.get("kinds", KINDS) for s in train.get("seeds", [0])]
    for task in move.get("tasks", []):
        if task not in transfer.TASKS:
            raise ValueError(f"{path}: [transfer] task {task!r}: one of {', '.join(transfer.TASKS)}")
        spec_t = transfer.TASKS[task]
        targets = move.get("targets", [transfer.SOURCE, *spec_t.targets])
        if bad := set(targets) - {transfer.SOURCE, *spec_t.targets}:
            raise ValueError(f"{path}: {task} transfers to {transfer.SOURCE}, {', '.join(spec_t.targets)}; not {bad}")
        methods = move.get("methods", list(spec_t.methods))
        if bad := set(methods) - set(spec_t.methods):
            raise ValueError(f"{path}: {task}'s methods are {', '.join(spec_t.methods)}; not {bad}")
        policies = move.get("policies", "trained")
        if policies not in ("trained", "shipped"):
            raise ValueError(f"{path}: policies = 'trained' (this sweep's) or 'shipped', not {policies!r}")
        seeds = [int(s) for s in move.get("policy_seeds", [0, 1, 2])]
        if policies == "shipped":
            files = [transfer.POLICIES / task / f"{k}-seed{s}.json" for k in KINDS for s in seeds]
            if missing := [str(f) for f in files if not f.exists()]:
                raise ValueError(f"{path}: no shipped policies {missing}")
        common = dict(task=task, policies=policies, episodes=int(move.get("episodes", spec_t.episodes)),
                      seed=int(move.get("seed", 0)), window=int(move.get("window", 4)),
                      horizon=move.get("horizon"), plot_episodes=int(move.get("plot_episodes", PLOT_EPISODES)),
                      steps=train.get("steps") if policies == "trained" else None)
        units += [unit("transfer", target=target, method=method, policy_seed=s, **common)
                  for target in targets for method in methods for s in seeds]
    trained = {u for u in units if u.kind == "train"}
    for u in units:
        if missing := [n.name for n in u.needs() if n not in trained]:
            raise ValueError(f"{path}: {u.name} runs policies [train] does not make: {missing}")
    return spec["name"], units


# ---- the units (run by a worker: they read and write no file of the sweep)


def execute(u: Unit, *inputs: dict) -> dict:
    """A unit's output: {"result": ... (a pure function of the unit), "timing": {"seconds": ...}}.
    A transfer unit's `inputs` are the outputs of its uc and dr training units (or the shipped
    policies in that shape, `shipped`)."""
    start = time.perf_counter()
    out = train_unit(u.p) if u.kind == "train" else {"result": transfer_unit(u.p, inputs), "timing": {}}
    out["timing"]["seconds"] = time.perf_counter() - start
    return out


def train_unit(p: dict) -> dict:
    """PPO: the policy (its file's content but the wall time, which goes to the timing), the
    learning curve and the weights' SHA-256."""
    import hashlib

    import diffosi

    task = diffosi.Task(p["task"])
    policy, curve = diffosi.Policy.train(task, p["policy"], seed=p["seed"], steps=p["steps"])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "policy.json"
        policy.save(path)
        doc = json.loads(path.read_text())
    wall = doc["training"].pop("wall_seconds")
    weights = hashlib.sha256(policy.parameters().tobytes()).hexdigest()
    result = {"final_metric": curve[-1]["mean_metric"] if curve else None, "curve": curve,
              "parameters_sha256": weights, "policy": doc}
    return {"result": result, "timing": {"policy_wall_seconds": wall}}


def policy_text(output: dict) -> str:
    """A training unit's policy file, as `diffosi train` writes it (its wall time put back)."""
    doc = json.loads(json.dumps(output["result"]["policy"]))
    doc["training"]["wall_seconds"] = output["timing"]["policy_wall_seconds"]
    return json.dumps(doc)


def transfer_unit(p: dict, inputs: tuple) -> dict:
    """harness transfer's episodes of one method with one policy seed on one target."""
    from harness import transfer

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for kind, output in zip(KINDS, inputs):
            (folder / f"{kind}-seed{p['policy_seed']}.json").write_text(policy_text(output))
        setup = transfer.Setup(transfer_args(p, [p["policy_seed"]], folder), [])
        episodes = transfer.run_batch(setup, p["target"], p["method"], p["policy_seed"], p["plot_episodes"])
    return {"episodes": episodes}


def transfer_args(p: dict, seeds: list[int], policies: Path, out: Path | None = None,
                  target: str = "all") -> argparse.Namespace:
    """harness transfer's arguments for a transfer unit's parameters."""
    from harness import transfer

    ap = argparse.ArgumentParser()
    transfer.add_arguments(ap)
    argv = ["--task", p["task"], "--target", target, "--seeds", ",".join(map(str, seeds)),
            "--episodes", str(p["episodes"]), "--seed", str(p["seed"]), "--window", str(p["window"]),
            "--plot-episodes", str(p["plot_episodes"]), "--policies", str(policies)]
    if p["horizon"] is not None:
        argv += ["--horizon", str(p["horizon"])]
    if out is not None:
        argv += ["--out", str(out)]
    return ap.parse_args(argv)


# ---- the driver


class Store:
    """The sweep's directory: units/<unit>.json ({"kind", "unit": parameters, "result",
    "timing"}: the result is the same wherever the unit ran, the timing is not), trained
    policies in policies/<task>/<kind>-seed<s>.json, failed.json."""

    def __init__(self, out: Path):
        self.out = out
        (out / "units").mkdir(parents=True, exist_ok=True)

    def path(self, u: Unit) -> Path:
        return self.out / "units" / f"{u.name}.json"

    def load(self, u: Unit) -> dict | None:
        """A finished unit's output ({"result", "timing"}), if its file holds this unit's parameters."""
        try:
            doc = json.loads(self.path(u).read_text())
        except (OSError, json.JSONDecodeError):
            return None
        if doc.get("kind") != u.kind or doc.get("unit") != u.p:
            return None
        return {"result": doc["result"], "timing": doc["timing"]}

    def save(self, u: Unit, output: dict) -> None:
        path = self.path(u)
        partial = path.with_suffix(".tmp")
        partial.write_text(json.dumps(jsonable({"kind": u.kind, "unit": u.p, **output}), indent=1) + "\n")
        partial.replace(path)  # atomic: a unit's file is whole or absent
        if u.kind == "train":
            policy = self.out / "policies" / u.p["task"] / f"{u.p['policy']}-seed{u.p['seed']}.json"
            policy.parent.mkdir(parents=True, exist_ok=True)
            policy.write_text(policy_text(output))


class Progress:
    """A one-line bar on stderr: units done of all, failures, elapsed time."""

    def __init__(self, total: int, done: int):
        self.total, self.done, self.failed, self.start = total, done, 0, time.perf_counter()
        self.show()

    def tick(self, failed: bool = False) -> None:
        self.done += 1
        self.failed += failed
        self.show()

    def show(self) -> None:
        width = 30
        filled = width * self.done // max(self.total, 1)
        failed = f", {self.failed} failed" if self.failed else ""
        print(f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} units{failed} "
              f"{time.perf_counter() - self.start:.0f} s", end="", file=sys.stderr, flush=True)


def shipped(u: Unit) -> list[dict]:
    """A transfer unit's shipped uc and dr policies, read here (workers need no checkout), in
    the shape of a training unit's output."""
    from harness import transfer

    outputs = []
    for kind in KINDS:
        doc = json.loads((transfer.POLICIES / u.p["task"] / f"{kind}-seed{u.p['policy_seed']}.json").read_text())
        wall = doc["training"].pop("wall_seconds")
        outputs.append({"result": {"policy": doc}, "timing": {"policy_wall_seconds": wall}})
    return outputs


def inputs(u: Unit, results: dict) -> list:
    """What execute(u, ...) takes after u: its needs' results (or Ray's refs to them)."""
    if u.kind == "transfer" and u.p["policies"] == "shipped":
        return shipped(u)
    return [results[n] for n in u.needs()]


def run_serial(units: list[Unit], store: Store, results: dict, progress: Progress, retries: int) -> dict:
    """Every unit not in `results`, in order, in this process; {unit name: error}."""
    failed = {}
    for u in units:
        if u in results:
            continue
        if blocked := [n.name for n in u.needs() if n.name in failed]:
            failed[u.name] = f"not run: needs {blocked}"
            progress.tick(failed=True)
            continue
        for attempt in range(retries + 1):
            try:
                results[u] = execute(u, *inputs(u, results))
                store.save(u, results[u])
                break
            except Exception:  # noqa: BLE001 (a unit's failure is reported, the sweep goes on)
                if attempt == retries:
                    failed[u.name] = traceback.format_exc()
        progress.tick(failed=u.name in failed)
    return failed


def run_ray(units: list[Unit], store: Store, results: dict, progress: Progress, args) -> dict:
    """Every unit not in `results` as a Ray task (a unit's needs are its arguments, so Ray runs it
    after them); results are saved as they arrive. {unit name: error}."""
    import ray

    # Workers run in a copy of the harness and the models (not this checkout), with this venv's
    # packages (the diffosi wheel, the reference engines) on every node.
    runtime = {"working_dir": str(REPO), "excludes": WORKER_EXCLUDES}
    if args.address:
        ray.init(address=args.address, runtime_env=runtime, log_to_driver=False)
    else:
        ray.init(num_cpus=args.workers, runtime_env=runtime, include_dashboard=False, log_to_driver=False)
    try:
        task = ray.remote(max_retries=args.retries, retry_exceptions=True)(execute)
        refs, known = {}, dict(results)  # known: a result, or Ray's ref to it
        for u in units:
            if u not in results:
                refs[u] = known[u] = task.remote(u, *inputs(u, known))
        pending, by_ref, failed = list(refs.values()), {r: u for u, r in refs.items()}, {}
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            u = by_ref[ready[0]]
            try:
                results[u] = ray.get(ready[0])
                store.save(u, results[u])
            except Exception as e:  # noqa: BLE001 (reported; its dependents fail with it)
                blocked = [n.name for n in u.needs() if n.name in failed]
                failed[u.name] = f"not run: needs {blocked}" if blocked else str(e)
            progress.tick(failed=u.name in failed)
        return failed
    finally:
        ray.shutdown()


def report(name: str, units: list[Unit], store: Store) -> None:
    """harness transfer's reports from the transfer units, one run_task per task."""
    from harness import transfer

    tasks = {}
    for u in units:
        if u.kind == "transfer":
            tasks.setdefault(u.p["task"], []).append(u)
    for task, group in tasks.items():
        p = group[0].p
        seeds = sorted({u.p["policy_seed"] for u in group})
        folder = store.out / "policies" / task if p["policies"] == "trained" else transfer.POLICIES / task
        results = {(u.p["target"], u.p["method"], u.p["policy_seed"]): store.load(u)["result"]["episodes"]
                   for u in group}

        def batch(setup, target, method, seed, plot_episodes):
            return [e if k < plot_episodes else {x: v for x, v in e.items() if x != "mu_fed"}
                    for k, e in enumerate(results[(target, method, seed)])]

        spec = transfer.TASKS[task]
        targets = [t for t in spec.targets if t in {t for t, _, _ in results}]
        missing = set(spec.methods) - {m for _, m, _ in results}
        if missing or transfer.SOURCE not in {t for t, _, _ in results}:
            print(f"sweep {name}: no report for {task}: it needs every method ({sorted(spec.methods)}) "
                  f"in {transfer.SOURCE} and the targets")
            continue
        print(f"sweep {name}: the transfer reports of {task} over policy seeds {seeds}")
        target = "all" if targets == list(spec.targets) else targets[0]
        transfer.run_targets(transfer_args(p, seeds, folder, store.out / "reports", target), targets, batch)


def tables(units: list[Unit], store: Store) -> None:
    """`diffosi reproduce`'s tables of each task whose UC and DR the sweep trained for seeds
    0..n-1, over those n models (the main job's files: Tables 1 and 4 and the window study for
    the cartpole, Table 2 and its window study for the half cheetah). Their UC-MLP rows use the
    shipped UC-MLP weights, copied next to the sweep's policies."""
    from harness import transfer

    binary = REPO / "target" / "release" / "diffosi"
    trained: dict = {}
    for u in units:
        if u.kind == "train":
            trained.setdefault(u.p["task"], set()).add((u.p["policy"], u.p["seed"]))
    for task, made in trained.items():
        n = len({seed for _, seed in made})
        if task not in TABLES or made != {(kind, s) for kind in KINDS for s in range(n)}:
            print(f"sweep: no tables for {task}: they need UC and DR of seeds 0..n-1 of cartpole or half_cheetah")
            continue
        if not binary.exists():
            raise SystemExit(f"sweep: {binary} is missing: `make setup` builds it")
        for weights in (transfer.POLICIES / task).glob("uc-mlp*.json"):
            shutil.copyfile(weights, store.out / "policies" / task / weights.name)
        print(f"sweep: diffosi reproduce {TABLES[task]} over the sweep's {n} models of each kind", flush=True)
        subprocess.run([str(binary), "reproduce", TABLES[task], "--policies", str(store.out / "policies"),
                        "--reports", str(store.out / "reports"), "--models", str(n)], check=True)


def run(args) -> int:
    try:
        name, units = load_spec(args.spec)
    except ValueError as e:
        print(f"sweep: {e}")
        return 2
    store = Store(args.out or OUT / name)
    results = {u: r for u in units if (r := store.load(u)) is not None}
    print(f"sweep {name}: {len(units)} units, {len(results)} done before; results in {store.out}", flush=True)
    progress = Progress(len(units), len(results))
    start = time.perf_counter()
    if args.serial:
        failed = run_serial(units, store, results, progress, args.retries)
    else:
        failed = run_ray(units, store, results, progress, args)
    print(file=sys.stderr)
    (store.out / "failed.json").write_text(json.dumps(failed, indent=1) + "\n")
    where = "serially" if args.serial else (f"on {args.address}" if args.address else f"on {args.workers} workers")
    print(f"sweep {name}: {len(units) - len(failed)} of {len(units)} units done {where} in "
          f"{time.perf_counter() - start:.1f} s", flush=True)
    for unit_name, error in failed.items():
        print(f"  FAILED {unit_name}: {error.strip().splitlines()[-1]}")
    if failed:
        return 1
    if args.report:
        report(name, units, store)
        tables(units, store)
    return 0
