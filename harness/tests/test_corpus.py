"""The corpus of real robot files (harness/corpus.py): every model loads, steps contact-free as
its engine does (MuJoCo for MJCF, PyBullet for URDF) within 1e-12, matches Pinocchio's ABA
(example-robot-data) within 1e-12, and steps 1000 times at rest without diverging.

Every model is asserted strictly. The models that fail today are listed in KNOWN_FAILURES with
the reason (the engine's message, file and line left out): each is an xfail(strict=True), so a
model that starts passing fails this test until its entry is removed. The table of every model
is printed at the end of the module's tests (and `python -m harness corpus` writes it to
reports/corpus.md and .json).
"""

import pytest

from harness import corpus

SEED = 0

# Each reason is corpus.reason() of the model's row at SEED, reviewed: what fails and why.
# The one-step check against PyBullet loads ours with inertial="pybullet" (PyBullet's reading:
# mass 1 where a link has no <inertial>, Bullet's principal axes, unphysical tensors zeroed);
# the Pinocchio check the default reading, the file as written.
KNOWN_FAILURES = {
    "example-robot-data:human_description/robots/human.urdf":
        "rest: rollout step 707: the step diverged: the next state is not finite; fastest: dof 23 of joint 'right_shoulder_Z' (|v| = 1.456e266; a joint too light or too stiff for the timestep?), at q = -2.9110e263 beyond its range",
    "example-robot-data:icub_description/robots/icub.urdf":
        "pinocchio: error 1.7e-12 > 1e-12 | rest: rollout step 10: the step diverged: the next state is not finite; fastest: dof 29 of joint 'r_wrist_prosup' (|v| = 6.637e161; a joint too light or too stiff for the timestep?), at q = -1.3274e159 beyond its range; 66 contacts, the deepest between geoms 22 '' and 27 '' at distance -1.060e-1",
    "example-robot-data:icub_description/robots/icub_reduced.urdf":
        "rest: rollout step 11: the step diverged: the next state is not finite; fastest: dof 28 of joint 'r_wrist_yaw' (|v| = 1.696e257; a joint too light or too stiff for the timestep?), at q = 3.3925e254 beyond its range; 58 contacts, the deepest between geoms 13 '' and 14 '' at distance -9.048e-2",
    "example-robot-data:romeo_description/urdf/romeo.urdf":
        "load: <link>: link 'RThumb3Link' moves (joint 'RThumb3') but neither it nor any link below it has mass or inertia, so that joint has no inertia (Pinocchio's ABA gives NaN, MuJoCo refuses it, PyBullet gives the joint no acceleration); give the link an <inertial>",
    "example-robot-data:so_arm_description/urdf/so101.urdf":
        "rest: rollout step 64: the step diverged: the next state is not finite; fastest: dof 2 of joint 'elbow_flex' (|v| = 7.809e303; a joint too light or too stiff for the timestep?), at q = 1.5619e301 beyond its range; 12 contacts, the deepest between geoms 1 '' and 6 '' at distance -2.918e-2",
    "example-robot-data:tiago_description/robots/tiago_dual.urdf":
        "one_step: PyBullet: getJointState failed.",
    "pybullet_data:humanoid/humanoid.urdf":
        "one_step: PyBullet joints with more than one dof:",
    "pybullet_data:spherical_joint_limit.urdf":
        "one_step: PyBullet joints with more than one dof:",
}

CASES = corpus.discover()


def params():
    for case in CASES:
        marks = [pytest.mark.xfail(strict=True, reason=KNOWN_FAILURES[case.name])] if case.name in KNOWN_FAILURES \
            else []
        yield pytest.param(case, id=case.name, marks=marks)


@pytest.fixture(scope="module")
def table(request):
    """The rows of the checked models; printed as the corpus table when the module ends."""
    rows = []
    yield rows
    order = {case.name: k for k, case in enumerate(CASES)}
    rows.sort(key=lambda r: order[r["model"]])
    plugins = request.config.pluginmanager
    write = plugins.get_plugin("terminalreporter").write_line
    with plugins.get_plugin("capturemanager").global_and_fixture_disabled():  # past pytest's capture
        write("")
        lines = [*corpus.markdown_table(corpus.SUMMARY_HEADER, corpus.summary(rows)), "",
                 *corpus.markdown_table(corpus.HEADER, corpus.table_rows(rows)), "", *corpus.failure_lines(rows)]
        for line in lines:
            write(line)


@pytest.mark.parametrize("case", list(params()))
def test_model(case, table):
    row = corpus.check(case, SEED)
    table.append(row)
    assert row["pass"], corpus.reason(row)


def test_the_corpus_is_what_the_collections_hold():
    """19 dm_control suite files; the 67 of
    example-robot-data's 69 URDFs that PyBullet loads (not romeo_laas_small: a mesh named .mesh,
    nor ur3: a robot without a name); the 43 robots among pybullet_data's 1095 URDFs."""
    by_source = {s: [c for c in CASES if c.source == s] for s in corpus.SOURCES}
    assert [len(by_source[s]) for s in corpus.SOURCES] == [19, 67, 43]


def test_every_known_failure_is_a_checked_model():
    """No stale entry: each name in KNOWN_FAILURES is a model this test checks."""
    assert set(KNOWN_FAILURES) <= {c.name for c in CASES}


# The checks themselves, on models that load today: they pass on a faithful model and fail
# on one with a wrong mass (so a dm_control model's MuJoCo check, which no suite file reaches
# before <include> loads, is exercised too).

def gym_humanoid():
    """gymnasium's humanoid: a free root, hinges, RK4, as MuJoCo compiles it."""
    from harness.engines.base import gym_assets_dir

    return corpus.Case("gymnasium", gym_assets_dir() / "humanoid.xml", gym_assets_dir(), "24/23/17")


def ur5():
    root = corpus.example_robot_data()
    return corpus.Case("example-robot-data", root / "ur_description/urdf/ur5_robot.urdf", root, "6/6/-",
                       [root.parent.parent, root])


def test_the_mujoco_check_passes_on_gymnasium_humanoid():
    row = corpus.check(gym_humanoid(), SEED)
    assert row["pass"] and row["one_step_error"] <= corpus.ONE_STEP_TOL, corpus.reason(row)


@pytest.mark.parametrize("case, body, check, inertial", [
    (gym_humanoid, "torso", corpus.mujoco_one_step, "pinocchio"),
    (ur5, "forearm_link", corpus.pybullet_one_step, "pybullet"),
    (ur5, "forearm_link", lambda case, ours, seed: (corpus.pinocchio_error(case, ours, seed), {}), "pinocchio"),
])
def test_a_check_fails_on_a_wrong_mass(case, body, check, inertial):
    case = case()
    ours = corpus.load_ours(case, inertial)
    assert check(case, ours, SEED)[0] <= corpus.ONE_STEP_TOL
    ours.set_param(f"body/{body}/mass", 1.01 * ours.get_param(f"body/{body}/mass"))
    assert check(case, ours, SEED)[0] > 1e-6
