# The two fresh-machine entry points (see README.md):
#   make run    set everything up, then run the main job
#   make test   set everything up, then run every test
PYTHON ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

.PHONY: setup run test bench golden

setup: $(STAMP)
	cargo build --release --locked

# The venv holds the reference engines (MuJoCo, PyBullet, DART) and gymnasium,
# whose MJCF assets the loader tests read.
$(STAMP): requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -r requirements.txt
	touch $(STAMP)

run: setup
	scripts/main.sh

test: setup
	cargo fmt --check
	cargo clippy --release --locked --all-targets -- -D warnings
	cargo test --release --locked

bench: setup
	cargo bench
	$(VENV)/bin/python scripts/bench_reference.py

# Regenerates the reference engines' golden data (committed; see reference_models/golden/README.md).
golden: setup
	$(VENV)/bin/python scripts/golden.py --all --seed 0
