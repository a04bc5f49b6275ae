"""harness sweep: the same spec gives the same results serially, on a local Ray runtime and on a
real Ray cluster; a rerun skips finished units and writes the main job's reports from them; a
failing unit is retried, then reported with the units that needed it; a bad spec is refused. The cluster is a Ray head started here on 127.0.0.1 (its
own port, temporary directory and token), stopped at the end. Run with `make test`."""

import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from harness.engines.base import REPO

SMALL = REPO / "sweeps" / "small.toml"
RAY = Path(sys.executable).parent / "ray"
UNITS = 16  # sweeps/small.toml: 4 trainings, 3 methods x 2 policy seeds x 2 targets


def sweep(*args, env=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness", "sweep", *map(str, args)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)


def results(out: Path) -> dict:
    """{unit file: its result as JSON text}: what must not depend on where a unit ran."""
    return {p.name: json.dumps(json.loads(p.read_text())["result"]) for p in sorted((out / "units").glob("*.json"))}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def ray_cluster():
    """A Ray head on 127.0.0.1 (token authentication with a token of its own); its address."""
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(16)}
    port, temp = free_port(), tempfile.mkdtemp(prefix="ray", dir="/tmp")  # short: socket paths
    head = subprocess.Popen([RAY, "start", "--head", "--block", f"--port={port}", "--node-ip-address=127.0.0.1",
                             "--num-cpus=2", "--include-dashboard=false", f"--temp-dir={temp}",
                             "--disable-usage-stats"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    address = f"127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while subprocess.run([RAY, "status", f"--address={address}"], env=env, capture_output=True).returncode:
            assert head.poll() is None, "the Ray head exited while starting"
            assert time.monotonic() < deadline, "the Ray head did not come up in 120 s"
            time.sleep(0.5)
        yield address, env
    finally:
        head.send_signal(signal.SIGTERM)  # --block: the head stops the cluster's processes with it
        try:
            head.wait(60)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)
            head.wait()


def test_a_sweep_on_a_ray_cluster_equals_a_serial_run(tmp_path, ray_cluster):
    address, env = ray_cluster
    on_cluster = sweep(SMALL, "--address", address, "--out", tmp_path / "cluster", env=env)
    assert on_cluster.returncode == 0, on_cluster.stdout + on_cluster.stderr
    assert f"{UNITS} of {UNITS} units done on {address}" in on_cluster.stdout
    serial = sweep(SMALL, "--serial", "--out", tmp_path / "serial")
    assert serial.returncode == 0, serial.stdout + serial.stderr
    cluster_results, serial_results = results(tmp_path / "cluster"), results(tmp_path / "serial")
    assert len(serial_results) == UNITS
    assert cluster_results == serial_results  # bit for bit: floats as JSON's shortest round trip
    policies = sorted(p.name for p in (tmp_path / "cluster" / "policies" / "cartpole").iterdir())
    assert policies == ["dr-seed0.json", "dr-seed1.json", "uc-seed0.json", "uc-seed1.json"]


def test_a_local_ray_runtime_gives_the_serial_results(tmp_path):
    local = sweep(SMALL, "--workers", "2", "--out", tmp_path / "local")
    assert local.returncode == 0, local.stdout + local.stderr
    assert f"{UNITS} of {UNITS} units done on 2 workers" in local.stdout
    serial = sweep(SMALL, "--serial", "--out", tmp_path / "serial")
    assert results(tmp_path / "local") == results(tmp_path / "serial")


def test_a_rerun_skips_finished_units_and_reports_from_them(tmp_path):
    out = tmp_path / "sweep"
    first = sweep(SMALL, "--serial", "--out", out)
    assert first.returncode == 0, first.stdout + first.stderr
    stamps = {p: p.stat().st_mtime_ns for p in (out / "units").iterdir()}
    second = sweep(SMALL, "--serial", "--out", out, "--report")
    assert second.returncode == 0, second.stdout + second.stderr
    assert f"{UNITS} units, {UNITS} done before" in second.stdout
    assert {p: p.stat().st_mtime_ns for p in (out / "units").iterdir()} == stamps
    # the transfer report of harness transfer, over the sweep's two policy seeds
    report = json.loads((out / "reports" / "transfer-cartpole-mujoco.json").read_text())
    assert report["meta"]["seeds"] == [0, 1] and len(report["methods"]["UC-Oracle"]["episodes"]) == 6
    # diffosi reproduce's Table 1 over the sweep's two trained models of each kind
    table1 = json.loads((out / "reports" / "table1-cartpole.json").read_text())
    assert table1["models"] == ["seed0", "seed1"]


def test_a_failing_unit_is_retried_then_reported_with_its_dependents(tmp_path):
    spec = tmp_path / "broken.toml"
    spec.write_text(SMALL.read_text().replace("steps = 8192", "steps = 0"))  # Policy.train refuses 0 steps
    run = sweep(spec, "--serial", "--retries", "1", "--out", tmp_path / "out")
    assert run.returncode == 1
    failed = json.loads((tmp_path / "out" / "failed.json").read_text())
    assert len(failed) == UNITS
    assert "steps must be at least 1" in failed["train-cartpole-uc-seed0"]
    assert failed["transfer-cartpole-mujoco-DR-seed0"].startswith("not run: needs")
    assert "FAILED train-cartpole-uc-seed0: ValueError: steps must be at least 1" in run.stdout


def test_quadruped_training_units_are_pure_functions_of_their_parameters():
    """sweeps/quadruped-seeds.toml trains uc and dr over seeds; one PPO iteration of a unit run
    twice gives the same policy and curve."""
    from harness import sweep as sw

    name, units = sw.load_spec(REPO / "sweeps" / "quadruped-seeds.toml")
    assert name == "quadruped-seeds" and {u.p["task"] for u in units} == {"quadruped"}
    assert sorted(u.name for u in units) == sorted(
        f"train-quadruped-{k}-seed{s}" for k in ("uc", "dr") for s in (0, 1, 2))
    one = sw.unit("train", task="quadruped", policy="uc", seed=1, steps=4096)
    first, again = sw.execute(one)["result"], sw.execute(one)["result"]
    assert first == again and len(first["curve"]) == 1
    assert first["policy"]["task"] == "quadruped"


@pytest.mark.parametrize("text, words", [
    ("name = 'x'\n[train]\ntask = ['cartpole']\n", "does not take ['task']"),
    ("name = 'x'\n[transfer]\ntasks = ['pendulum']\n", "task 'pendulum'"),
    ("name = 'x'\n[train]\ntasks = ['cartpole']\nkinds = ['mlp']\n", "not ['mlp']"),
    ("name = 'x'\n[transfer]\ntasks = ['cartpole']\npolicy_seeds = [0]\n", "runs policies [train] does not make"),
    ("name = 'x'\n[transfer]\ntasks = ['cartpole']\npolicies = 'shipped'\npolicy_seeds = [7]\n", "no shipped"),
    ("[train]\n", "a sweep has a name"),
    ("name = \n", "Invalid"),
])
def test_a_bad_spec_is_refused_with_the_reason(tmp_path, text, words):
    spec = tmp_path / "bad.toml"
    spec.write_text(text)
    run = sweep(spec, "--serial", "--out", tmp_path / "out")
    assert run.returncode == 2 and words in run.stdout, run.stdout
