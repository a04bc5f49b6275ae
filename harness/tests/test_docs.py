"""The README and the user guide (docs/src/) as a reader runs them (issue 40): every ```python
block of a file runs, in order, in one namespace, from the checkout's root; the CLI reference
is the binary's own help. Rust blocks run as doctests (src/lib.rs includes the chapters under
cfg(doctest)). Run with `make test`."""

import os
import re
import runpy
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PAGES = [REPO / "README.md", *sorted((REPO / "docs" / "src").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```$", re.S | re.M)


def python_blocks(page: Path) -> list[str]:
    return BLOCK.findall(page.read_text())


@pytest.mark.parametrize("page", [p for p in PAGES if python_blocks(p)], ids=lambda p: p.name)
def test_python_examples_run(page, monkeypatch):
    monkeypatch.chdir(REPO)
    namespace: dict = {"__name__": "__docs__"}
    for i, code in enumerate(python_blocks(page)):
        exec(compile(code, f"{page.name}, python block {i + 1}", "exec"), namespace)


def test_the_guide_has_examples_to_run():
    assert len(python_blocks(REPO / "docs" / "src" / "getting-started.md")) >= 1
    assert len(python_blocks(REPO / "README.md")) == 1


def test_cli_reference_is_the_binarys_help():
    script = runpy.run_path(str(REPO / "scripts" / "cli_reference.py"))
    committed = (REPO / "docs" / "src" / "cli-reference.md").read_text()
    assert committed == script["reference"](), (
        "docs/src/cli-reference.md differs from `target/release/diffosi --help`: run `make docs` "
        "(or `python scripts/cli_reference.py`) and commit it")


def test_every_chapter_is_in_the_summary():
    summary = (REPO / "docs" / "src" / "SUMMARY.md").read_text()
    listed = set(re.findall(r"\]\(([^)]+\.md)\)", summary))
    chapters = {p.name for p in (REPO / "docs" / "src").glob("*.md")} - {"SUMMARY.md"}
    assert listed == chapters


def test_readme_is_short():
    assert len((REPO / "README.md").read_text().splitlines()) <= 300


def test_guide_links_resolve():
    """Relative links of the README and the chapters point at files that exist."""
    for page in PAGES:
        text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
            if "://" in target:
                continue
            assert (page.parent / target).exists(), f"{page.name}: link to {target}"
    assert os.path.exists(REPO / "docs" / "book.toml")


def test_rust_examples_are_doctests():
    """A chapter with a ```rust block is included in src/lib.rs, so that `cargo test` runs it."""
    lib = (REPO / "src" / "lib.rs").read_text()
    for page in (REPO / "docs" / "src").glob("*.md"):
        if re.search(r"^```rust", page.read_text(), re.M):
            assert f'include_str!("../docs/src/{page.name}")' in lib, page.name
