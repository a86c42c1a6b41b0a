#!/usr/bin/env bash
# qemu_run.sh QEMU CPU TMP PROGRAM ARGS...: PROGRAM as CPU would run it, under Debian's
# qemu-user, with TMP (made empty) as its temporary folder, so that the same test program running
# natively or as another CPU at the same time never shares a temporary file with it; exit 77
# (ctest: skipped) when qemu-x86_64 is not installed. QEMU "-" runs PROGRAM natively. Child processes the program starts
# run natively (qemu-user follows no exec): the replay tests start nvstim through
# tests/isa/qemu_nvstim.sh, which runs it under qemu too.
set -euo pipefail
qemu=$1 cpu=$2 tmp=$3
shift 3
rm -rf "$tmp" && mkdir -p "$tmp"
export TMPDIR="$tmp" TEST_TMPDIR="$tmp/"
if [ "$qemu" = - ]; then exec "$@"; fi
if ! command -v "$qemu" >/dev/null 2>&1; then
  echo "SKIPPED: $qemu is not installed (Debian package qemu-user, which make test installs)"
  exit 77
fi
export NVS_ISA_QEMU="$qemu" NVS_ISA_CPU="$cpu"
exec "$qemu" -cpu "$cpu" "$@"
