#!/usr/bin/env bash
# One shipped scenario on another instruction set (docs/portability.md): FRAMES frames on this
# machine's CPU as it is, and again with a command prefix that changes the instruction set:
# Debian's qemu-user as another CPU (`qemu-x86_64 -cpu Haswell-v4`: AVX2; `-cpu Nehalem-v2`:
# SSE4.2) or Embree pinned natively (`env NVS_EMBREE_ISA=sse4.2`); then
#   1. the renderer's radiance (run --output exr:) within the tolerance nvs_isa_compare states;
#   2. the camera chain's bits for the same radiance: `nvstim sensor` on the host's radiance
#      files, on the host and under qemu, must give identical frames;
#   3. the scenario's frames (run --output pgm:): identical where the radiance is, else within
#      the frame tolerance nvs_isa_compare states.
# Usage: isa_scenario.sh NVSTIM COMPARE SCENARIO_DIR WORK_DIR FRAMES LABEL PREFIX...
# Exit 77 (ctest: skipped) when the prefix's program is not installed.
set -euo pipefail
nvstim=$1 compare=$2 scen=$3 work=$4 frames=$5 label=$6
shift 6
prefix=("$@")
if ! command -v "${prefix[0]}" >/dev/null 2>&1; then
  echo "SKIPPED: ${prefix[0]} is not installed (qemu-x86_64: Debian package qemu-user, which" \
       "make test installs)"
  exit 77
fi
name=$(basename "$scen")
rm -rf "$work" && mkdir -p "$work"
toml="$scen/scenario.toml"
preset=$(sed -n 's/^preset *= *"\([^"]*\)".*/\1/p' "$toml" | head -n1)
width=$(sed -n 's/^width *= *\([0-9]*\).*/\1/p' "$toml" | head -n1)
height=$(sed -n 's/^height *= *\([0-9]*\).*/\1/p' "$toml" | head -n1)

run_on() {  # run_on LABEL PREFIX...: the scenario's first frames, radiance and frames
  local label=$1; shift
  local t0=$SECONDS
  "$@" "$nvstim" run "$toml" --clock sim --frames "$frames" \
    --output "exr:$work/$label/exr" --output "pgm:$work/$label/pgm" >"$work/$label.log" 2>&1 \
    || { cat "$work/$label.log"; echo "$name: run on $label failed"; exit 1; }
  echo "$name: $frames frames on $label in $((SECONDS - t0)) s"
}
sense_on() {  # sense_on LABEL PREFIX...: the camera chain on the host's radiance files
  local label=$1; shift
  local set=()
  if [ -n "$width" ]; then set=(--set "width=$width" --set "height=$height"); fi
  mkdir -p "$work/$label/sensor"
  "$@" "$nvstim" sensor --in "$work/host/exr/{frame:06d}.exr" --camera "$preset" "${set[@]}" \
    --frames "$frames" --seed 7 --out "$work/$label/sensor/{frame:06d}.pgm" \
    >"$work/$label.sensor.log" 2>&1 \
    || { cat "$work/$label.sensor.log"; echo "$name: sensor on $label failed"; exit 1; }
}

run_on host env
run_on "$label" "${prefix[@]}"
echo "$name: radiance, $label against the host:"
"$compare" radiance "$work/host/exr" "$work/$label/exr"
sense_on host env
sense_on "$label" "${prefix[@]}"
echo "$name: camera chain on the host's radiance, $label against the host:"
"$compare" frames "$work/host/sensor" "$work/$label/sensor"
echo "$name: frames of the run, $label against the host:"
"$compare" run-frames "$work/host/pgm" "$work/$label/pgm"
echo "$name on $label: PASS"
