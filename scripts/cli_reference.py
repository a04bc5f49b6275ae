"""Writes docs/src/cli-reference.md from the built binary's own help (clap's), so the guide's
CLI reference cannot drift: `make docs` runs this, and harness/tests/test_docs.py fails when
the committed file differs from what the binary prints.

    python scripts/cli_reference.py [--check]
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BINARY = REPO / "target" / "release" / "diffosi"
OUT = REPO / "docs" / "src" / "cli-reference.md"


def help_of(*command: str) -> str:
    return subprocess.run([str(BINARY), *command, "--help"], capture_output=True, text=True, check=True).stdout


def commands(top: str) -> list[str]:
    """The subcommands clap lists under "Commands:" (without `help`)."""
    section = top.split("Commands:\n", 1)[1].split("\n\n", 1)[0]
    names = [m.group(1) for m in re.finditer(r"^  (\S+)", section, re.M)]
    return [n for n in names if n != "help"]


def reference() -> str:
    top = help_of()
    parts = ["# CLI reference", "",
             "Generated from `target/release/diffosi --help` and each command's `--help` by",
             "`scripts/cli_reference.py` (`make docs`); a test keeps it equal to the binary's.", "",
             "```text", "$ diffosi --help", top.rstrip(), "```"]
    for name in commands(top):
        parts += ["", f"## diffosi {name}", "", "```text", f"$ diffosi {name} --help", help_of(name).rstrip(), "```"]
    return "\n".join(parts) + "\n"


if __name__ == "__main__":
    text = reference()
    if "--check" in sys.argv[1:]:
        sys.exit(0 if OUT.read_text() == text else f"{OUT} differs from the binary's help: run `make docs`")
    OUT.write_text(text)
