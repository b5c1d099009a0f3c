# genie-gl: `make demo` builds a small demo dataset with preview pictures; `make test` runs the tests.
# Both set everything up first (system GL libraries, .venv, the package with its test extras).
SHELL := bash
.SHELLFLAGS := -eu -o pipefail -c
.DELETE_ON_ERROR:
.DEFAULT_GOAL := help
MAKEFLAGS += --no-print-directory

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
GENIE := $(VENV)/bin/genie
# GL for the renderer (EGL/Mesa, OSMesa fallback); libgl1, libx11-6, libusb-1.0-0 and libgomp1
# for Open3D, one of the independent readers the tests use
APT_PACKAGES := libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6 libgl1 libx11-6 libusb-1.0-0 libgomp1
# the tests' browser: Debian's chromium opens genie view's web viewer headless (WebGL on SwiftShader)
TEST_APT_PACKAGES := chromium
STAMP := $(VENV)/.setup-stamp
OUT ?= out
SEED ?= 0
SCENES ?= 3
CAMERAS ?= 8
WORKERS ?= 2
SENSOR ?= realsense_d435
FORMAT ?= semantickitti
# the demo's 3 sequences, one each to train, valid and test (0.8,0.1,0.1 would leave two splits empty)
DEMO_SPLIT ?= 1,1,1
PYTEST_ARGS ?= -n 2

.PHONY: help setup system-deps test-deps test test-slow mutants planted-bugs demo docs-images docs-view-image sensor-pages bench bench-render bench-layout bench-accuracy bench-pipeline bench-planning bench-stability bench-cli bench-sequence bench-odometry bench-eval studies \
        dataset-assembly-line dataset-storage-area dataset-logistics-lane clean

help: ## list the targets
	@grep -E '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN {FS = ":.*## "}; {printf "  %-24s %s\n", $$1, $$2}'

system-deps: ## install the system GL libraries (EGL/Mesa, OSMesa) with apt-get when missing
	@if ! ldconfig -p | grep -q 'libEGL_mesa.so.0' || ! ldconfig -p | grep -q 'libOSMesa.so' \
	    || ! ldconfig -p | grep -q 'libusb-1.0.so.0' || ! ldconfig -p | grep -q 'libGL.so.1' \
	    || ! ldconfig -p | grep -q 'libgomp.so.1' || ! ldconfig -p | grep -q 'libX11.so.6' \
	    || ! ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1; then \
	  echo "installing $(APT_PACKAGES)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] && echo "" || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $(APT_PACKAGES) >/dev/null; \
	fi

$(STAMP): pyproject.toml constraints.txt
	$(MAKE) system-deps
	[ -x $(PY) ] || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -c constraints.txt -e ".[test,neural,view]"
	# pyrender (the reference renderer) pins PyOpenGL==3.1.0, whose OSMesa import is broken:
	# install it without its pins; its real dependencies come with the test extra.
	$(PY) -m pip install -q -c constraints.txt --no-deps "pyrender==0.1.45"
	# semantic-kitti-api's declared dependencies pull torch, PyQt5 and vispy (~6 GB); its reader
	# and evaluation classes need only numpy and PyYAML: install it without them (tests read with it)
	$(PY) -m pip install -q -c constraints.txt --no-deps "semantic-kitti-api==0.1"
	# numba compiles genie-gl's kernels on first use (a minute or two, in every worker at once):
	# compile the demo recipe's kernels into numba's cache now, so the first make demo loads them
	$(PY) -c "from genie_gl.dataset.warmup import compile_kernels as c; print(f'kernels compiled and cached in {c(sensor=\"$(SENSOR)\", format=\"$(FORMAT)\"):.0f} s')"
	touch $(STAMP)

setup: $(STAMP) ## install system libraries, create .venv and install genie-gl with its test extras

test-deps: ## install what only the tests need (chromium, for the web viewer's test) with apt-get when missing
	@if ! command -v chromium >/dev/null 2>&1; then \
	  echo "installing $(TEST_APT_PACKAGES)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] && echo "" || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $(TEST_APT_PACKAGES) >/dev/null; \
	fi

test: setup test-deps ## ruff check, then the test suite (real GL on EGL/llvmpipe); tests marked slow are left to test-slow
	$(VENV)/bin/ruff check .
	$(PY) -m pytest $(PYTEST_ARGS)

docs-images: setup ## remake the README's pictures (one scene, seed 0) into docs/images
	$(PY) docs/make_images.py $(OUT)/docs

docs-view-image: setup test-deps ## the picture of genie view's web viewer on the demo dataset (make demo first) into docs/images
	$(PY) docs/make_view_image.py $(OUT)/demo

sensor-pages: setup ## each shipped profile's report card against published figures: pages and curves in docs/sensors
	$(GENIE) report-card --sensor all --seed $(SEED) --pages docs/sensors --out $(OUT)/report-card

test-slow: setup test-deps ## run only the slow tests (the cloud kernels again with numba's bounds checks on)
	$(PY) -m pytest $(PYTEST_ARGS) -m slow

MUTANT_MODULES ?= all
MUTANT_TIMEOUT ?= 3600
mutants: setup ## mutation testing of the numerical core: kill rate per module and the survivors (report in out/mutants/)
	$(PY) -m pip install -q -c constraints.txt -e ".[mutants]"
	mkdir -p $(OUT)/mutants
	$(PY) tools/mutants.py --modules $(MUTANT_MODULES) --timeout $(MUTANT_TIMEOUT) --recheck 900 2>&1 | tee $(OUT)/mutants/report.txt

planted-bugs: setup ## plant known bugs one at a time in build/planted/ and list the tests that catch each
	$(PY) tools/planted_bugs.py

demo: setup ## generate a 3-scene demo dataset with preview pictures into out/demo
	$(GENIE) dataset layouts/assembly_line.json --scenes $(SCENES) --cameras $(CAMERAS) \
	  --sensor $(SENSOR) --format $(FORMAT) --out $(OUT)/demo --workers $(WORKERS) --seed $(SEED) --split $(DEMO_SPLIT)
	@echo "demo dataset and previews in $(OUT)/demo (open $(OUT)/demo/previews/; genie view $(OUT)/demo --serve: a 3-D view in the browser)"

bench: setup ## run every benchmark (render, layout, accuracy, pipeline, stability, planning, cli); figures into out/bench
	$(VENV)/bin/pip install -q "open3d>=0.18" && { ldconfig -p | grep -q libusb-1.0 || apt-get install -y -qq libusb-1.0-0; } || echo "open3d unavailable: the render bench skips it"
	$(GENIE) bench render --out $(OUT)/bench
	$(GENIE) bench layout --out $(OUT)/bench
	$(GENIE) bench accuracy --out $(OUT)/bench
	$(GENIE) bench pipeline --out $(OUT)/bench
	$(GENIE) bench stability --out $(OUT)/bench
	$(GENIE) bench planning --out $(OUT)/bench
	$(GENIE) bench cli --out $(OUT)/bench

bench-render: setup ## renderer against pyrender and Open3D
	$(GENIE) bench render --out $(OUT)/bench
bench-layout: setup ## layout engine throughput (paper Table 7)
	$(GENIE) bench layout --out $(OUT)/bench
bench-accuracy: setup ## what each sensor effect and accuracy knob costs in time
	$(GENIE) bench accuracy --out $(OUT)/bench
bench-pipeline: setup ## seconds per scene end to end
	$(GENIE) bench pipeline --out $(OUT)/bench
bench-stability: setup ## hard cases against analytic truth (exit 1 if one fails its tolerance)
	$(GENIE) bench stability --out $(OUT)/bench
bench-eval: setup ## the classical model's training time on ~1 M points (makes a 10-scene dataset once)
	$(GENIE) dataset assembly_line --scenes 10 --cameras 16 --sensor realsense_d435 --out $(OUT)/eval-cache/datasets/assembly_line.realsense_d435.s0.n10.c16 --seed 0 --previews 0 --workers $(WORKERS)
	$(GENIE) eval --bench --train $(OUT)/eval-cache/datasets/assembly_line.realsense_d435.s0.n10.c16 --out $(OUT)/bench --workers $(WORKERS)
studies: setup ## every genie eval study (datasets made once under out/eval-cache; hours on 2 cores)
	$(GENIE) eval --study all --out $(OUT)/studies --cache $(OUT)/eval-cache --workers $(WORKERS) --yes
bench-planning: setup ## a full D435 / Azure frame before and after planning (x the ideal render)
	$(GENIE) bench planning --out $(OUT)/bench
bench-cli: setup ## seconds genie --help and every subcommand's --help take
	$(GENIE) bench cli --out $(OUT)/bench
bench-sequence: setup ## frames/s along a trajectory against the same number of standing frames
	$(GENIE) bench sequence --out $(OUT)/bench
bench-odometry: setup ## KISS-ICP on a SemanticKITTI sequence of ours; evo's ATE against its ground truth
	$(GENIE) bench odometry --out $(OUT)/bench

dataset-assembly-line: setup ## the paper's setup: make dataset-assembly-line SCENES=499 CAMERAS=40
	$(GENIE) dataset layouts/assembly_line.json --scenes $(SCENES) --cameras $(CAMERAS) \
	  --sensor $(SENSOR) --format $(FORMAT) --out $(OUT)/assembly_line --workers $(WORKERS) --seed $(SEED)
dataset-storage-area: setup ## storage area strategy
	$(GENIE) dataset layouts/storage_area.json --scenes $(SCENES) --cameras $(CAMERAS) \
	  --sensor $(SENSOR) --format $(FORMAT) --out $(OUT)/storage_area --workers $(WORKERS) --seed $(SEED)
dataset-logistics-lane: setup ## logistics lane strategy
	$(GENIE) dataset layouts/logistics_lane.json --scenes $(SCENES) --cameras $(CAMERAS) \
	  --sensor $(SENSOR) --format $(FORMAT) --out $(OUT)/logistics_lane --workers $(WORKERS) --seed $(SEED)

clean: ## remove build outputs (keeps .venv)
	rm -rf $(OUT) build dist *.egg-info .pytest_cache
