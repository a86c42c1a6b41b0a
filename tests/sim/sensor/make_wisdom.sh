#!/usr/bin/env bash
# Makes the camera chains' shipped FFTW wisdom (sim/core/fft_plans.h, docs/portability.md): the
# intensified chain's blur and the microbolometer optics' MTF.
#   make_wisdom.sh BUILD_DIR CONFIG_DIR [WxH ...]
# The plans (FFTW_MEASURE) are made as a CPU with SSE4.2 only, under Debian's qemu-user, so that
# they name SSE2 codelets, which every x86-64 CPU has; they are written twice, once under the
# header (FFTW's hash of the solvers it registers) of CPUs without AVX, as FFTW wrote them
# (CONFIG_DIR/fftw/wisdom-single-sse.txt), and once under the header of CPUs with AVX
# (CONFIG_DIR/fftw/wisdom-single.txt). FFTW takes only the file whose header matches its CPU.
# WxH: frame sizes besides the shipped presets' (default 1280x1024, the SXGA scenario's).
# The plans already in CONFIG_DIR/fftw/wisdom-single-sse.txt are kept as they are (imported
# first; the planner measures only the problems they lack), so that adding a preset changes no
# existing plan and no replay digest; NVS_WISDOM_FRESH=1 plans everything anew.
set -euo pipefail
build=$1 config=$2
shift 2
sizes=("${@:-1280x1024}")
tool="$build/tests/sim/sensor/nvs_fftw_wisdom"
q=(qemu-x86_64 -cpu Nehalem-v2)
out="$config/fftw"
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# The presets are read from a copy without fftw/: no wisdom is loaded first.
cp -r "$config" "$tmp/config" && rm -rf "$tmp/config/fftw"
keep=()
if [ "${NVS_WISDOM_FRESH:-0}" != 1 ] && [ -f "$out/wisdom-single-sse.txt" ]; then
  keep=(--import "$out/wisdom-single-sse.txt")
fi
"${q[@]}" "$tool" --measure "${keep[@]}" "$tmp/config" "$tmp/sse.txt" "${sizes[@]}" 2>/dev/null
if [ ${#keep[@]} -gt 0 ]; then
  # Every entry of the old file is still there (FFTW may write them in another order).
  missing=$(grep -vxF -f "$tmp/sse.txt" <(tail -n +2 "$out/wisdom-single-sse.txt") | sed 's/)$//' \
            | grep -vF -f <(sed 's/)$//' "$tmp/sse.txt") || true)
  [ -z "$missing" ] || { echo "make_wisdom: plans of the old wisdom changed:" >&2; echo "$missing" >&2; exit 1; }
fi
sse=$("${q[@]}" "$tool" --signature 2>/dev/null)
avx=$(qemu-x86_64 -cpu Haswell-v4 "$tool" --signature 2>/dev/null)
[ "$(head -n1 "$tmp/sse.txt")" = "$sse" ] || { echo "make_wisdom: unexpected header" >&2; exit 1; }
[ "$sse" != "$avx" ] || { echo "make_wisdom: the two headers are the same" >&2; exit 1; }
cp "$tmp/sse.txt" "$out/wisdom-single-sse.txt"
{ echo "$avx"; tail -n +2 "$tmp/sse.txt"; } > "$out/wisdom-single.txt"
echo "make_wisdom: $out/wisdom-single.txt (CPUs with AVX), $out/wisdom-single-sse.txt (without)"
