"""The type stub diffosi.pyi (shipped in the wheel with py.typed) against the built module:
mypy's stubtest, and the defaults that help() shows against the objects' own (issue 40). Run
with `make test`."""

import inspect
import subprocess
import sys
from pathlib import Path

import diffosi

REPO = Path(__file__).resolve().parents[2]


def test_stubtest_passes():
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", "diffosi", "--ignore-disjoint-bases",
                          "--allowlist", str(REPO / "harness" / "tests" / "stubtest-allowlist.txt")],
                         capture_output=True, text=True, cwd=REPO)
    assert out.returncode == 0, (
        "diffosi.pyi no longer matches the built module (a method, argument or default changed in "
        "bindings/): bring diffosi.pyi in step (stubtest's report follows)\n" + out.stdout + out.stderr)


def test_the_stub_is_installed_with_py_typed():
    package = Path(diffosi.__file__).parent
    assert (package / "__init__.pyi").read_text() == (REPO / "diffosi.pyi").read_text()
    assert (package / "py.typed").exists()


def default(f, name):
    return inspect.signature(f).parameters[name].default


def test_help_shows_the_real_defaults():
    m = diffosi.Model.load(str(REPO / "reference_models" / "cartpole.xml"))
    huber = diffosi.DiffOsi(m, ["body/pole/mass"], [0.01], [1.0], loss="huber")
    assert default(diffosi.DiffOsi, "huber") == huber.huber == 1.345
    assert default(diffosi.OnlineOsi, "huber") == 1.345
    assert default(diffosi.OnlineOsi, "restarts") == 8
    assert default(diffosi.DiffOsi, "margin") == default(diffosi.OnlineOsi, "margin") == 0.02
    cma = diffosi.CmaEs(m, ["body/pole/mass"], [0.01], [1.0])
    assert (default(diffosi.CmaEs, "seed"), default(diffosi.CmaEs, "max_evaluations")) == \
        (cma.seed, cma.max_evaluations)
    for f in (diffosi.DiffOsi, diffosi.OnlineOsi, diffosi.CmaEs):
        assert all(p.default is not Ellipsis for p in inspect.signature(f).parameters.values()), f
