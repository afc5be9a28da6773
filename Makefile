# Two commands do all the set-up on a fresh clone: `make test` and `make train`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
TRAIN_STAMP := $(VENV)/.installed-train
PIP_INSTALL := $(BIN)/python -m pip install --quiet -c constraints.txt

.PHONY: test test-fast test-jax-train train lint format docs docs-check figures bench results clean clean-cache

# The venv with the package and the extras $(1); `make train` needs only "train", which
# installs in half the time of "test" (Ray, Optuna, the zoo, the test tools), part of the
# budget of `make train` on a fresh clone.
define install
	$(PYTHON) -m venv $(VENV)
	$(PIP_INSTALL) --upgrade pip
	$(PIP_INSTALL) -e ".[$(1)]"
endef

$(STAMP): pyproject.toml constraints.txt
	$(call install,test)
	touch $(STAMP) $(TRAIN_STAMP)

$(TRAIN_STAMP): pyproject.toml constraints.txt
	$(call install,train)
	touch $(TRAIN_STAMP)

# The docs' site is built with --strict by tests/contracts/test_docs.py, not twice.
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -n auto --dist worksteal -m "not jax_train" --durations=15

# The JAX PPO's tests, apart (they compile the trainer for minutes) and under a time limit: a
# deadlock of XLA's CPU pool (jaxlib 0.10's batched LAPACK kernels, docs/jax.md) fails here.
test-jax-train: $(STAMP)
	timeout 900 $(BIN)/python -m pytest -q -p no:xdist -m jax_train

# The inner loop: ruff and every test but the `slow` ones (training runs, Ray, the browser, the
# wheel, the docs' commands).
test-fast: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -n auto --dist worksteal -m "not slow and not jax_train" --durations=10

# The documentation site into build/site; --strict: a broken link, a missing reference or a
# results table whose file is gone fails the build.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

# A headless Chromium (Debian's package: apt-get install chromium) opens every page of the built
# site at 1280 px: no console error, no table cut off, on the pages that show results no table
# wider than the page (scrolling or not), each table with its source's rows, the GIFs loaded;
# screenshots in build/screenshots/. In `make test` it skips without chromium.
docs-check: $(STAMP)
	TETHER_REQUIRE_CHROMIUM=1 $(BIN)/python -m pytest -q tests/contracts/test_docs.py -k chromium

# The default run on two torch threads: TetherBounce's gradient steps are large enough to share.
train: $(TRAIN_STAMP)
	$(BIN)/python train.py --num-threads 2

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

format: $(STAMP)
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

figures: $(STAMP)
	$(BIN)/python -m tether_gym.figures --out docs/figures --overwrite

# Every speed benchmark (benchmarks/README.md) in its short mode, a few minutes on two cores;
# env_against (env against a revision), the full runs, the experiments and the validations
# are run one by one.
BENCH_SPEED := physics env train planners cold_start sweep_throughput jax_throughput
bench: $(STAMP)
	for name in $(BENCH_SPEED); do $(BIN)/python -m benchmarks.speed.$$name --quick || exit 1; done

# Every results file from its command (results/manifest.yaml, benchmarks/results.py): PART=name
# one part (or a file), STALE=1 the known-stale files only; the plan and its estimated cost
# first; a file that exists is replaced only with OVERWRITE=1; DRY_RUN=1 prints the plan only.
# All of it is about half a day on two cores: `python -m benchmarks.results --list`.
results: $(STAMP)
	$(BIN)/python -m benchmarks.results $(PART) $(if $(STALE),--stale) $(if $(OVERWRITE),--overwrite) $(if $(DRY_RUN),--dry-run)

# Every kernel compiles anew on first use (importing tether_gym does the same by itself when
# the kernels' sources changed: tether_gym/kernel_cache.py).
clean-cache:
	find tether_gym -name "*.nbi" -delete -o -name "*.nbc" -delete

clean: clean-cache
	rm -rf $(VENV) .pytest_cache .ruff_cache build *.egg-info
