# nvstim — the two user commands:
#   make run    install missing Debian packages, build, run the default scenario
#   make test   the same set-up, then the whole test suite through ctest
# Everything else is CMake (CMakePresets.json): `cmake --preset debug-asan` etc.;
# `cmake --install build/release --prefix PREFIX` installs nvstim with its config and scenarios.

# Debian 12 packages the build, the tests and the runtime need. Only the missing ones are
# installed, and the list of them is printed first.
PACKAGES := build-essential cmake ninja-build pkg-config \
            libtomlplusplus-dev libcli11-dev libgtest-dev libgmock-dev libbenchmark-dev \
            librandom123-dev libgsl-dev liberfa-dev libembree-dev libopenexr-dev libfftw3-dev \
            libgpiod-dev libtinyobjloader-dev libssl-dev libpng-dev python3 python3-ephem clang-format ffmpeg \
            qemu-system-x86 busybox-static can-utils v4l-utils kmod cpio
# The last line is the HIL test's (tests/hil): a QEMU virtual machine with Debian's kernel,
# busybox, can-utils and v4l2-ctl; the kernel packages themselves are fetched by the test.

PRESET   ?= release
BUILD    := build/$(PRESET)
SUDO     := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
NVSTIM   := $(BUILD)/rt/cli/nvstim

SCENARIO ?= scenarios/thesis-nolight
OUT      := out

.PHONY: run test
run: .nvs-build
	@mkdir -p $(OUT)
	$(NVSTIM) run $(SCENARIO) --clock sim --output y4m:$(OUT)/$(notdir $(SCENARIO)).y4m \
	  --output contact:$(OUT)/$(notdir $(SCENARIO))-contact.png \
	  --output meta:$(OUT)/$(notdir $(SCENARIO)).jsonl
	@if command -v ffmpeg >/dev/null; then \
	  ffmpeg -y -loglevel error -i $(OUT)/$(notdir $(SCENARIO)).y4m -c:v libx264 -pix_fmt yuv420p \
	    $(OUT)/$(notdir $(SCENARIO)).mp4 && echo "nvstim: video        $(OUT)/$(notdir $(SCENARIO)).mp4"; fi
	@echo "nvstim: raw video    $(OUT)/$(notdir $(SCENARIO)).y4m   (play: ffplay $(OUT)/$(notdir $(SCENARIO)).y4m)"
	@echo "nvstim: contact sheet $(OUT)/$(notdir $(SCENARIO))-contact.png"
	@echo "nvstim: metadata     $(OUT)/$(notdir $(SCENARIO)).jsonl"
	@echo "nvstim: to send the same to a V4L2 device in real time instead (docs/hil.md):"
	@echo "  $(NVSTIM) run $(SCENARIO) --clock wall --output v4l2:/dev/videoN"
	@echo "nvstim: to install (binary, config, scenarios; runs from any directory):"
	@echo "  cmake --install $(BUILD) --prefix PREFIX"

# A skipped test says why in its output; those reasons are printed after the summary.
test: .nvs-build
	ctest --preset $(PRESET); rc=$$?; \
	  grep -h "SKIPPED:" $(BUILD)/Testing/Temporary/LastTest.log 2>/dev/null | sort -u; exit $$rc

.PHONY: .nvs-deps .nvs-build
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
