"""`python -m harness COMMAND ...`: the harness's commands, one module each.

A command module has a docstring (its first line is the help text), an
`add_arguments(parser)` and a `run(args) -> int` (the exit status). A command whose module
needs a package that is not installed (outside the checkout, `pip install "diffosi[harness]"`
brings MuJoCo, PyBullet, DART, gymnasium and matplotlib: enough for `check`, not for `bench`'s
Pinocchio or `sweep`'s Ray) stays listed and, when run, says which package it needs (exit 2).
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
    modules, missing = {}, {}
    for name, path in COMMANDS.items():
        try:
            module = modules[name] = importlib.import_module(path)
        except ModuleNotFoundError as e:
            if e.name.split(".")[0] == "harness":  # ours: a bug, not a missing package
                raise
            missing[name] = e.name
            sub.add_parser(name, help=f"(needs {e.name}, not installed)", add_help=False)
            continue
        doc = module.__doc__ or ""
        cmd = sub.add_parser(name, help=doc.splitlines()[0] if doc else None, description=doc,
                             formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(cmd)
    args, unknown = parser.parse_known_args(argv)
    if args.command in missing:
        print(f"python -m harness {args.command}: needs the Python package {missing[args.command]}, "
              "which is not installed", file=sys.stderr)
        return 2
    if unknown:
        parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    return modules[args.command].run(args)


if __name__ == "__main__":
    sys.exit(main())
