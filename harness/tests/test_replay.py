"""`python -m harness replay` end to end on the cartpole, few steps, into a temporary directory."""

import argparse
import json

from harness import replay


def run_replay(out, *extra):
    parser = argparse.ArgumentParser()
    replay.add_arguments(parser)
    return replay.run(parser.parse_args(["--model", "cartpole", "--steps", "30", "--samples", "10",
                                         "--seed", "3", "--out", str(out), *extra]))


def test_replay_writes_a_passing_report(tmp_path):
    assert run_replay(tmp_path) == 0
    doc = json.loads((tmp_path / "replay-cartpole.json").read_text())
    assert doc["pass"] and list(doc["engines"]) == ["mujoco", "pybullet", "dart"]
    for name, r in doc["engines"].items():
        assert len(r["rollout"]["error"]) == 31, name
        assert r["one_step"]["max_error"] <= 1e-12 and r["rollout"]["max_error"] <= 1e-9, name
    assert doc["engines"]["dart"]["passive"] == "implicit_damping_stiffness"
    md = (tmp_path / "replay-cartpole.md").read_text()
    assert "Result: PASS" in md and md.count("| PASS |") == 3 and "FAIL" not in md
    assert "qfrc_applied" in md and "URDF_USE_INERTIA_FROM_FILE" in md  # the engines' settings
    assert (tmp_path / "replay-cartpole.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_replay_is_seeded(tmp_path):
    run_replay(tmp_path / "a")
    run_replay(tmp_path / "b")
    run_replay(tmp_path / "c", "--seed", "4")
    first = (tmp_path / "a" / "replay-cartpole.json").read_text()
    assert first == (tmp_path / "b" / "replay-cartpole.json").read_text()
    assert first != (tmp_path / "c" / "replay-cartpole.json").read_text()


def test_unknown_engine_is_an_error(tmp_path):
    assert run_replay(tmp_path, "--engines", "mujoco,bullet") == 2
    assert not any(tmp_path.iterdir())


def test_a_failing_engine_fails_the_command(tmp_path, monkeypatch):
    monkeypatch.setattr(replay, "ROLLOUT_TOL", 1e-30)  # round-off alone now fails
    assert run_replay(tmp_path) == 1
    assert "Result: **FAIL**" in (tmp_path / "replay-cartpole.md").read_text()
    assert not json.loads((tmp_path / "replay-cartpole.json").read_text())["pass"]
