# Two commands for a newcomer (see README):
#   make demo   set up the venv (first time) and run the dressed, walking character
#   make test   set up the venv (first time), run `ruff check .`, then the test suite
#   make bench      every benchmark, the figures and their ratios (PEERS_VENV=... adds the peers)
#   make evaluate   do the garments stay on real motion: every shared mocap clip (issue 11's table)
PYTHON ?= python3.11
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
DURATION ?= 20
BVH ?=
GARMENTS ?=
MOCAP ?= ../shared/mocap
JOBS ?= 2
PEERS ?= ../shared/peers
PEERS_VENV ?= /tmp/peers-venv
BENCHES ?=

.PHONY: venv demo test bench evaluate clean

venv: $(STAMP)

# Re-run when the pins or the package metadata change; otherwise the venv is reused.
$(STAMP): requirements.txt setup.py package.xml tools/build_tf2_msgs.sh $(wildcard tools/tf2_msgs/*.txt tools/tf2_msgs/*.xml tools/tf2_msgs/msg/*.msg)
	@test -x "$$(command -v $(PYTHON))" || { echo "error: $(PYTHON) not found; set PYTHON=/path/to/python3.11"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	VENV=$(VENV) bash tools/build_tf2_msgs.sh
	$(PY) -m garment_sim_ros.warmup
	$(PY) -c "import rclpy, tf2_msgs.msg, visualization_msgs.msg, numba, rerun; print('venv ready:', rclpy.__name__, numba.__version__, rerun.__version__)"
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/garment-sim demo --duration $(DURATION) $(if $(BVH),--bvh $(BVH),) $(if $(GARMENTS),--garments $(GARMENTS),)

# Lint first (ruff.toml: pyflakes, pycodestyle, import order); a finding fails the target before pytest runs.
# Several real-motion tests follow one chaotic trajectory of the cloth; numpy's AVX-512 kernels (sin, cos, exp of
# float64, SVML) round differently from its AVX2 ones, so they are switched off for the tests: an AVX-512 machine
# then plays what an AVX2 one does (a guess, README "Tests and the machine": this machine has no AVX-512).
NPY_TEST_FEATURES ?= X86_V4 AVX512_ICL AVX512_SPR
test: $(STAMP)
	$(VENV)/bin/ruff check .
	NPY_DISABLE_CPU_FEATURES="$(NPY_TEST_FEATURES)" $(PY) -m pytest -q test

# Every benchmark, then the issue-15 figures against their targets with ratios to the roofline and, when
# PEERS_VENV exists, the peers measured in the same run (JSON lines in out/bench.jsonl, and a table).
bench: $(STAMP)
	PEERS=$(PEERS) PEERS_VENV=$(PEERS_VENV) $(PY) bench/run.py $(if $(BENCHES),--only $(BENCHES),)

# Every clip x garment x 1, 2, 3x playback x 60, 30 fps; fails (exit 1) while a run misses a target.
evaluate: $(STAMP)
	$(VENV)/bin/garment-sim evaluate $(MOCAP)/*.bvh --garments all --speeds 1,2,3 --fps 60,30 --jobs $(JOBS)

clean:
	rm -rf $(VENV) out build *.egg-info
