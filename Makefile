# Two commands set everything up on a fresh machine:
#   make train   installs into .venv (if missing), trains a team that plays and shows it
#   make test    installs into .venv (if missing) and runs the test suite
#   make docs    builds the documentation site into site/ (strict: a broken link fails)
VENV   ?= .venv
PYTHON ?= python3
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# torch is installed first, pinned, so that the CPU wheel is used and no
# dependency can pull a CUDA build.
TORCH  ?= torch==2.13.0

.PHONY: install train test lint docs bench clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet "$(TORCH)"
	$(PY) -m pip install --quiet -e ".[dev,cluster,docs,envs]"
	touch $(STAMP)

# make train: the game's preset whose teams play (PRESET=best, RLHC's hierarchical critic),
# then its showcase in <run>/showcase/ (python -m rlhc.evaluate mode=showcase): point.gif,
# curves.png, showcase.json, and the headline numbers printed.
#   make train GAME=soccer            the other game
#   make train PRESET=paper           the paper's Table 3 preset instead
#   make train ARGS="critic=ppo seed=1"   any other overrides
#   make train PROCS=2                the same run on 2 processes (torchrun, parallel=$(PARALLEL);
#                                     pipeline is faster on 2 cores, but not with a league:
#                                     make train PRESET=paper PROCS=2 PARALLEL=pipeline)
GAME   ?= tennis
PRESET ?= best
ARGS   ?=
PROCS  ?= 1
PARALLEL ?= data
RUN    := outputs/train/$(GAME)/$(shell date +%Y-%m-%d_%H-%M-%S)
ifeq ($(PROCS),1)
TRAIN  := $(PY) -m rlhc.run
else
TRAIN  := $(PY) -m torch.distributed.run --standalone --nproc_per_node=$(PROCS) -m rlhc.run parallel=$(PARALLEL)
endif
train: $(STAMP)
	$(TRAIN) env=$(GAME) preset=$(PRESET) hydra.run.dir=$(RUN) $(ARGS)
	$(PY) -m rlhc.evaluate mode=showcase env=$(GAME) home=$(RUN) matches=50 hydra.run.dir=$(RUN)/showcase

# tests/ and the examples in rlhc/'s docstrings (pyproject.toml: testpaths, --doctest-modules).
# No tests collected (pytest's exit code 5) is a failure.
test: $(STAMP)
	$(PY) -m pytest -n 2 -q

lint: $(STAMP)
	$(PY) -m ruff check rlhc tests benchmarks
	$(PY) -m ruff format --check rlhc tests benchmarks
	$(PY) -m mypy rlhc benchmarks

# mkdocs.yml: the user guide, docs/RESULTS.md and the API reference from the docstrings;
# --strict turns every warning (a broken link or anchor, an unknown API reference) into a failure.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict

bench: $(STAMP)
	$(PY) benchmarks/env_throughput.py

clean:
	rm -rf $(VENV) outputs multirun .pytest_cache .mypy_cache .ruff_cache
