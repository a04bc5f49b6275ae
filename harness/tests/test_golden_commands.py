"""The golden data's commands (`make golden`: golden, golden-contact, golden-free) in their
cheapest form, into a temporary directory: each runs to its end and writes files holding what
the Rust tests read, so a broken name or import in a command (golden-free's NameError after
the quiet-loading change) fails here, not at the next regeneration. The committed data are
not compared: rounding moves them by about 1e-15 between machines. Run with `make test`."""

import json

import numpy as np

from harness.__main__ import main


def written(out) -> dict:
    docs = {p.stem: json.loads(p.read_text()) for p in sorted(out.glob("*.json"))}
    assert docs, f"nothing written to {out}"
    return docs


def test_golden_pendulum_cases(tmp_path):
    assert main(["golden", "--only", "pendulum", "--seed", "0", "--out", str(tmp_path)]) == 0
    docs = written(tmp_path)
    assert {doc["engine"] for doc in docs.values()} == {"mujoco", "pybullet", "dart"}
    for name, doc in docs.items():
        assert "pendulum" in name and np.all(np.isfinite(doc["rollout"]["q"])), name


def test_golden_contact_one_state_per_model(tmp_path):
    assert main(["golden-contact", "--seed", "0", "--states", "1", "--out", str(tmp_path)]) == 0
    docs = written(tmp_path)
    assert all(doc["states"] for doc in docs.values())
    assert any(s["contacts"] for s in docs["wiping_arm"]["states"])


def test_golden_free(tmp_path):
    assert main(["golden-free", "--seed", "0", "--out", str(tmp_path)]) == 0
    docs = written(tmp_path)
    assert {"floating_arm", "pybullet_floating_arm", "dart_floating_arm"} <= set(docs)
    for name, doc in docs.items():
        assert np.all(np.isfinite(doc["rollout"]["q"])) and len(doc["rollout"]["q"]) > 1, name
