# nvstim — the two user commands:
#   make run    install missing Debian packages, build, run the default scenario
#   make test   the same set-up, then the whole test suite through ctest
#   make fuzz   the fuzz targets (tests/fuzz) under ASan+UBSan, FUZZ_SECONDS each (clang)
#   make deb   the same set-up, then the Debian package build/release/package/nvstim_*.deb
#              (CPack: binary, config and scenarios under /usr/share/nvstim, the manual page,
#              the bash completion, the GStreamer plugin and the Python module; docs/install.md)
#   make validate  the hidden-effect sweeps of `nvstim diagnose` (20 seeds per effect; the
#               open-world sweep of tests/diagnose_open, OPEN_SEEDS at OPEN_SIZE) and the
#               thesis datasets; writes $(BUILD)/validate/diagnose.md (docs/validation.md)
# Everything else is CMake (CMakePresets.json): `cmake --preset debug-asan` etc.;
# `cmake --install build/release --prefix PREFIX` installs nvstim with its config and scenarios.

# Debian 12 packages the build, the tests and the runtime need. Only the missing ones are
# installed, and the list of them is printed first.
PACKAGES := build-essential cmake ninja-build pkg-config \
            libtomlplusplus-dev libcli11-dev libgtest-dev libgmock-dev libbenchmark-dev \
            librandom123-dev libgsl-dev liberfa-dev libembree-dev libopenexr-dev libfftw3-dev \
            libgpiod-dev libtinyobjloader-dev libssl-dev libpng-dev python3 python3-ephem python3-matplotlib clang-format ffmpeg \
            python3-numpy python3-opencv \
            libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri libosmesa6-dev \
            qemu-system-x86 busybox-static can-utils v4l-utils kmod cpio gpiod \
            qemu-user valgrind \
            libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev gstreamer1.0-tools \
            pybind11-dev python3-dev python3-pytest \
            slurm-wlm munge dpkg-dev file
# libegl-dev, libgl-dev: headers of the OpenGL primary-visibility pass (sim/render/gl_*); Mesa's
# EGL (libegl-mesa0), its llvmpipe driver (libgl1-mesa-dri) and OSMesa (libosmesa6-dev) run it
# without a GPU. They are loaded at run time, so nvstim builds and runs without them.
# python3-numpy and python3-opencv: the reference fusion consumer (examples/fusion, docs/fusion.md)
# and its tests (tests/fusion, tests/hil's fusion case).
# The line from qemu-system-x86 to gpiod is the HIL test's (tests/hil): a QEMU virtual machine
# with Debian's kernel, busybox, can-utils, v4l2-ctl and libgpiod's tools (gpiod: gpiodetect,
# gpioinfo, gpiomon); the kernel packages themselves (and linux-source-6.1 for gpio-sim) are
# fetched by the test.
# qemu-user runs the isa.* tests as CPUs without AVX-512 (tests/isa), valgrind the memcheck.*
# tests (tests/memcheck).
# The last three lines: the GStreamer source element (rt/gst; gst-launch-1.0 and gst-inspect-1.0
# from gstreamer1.0-tools test it; its gstreamer-video-1.0.pc is in
# libgstreamer-plugins-base1.0-dev: without it the plugin is not built, the gst.* tests skip and
# deb.install_run_remove fails), the Python module (python/; pybind11, tested with pytest), the
# Slurm job array of `nvstim sweep` (tests/sweep starts munge, slurmctld and slurmd from
# slurm-wlm on this machine) and the Debian package (`make deb`: CPack's DEB generator computes
# its dependencies with dpkg-shlibdeps from dpkg-dev; `file` is what CPack runs on binaries).

PRESET   ?= release
BUILD    := build/$(PRESET)
SUDO     := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
NVSTIM   := $(BUILD)/rt/cli/nvstim

SCENARIO ?= scenarios/thesis-nolight
OUT      := out

# `make fuzz` only: clang and libFuzzer (libclang-rt-14-dev) for the `fuzz` preset. `make test`
# does not need them: it replays the seed corpora with the release compiler.
FUZZ_PACKAGES := clang libclang-rt-14-dev
FUZZ_SECONDS  ?= 60
FUZZ_TARGETS  := dbc candump nmea mavlink scenario camera csv obj image frame_pattern
FUZZ_BUILD    := build/fuzz

.PHONY: run test fuzz validate deb
# SCENARIO: a folder, a .toml file or the bare name of a shipped scenario (nvstim looks NAME up
# in scenarios/ itself); the outputs are named after its last part (thesis-stlamp,
# scenarios/thesis-stlamp/ and scenarios/thesis-stlamp/scenario.toml all give thesis-stlamp).
run: RUN_NAME = $(basename $(notdir $(patsubst %/scenario.toml,%,$(patsubst %/,%,$(SCENARIO)))))
run: .nvs-build
	@mkdir -p $(OUT)
	$(NVSTIM) run $(SCENARIO) --clock sim --output y4m:$(OUT)/$(RUN_NAME).y4m \
	  --output contact:$(OUT)/$(RUN_NAME)-contact.png \
	  --output meta:$(OUT)/$(RUN_NAME).jsonl
	@if command -v ffmpeg >/dev/null; then \
	  ffmpeg -y -loglevel error -i $(OUT)/$(RUN_NAME).y4m -c:v libx264 -pix_fmt yuv420p \
	    $(OUT)/$(RUN_NAME).mp4 && echo "nvstim: video        $(OUT)/$(RUN_NAME).mp4"; fi
	@echo "nvstim: raw video    $(OUT)/$(RUN_NAME).y4m   (play: ffplay $(OUT)/$(RUN_NAME).y4m)"
	@echo "nvstim: contact sheet $(OUT)/$(RUN_NAME)-contact.png"
	@echo "nvstim: metadata     $(OUT)/$(RUN_NAME).jsonl"
	@echo "nvstim: to send the same to a V4L2 device in real time instead (docs/hil.md):"
	@echo "  $(NVSTIM) run $(SCENARIO) --clock wall --output v4l2:/dev/videoN"
	@echo "nvstim: to install (binary, config, scenarios; runs from any directory):"
	@echo "  cmake --install $(BUILD) --prefix PREFIX"

# The package's dependencies come from the binaries (dpkg-shlibdeps); install it with
# `sudo dpkg -i build/release/package/nvstim_*.deb` (or `sudo apt install ./build/...deb`).
deb: .nvs-build
	cd $(BUILD) && cpack --config CPackConfig.cmake -B package
	@ls -1 $(BUILD)/package/nvstim_*.deb | sed 's/^/nvstim: package /'

# A skipped test says why in its output; those reasons are printed after the summary.
test: .nvs-build
	ctest --preset $(PRESET); rc=$$?; \
	  grep -h "SKIPPED:" $(BUILD)/Testing/Temporary/LastTest.log 2>/dev/null | sort -u; exit $$rc

# Each target runs FUZZ_SECONDS on its seeds (tests/fuzz/NAME/corpus, read only) and a working
# corpus in build/fuzz/corpus/NAME; a finding stops with the crashing input under
# build/fuzz/artifacts/NAME/ (add it to the seeds once fixed).
fuzz: .nvs-fuzz-deps
	@[ -f $(FUZZ_BUILD)/CMakeCache.txt ] || cmake --preset fuzz
	cmake --build --preset fuzz
	@for t in $(FUZZ_TARGETS); do \
	  mkdir -p $(FUZZ_BUILD)/corpus/$$t $(FUZZ_BUILD)/artifacts/$$t; \
	  echo "nvstim: fuzzing $$t for $(FUZZ_SECONDS) s"; \
	  $(FUZZ_BUILD)/tests/fuzz/nvs_fuzz_$$t -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 \
	    -artifact_prefix=$(FUZZ_BUILD)/artifacts/$$t/ $(FUZZ_BUILD)/corpus/$$t tests/fuzz/$$t/corpus \
	    || { echo "nvstim: fuzz target $$t found a crash: $(FUZZ_BUILD)/artifacts/$$t/" >&2; exit 1; }; \
	done

.PHONY: .nvs-deps .nvs-fuzz-deps .nvs-build
.nvs-fuzz-deps:
	@$(MAKE) --no-print-directory .nvs-deps PACKAGES="$(PACKAGES) $(FUZZ_PACKAGES)"

VALIDATE := $(BUILD)/validate
# The open-world sweep (tests/diagnose_open, docs/validation.md): every effect of open_world.py,
# OPEN_SEEDS seeds at OPEN_SIZE, 40 frames. At full size it is the longest part of validate
# (about a minute a dataset on this 2-core machine); OPEN_SEEDS=3 OPEN_SIZE=256x160 runs in
# about 7 minutes.
OPEN_SEEDS ?= 20
# The hidden-effect sweeps run one case a job through `nvstim sweep` (tests/sweep/validate-*.toml,
# docs/sweep.md), VALIDATE_JOBS cases at once; each sweep's folder holds its results table.
VALIDATE_JOBS ?= 2
OPEN_SIZE ?= 768x494
validate: .nvs-build
	@mkdir -p $(VALIDATE)
	rm -rf $(VALIDATE)/sweep-diagnose $(VALIDATE)/sweep-scene
	$(NVSTIM) sweep tests/sweep/validate-diagnose.toml --out $(VALIDATE)/sweep-diagnose \
	  --jobs $(VALIDATE_JOBS) --var build=$(BUILD) --var seeds=20
	cp $(VALIDATE)/sweep-diagnose/table.md $(VALIDATE)/diagnose.md
	$(NVSTIM) sweep tests/sweep/validate-scene.toml --out $(VALIDATE)/sweep-scene \
	  --jobs $(VALIDATE_JOBS) --var build=$(BUILD) --var seeds=20
	cp $(VALIDATE)/sweep-scene/table.md $(VALIDATE)/diagnose-scene.md
	rm -rf $(VALIDATE)/thesis && python3 tests/data/diagnose/make_thesis_datasets.py tests/data/thesis $(VALIDATE)/thesis
	$(BUILD)/tests/rt/thesis_scene/nvs_thesis_scene_datasets tests/data/thesis $(VALIDATE)/thesis
	/usr/bin/python3 tests/diagnose_open/sweep.py --effects all --seeds $(OPEN_SEEDS) --size $(OPEN_SIZE) \
	  --frames 40 --jobs 2 --nvstim $(NVSTIM) --out $(VALIDATE)/diagnose-open.md --json $(VALIDATE)/diagnose-open.json
	@for d in $(VALIDATE)/thesis/*/; do \
	  echo "nvstim: diagnose $$d"; \
	  $(NVSTIM) diagnose $$d --json $${d%/}.json --report $${d%/}-report 2>/dev/null || exit 1; \
	done
	@echo "nvstim: sweep tables $(VALIDATE)/diagnose.md $(VALIDATE)/diagnose-scene.md $(VALIDATE)/diagnose-open.md; thesis findings $(VALIDATE)/thesis/*.json"

.nvs-deps:
	@missing=""; \
	for p in $(PACKAGES); do \
	  dpkg-query -W -f='$${Status}\n' "$$p" 2>/dev/null | grep -q '^install ok installed$$' \
	    || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "nvstim: installing missing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing \
	    || { echo "nvstim: apt-get install failed for:$$missing" >&2; exit 1; }; \
	fi

.nvs-build: .nvs-deps
	@[ -f $(BUILD)/CMakeCache.txt ] || cmake --preset $(PRESET)
	cmake --build --preset $(PRESET)
