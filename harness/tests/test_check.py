"""`python -m harness check` end to end: real robots (pybullet_data's KUKA iiwa URDF,
example-robot-data's two-dof arm URDF with meshes, dm_control's Kinova Jaco arm MJCF with
meshes), our shipped half cheetah and its twin, a deliberately wrong twin, a twin with a
renamed joint and broken files. Few steps and samples: the numbers are the engines' own."""

import argparse
import json
from pathlib import Path

import dm_control
import pybullet_data
import pytest

from harness import check, replay
from harness.corpus import example_robot_data
from harness.engines.base import MODELS

KUKA = Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"
TWO_DOFS = example_robot_data() / "asr_twodof_description" / "urdf" / "TwoDofs.urdf"
JACO = Path(dm_control.__file__).parent / "third_party" / "kinova" / "jaco_arm.xml"


def run_check(out: Path, model: Path, *extra) -> int:
    parser = argparse.ArgumentParser()
    check.add_arguments(parser)
    return check.run(parser.parse_args([str(model), "--steps", "30", "--samples", "4", "--out", str(out), *extra]))


def report(out: Path, model: Path) -> tuple[dict, str]:
    stem = f"check-{model.stem}"
    assert (out / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return json.loads((out / f"{stem}.json").read_text()), (out / f"{stem}.md").read_text()


def dynamic_mismatches(row: dict) -> list:
    """The compiled mismatches that matter to the dynamics (not welded or massless leftovers)."""
    return [m for m in row["compiled_mismatches"] if not m["inert"]]


def test_kuka_urdf_agrees_in_every_engine(tmp_path):
    assert run_check(tmp_path, KUKA) == 0
    doc, md = report(tmp_path, KUKA)
    assert doc["pass"] and list(doc["engines"]) == ["mujoco", "pybullet", "dart"]
    for name, row in doc["engines"].items():
        assert row["loaded"] and row["one_step_error"] <= 1e-9, name
        assert not dynamic_mismatches(row), (name, dynamic_mismatches(row))
        assert {r["name"] for r in row["compiled"] if r["kind"] == "joint"} == {f"lbr_iiwa_joint_{i}" for i in range(1, 8)}
    # PyBullet zeroes the fixed base's inertia; MuJoCo's importer drops the base link: both named
    assert any(m["name"] == "lbr_iiwa_link_0" and m["inert"] for m in doc["engines"]["pybullet"]["compiled_mismatches"])
    assert doc["gradients"]["pass"] and "MJCF only" in doc["contact"]["error"]
    assert "defaults (the file sets none): h = 0.002 s" in json.dumps(doc["engines"]["pybullet"]["settings"])
    assert "Result: PASS" in md and "| dart | yes |" in md


def test_urdf_with_meshes_and_packages_loads_in_every_engine(tmp_path):
    robots = example_robot_data()
    assert run_check(tmp_path, TWO_DOFS, "--package-dir", str(robots.parent), "--package-dir",
                     str(robots.parent.parent)) == 0
    doc, _ = report(tmp_path, TWO_DOFS)
    for name in ("mujoco", "pybullet", "dart"):
        assert doc["engines"][name]["loaded"], name
    for name in ("pybullet", "dart"):
        assert doc["engines"][name]["one_step_error"] <= 1e-9, name


def test_package_dirs_reach_darts_loader(tmp_path):
    """A copy of the arm outside example-robot-data: its package://example-robot-data/ meshes
    resolve only through --package-dir, in DART's loader (DartLoader.addPackageDirectory) as in ours."""
    copy = tmp_path / "TwoDofs.urdf"
    copy.write_text(TWO_DOFS.read_text())
    args = argparse.Namespace(package_dir=[], timestep=None)
    engine, error = check.load_engine("dart", copy, args)
    assert engine is None and "DART could not parse it" in error
    args.package_dir = [example_robot_data().parent]
    engine, error = check.load_engine("dart", copy, args)
    assert error is None and engine.joint_names == check.load_ours(copy, args.package_dir).joint_names


def test_mjcf_with_meshes_and_a_pair_without_collider(tmp_path):
    assert run_check(tmp_path, JACO) == 0
    doc, md = report(tmp_path, JACO)
    mj = doc["engines"]["mujoco"]
    # its frictionloss is a constraint MuJoCo's adapter switches off, and ours() zeroes
    assert mj["one_step_error"] <= 1e-9 and mj["settings"]["ignored"]["frictionloss"]
    assert not dynamic_mismatches(mj)
    for name, loader in (("pybullet", "loadMJCF"), ("dart", "MjcfParser")):  # their own MJCF loaders
        row = doc["engines"][name]
        assert row["loader"] == loader and row.get("agrees") is None, row  # compiled only: never gated
    assert doc["engines"]["pybullet"]["loaded"]
    dart = doc["engines"]["dart"]  # its own error, and what it printed
    assert not dart["loaded"] and "MJCF parser returned no world" in dart["error"] and "printed:" in dart["error"]
    assert "no collider" in doc["contact"]["error"] and doc["gradients"]["pass"]
    assert "not checked: ValueError: step: geoms" in md


def test_shipped_twin_passes_through_the_same_code(tmp_path):
    model, twin = MODELS / "half_cheetah.xml", MODELS / "half_cheetah.urdf"
    assert run_check(tmp_path, model, "--twin", str(twin)) == 0
    doc, md = report(tmp_path, model)
    t = doc["twin_check"]
    assert not t["differs"] and t["ours"] == [] and t["steps"]["max_error"] <= 1e-12
    assert doc["contact"]["agrees"] and doc["contact"]["contact_states"] > 0
    assert "Result: same robot." in md


def test_a_wrong_twin_exits_1_and_names_the_link_and_the_quantity(tmp_path):
    urdf = (MODELS / "cartpole.urdf").read_text()
    assert urdf.count('<mass value="0.1"/>') == 1
    wrong = tmp_path / "cartpole.urdf"
    wrong.write_text(urdf.replace('<mass value="0.1"/>', '<mass value="0.11"/>'))  # the pole's, +10%
    assert run_check(tmp_path / "out", wrong, "--twin", str(MODELS / "cartpole.xml")) == 1
    doc, md = report(tmp_path / "out", wrong)
    t = doc["twin_check"]
    assert t["differs"] and t["steps"]["max_error"] > 1e-3
    assert t["ours"] == [{"kind": "body", "name": "pole", "inert": False, "field": "mass", "a": 0.11, "b": 0.1}]
    assert "body `pole`: mass 0.11 vs 0.1" in md


def test_a_twin_with_a_renamed_joint_gets_a_table(tmp_path):
    urdf = (MODELS / "cartpole.urdf").read_text()
    renamed = tmp_path / "cartpole.urdf"
    renamed.write_text(urdf.replace('name="hinge"', 'name="pivot"'))
    assert run_check(tmp_path / "out", renamed, "--twin", str(MODELS / "cartpole.xml")) == 1
    doc, md = report(tmp_path / "out", renamed)
    t = doc["twin_check"]
    assert t["steps"] is None and ["pivot", "1", "-"] in t["joints_differ"] and ["hinge", "-", "1"] in t["joints_differ"]
    assert "| pivot | 1 | - |" in md


@pytest.mark.parametrize("name, text, message", [
    ("nan.urdf", '<robot name="r">\n  <link name="a">\n    <inertial><mass value="nan"/></inertial>\n  </link>\n'
                 '</robot>\n', "nan.urdf:3: <mass>"),
    ("cut.xml", "<mujoco>\n<worldbody>\n<body>\n</worldbody>\n", "cut.xml: XML syntax error"),
    ("missing.urdf", None, "missing.urdf: no such file"),
    ("mesh.urdf", '<robot name="m">\n  <link name="base"/>\n  <link name="arm">\n    <inertial><mass value="1"/>'
                  '<inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>\n'
                  '    <collision><geometry><mesh filename="package://nope/arm.stl"/></geometry></collision>\n'
                  '  </link>\n  <joint name="j" type="continuous"><parent link="base"/><child link="arm"/></joint>\n'
                  '</robot>\n', "mesh.urdf:5: <mesh>: mesh 'package://nope/arm.stl'"),
])
def test_a_file_we_cannot_read_exits_2_with_one_line(tmp_path, capsys, name, text, message):
    path = tmp_path / name
    if text is not None:
        path.write_text(text)
    assert run_check(tmp_path, path) == 2
    out = capsys.readouterr().out.strip()
    assert len(out.splitlines()) == 1 and message in out, out
    if name == "mesh.urdf":  # the package paths searched are named
        assert f"package 'nope' not found (tried {tmp_path}/nope/arm.stl" in out, out
    assert not (tmp_path / f"check-{path.stem}.json").exists()


def test_replay_takes_a_urdf_without_options(tmp_path):
    """The issue's traceback: replay on pybullet_data's KUKA now runs at the stated defaults."""
    parser = argparse.ArgumentParser()
    replay.add_arguments(parser)
    assert replay.run(parser.parse_args(["--model", str(KUKA), "--steps", "20", "--samples", "4",
                                         "--out", str(tmp_path)])) == 0
    doc = json.loads((tmp_path / "replay-model.json").read_text())
    assert all(r["timestep"] == 0.002 for r in doc["engines"].values())


def test_corpus_report_has_a_row_per_model_and_a_column_per_engine(tmp_path, monkeypatch):
    from harness import corpus

    everything = corpus.discover()
    names = ("dm_control:pendulum.xml", "pybullet_data:kuka_iiwa/model.urdf", "dm_control:ball_in_cup.xml")
    picked = [c for c in everything if c.name in names]
    monkeypatch.setattr(corpus, "discover", lambda: picked)
    parser = argparse.ArgumentParser()
    check.add_arguments(parser)
    assert check.run(parser.parse_args(["--corpus", "--steps", "10", "--samples", "2", "--out", str(tmp_path)])) == 0
    doc = json.loads((tmp_path / "check-corpus.json").read_text())
    rows = {r["model"]: r for r in doc["models"]}
    assert rows["pybullet_data:kuka_iiwa/model.urdf"]["pass"]
    kuka = rows["pybullet_data:kuka_iiwa/model.urdf"]["engines"]
    assert all(kuka[n]["loaded"] and kuka[n]["one_step_error"] <= 1e-9 for n in ("mujoco", "pybullet", "dart"))
    pendulum = rows["dm_control:pendulum.xml"]["engines"]
    assert pendulum["mujoco"]["one_step_error"] <= 1e-9
    # DART's own MjcfParser loads it: compared compiled, not stepped
    assert pendulum["dart"]["loaded"] and pendulum["dart"]["one_step_error"] is None
    # ball_in_cup's string is a limited spatial tendon
    cup = rows["dm_control:ball_in_cup.xml"]
    assert cup["pass"] and cup["ours"] == "ok", cup
    md = (tmp_path / "check-corpus.md").read_text()
    assert "| model | ours | mujoco | pybullet | dart | result |" in md


def test_timestep_override_and_seeded_reports(tmp_path):
    model = MODELS / "cartpole.urdf"
    for out in ("a", "b"):
        assert run_check(tmp_path / out, model, "--timestep", "0.005") == 0
    first = (tmp_path / "a" / "check-cartpole.json").read_text()
    assert first == (tmp_path / "b" / "check-cartpole.json").read_text()
    doc = json.loads(first)
    for name, row in doc["engines"].items():
        assert row["settings"]["timestep"] == 0.005, name
        assert row["settings"]["settings"]["timestep_override"]["used"] == 0.005, name
        assert row["one_step_error"] <= 1e-9, name


@pytest.mark.parametrize("name", ["box", "cartpole", "double_pendulum", "floating_arm", "pendulum", "wiping_arm"])
def test_every_shipped_twin_is_the_same_robot(tmp_path, name):
    model = MODELS / f"{name}.xml"
    assert run_check(tmp_path, model, "--twin", str(MODELS / f"{name}.urdf"), "--engines", "mujoco") == 0
    t = report(tmp_path, model)[0]["twin_check"]
    assert not t["differs"] and t["ours"] == [] and t["steps"]["max_error"] <= 1e-12, t


def test_mjcf_in_pybullets_and_darts_own_loaders(tmp_path):
    """Our half cheetah MJCF: PyBullet's loadMJCF and DART's MjcfParser load it; their compiled
    models against ours, reported and not gated: the joints match but for the armature neither
    has (and the damping, which loadMJCF does not read), and the bodies' inertia is each
    loader's own (PyBullet's from the geoms, DART's the identity)."""
    model = MODELS / "half_cheetah.xml"
    assert run_check(tmp_path, model) == 0
    doc, md = report(tmp_path, model)
    for name in ("pybullet", "dart"):
        row = doc["engines"][name]
        assert row["loaded"] and row["one_step_error"] is None and row["agrees"] is None
        joints = {(m["name"], m["field"]) for m in dynamic_mismatches(row) if m["kind"] == "joint"}
        fields = ("armature", "damping") if name == "pybullet" else ("armature",)  # loadMJCF reads no damping
        assert joints == {(j, f) for j in ("bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot") for f in fields}
        assert ("torso", "principal moments") in {(m["name"], m["field"]) for m in dynamic_mismatches(row)}
    assert "its own loadMJCF: compiled only" in md and "not stepped" in md


def test_a_loader_that_crashes_is_its_row(tmp_path):
    """DART's MjcfParser dies of a segmentation fault on dm_control's acrobot: read in a process
    of its own, the crash is DART's row and the check goes on."""
    acrobot = Path(dm_control.__file__).parent / "suite" / "acrobot.xml"
    assert run_check(tmp_path, acrobot) == 0
    doc, md = report(tmp_path, acrobot)
    assert doc["engines"]["dart"] == {"loaded": False, "loader": "MjcfParser",
                                      "error": "the loader crashed (signal SIGSEGV)"}
    assert doc["engines"]["pybullet"]["loaded"] and doc["engines"]["mujoco"]["one_step_error"] <= 1e-9
