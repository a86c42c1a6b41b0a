#!/usr/bin/env bash
# The microbolometer chain's frames as other CPUs compute them (docs/portability.md):
#   isa_frames.sh TOOL CONFIG_DIR PRESET FRAMES QEMU CPU
# runs TOOL (nvs_bolometer_frames) natively and under QEMU -cpu CPU and requires the same
# lines (every frame's digest of raw and display, bit for bit). Exit 77 (skipped) without qemu.
set -euo pipefail
tool=$1 config=$2 preset=$3 frames=$4 qemu=$5 cpu=$6
command -v "$qemu" >/dev/null 2>&1 || { echo "no $qemu: skipped"; exit 77; }
native=$("$tool" "$config" "$preset" "$frames")
emulated=$("$qemu" -cpu "$cpu" "$tool" "$config" "$preset" "$frames")
echo "$native" | head -n 1
if [ "$native" != "$emulated" ]; then
  echo "isa_frames: $preset differs as $cpu:" >&2
  diff <(echo "$native") <(echo "$emulated") >&2 || true
  exit 1
fi
echo "isa_frames: $preset, $frames frames: the same bits natively and as $cpu"
