"""`python -m harness COMMAND ...`: the harness's commands, one module each.

A command module has a docstring (its first line is the help text), an
`add_arguments(parser)` and a `run(args) -> int` (the exit status).
"""

import argparse
import importlib
import sys

COMMANDS = {
    "replay": "harness.replay",
    "gradcheck": "harness.gradcheck",
    "gradcheck-free": "harness.gradcheck_free",
    "golden": "harness.golden",
    "golden-contact": "harness.golden_contact",
    "golden-free": "harness.golden_free",
    "bench": "harness.bench",
    "osi-bench": "harness.osi_bench",
    "figures": "harness.figures",
    "transfer": "harness.transfer",
    "overview": "harness.overview",
    "joint-osi": "harness.joint_osi",
    "robustness": "harness.robustness",
    "contact": "harness.contact",
    "wiping-replay": "harness.wiping_replay",
    "sweep": "harness.sweep",
    "corpus": "harness.corpus",
    "check": "harness.check",
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m harness", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    modules = {}
    for name, path in COMMANDS.items():
        module = modules[name] = importlib.import_module(path)
        doc = module.__doc__ or ""
        cmd = sub.add_parser(name, help=doc.splitlines()[0] if doc else None, description=doc,
                             formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(cmd)
    args = parser.parse_args(argv)
    return modules[args.command].run(args)


if __name__ == "__main__":
    sys.exit(main())
