#!/usr/bin/env bash
# Makes the blur's shipped FFTW wisdom (sim/sensor/chain.cpp, docs/portability.md):
#   make_wisdom.sh BUILD_DIR CONFIG_DIR [WxH ...]
# The plans (FFTW_MEASURE) are made as a CPU with SSE4.2 only, under Debian's qemu-user, so that
# they name SSE2 codelets, which every x86-64 CPU has; they are written twice, once under the
# header (FFTW's hash of the solvers it registers) of CPUs without AVX, as FFTW wrote them
# (CONFIG_DIR/fftw/wisdom-single-sse.txt), and once under the header of CPUs with AVX
# (CONFIG_DIR/fftw/wisdom-single.txt). FFTW takes only the file whose header matches its CPU.
# WxH: frame sizes besides the shipped presets' (default 1280x1024, the SXGA scenario's).
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
"${q[@]}" "$tool" --measure "$tmp/config" "$tmp/sse.txt" "${sizes[@]}" 2>/dev/null
sse=$("${q[@]}" "$tool" --signature 2>/dev/null)
avx=$(qemu-x86_64 -cpu Haswell-v4 "$tool" --signature 2>/dev/null)
[ "$(head -n1 "$tmp/sse.txt")" = "$sse" ] || { echo "make_wisdom: unexpected header" >&2; exit 1; }
[ "$sse" != "$avx" ] || { echo "make_wisdom: the two headers are the same" >&2; exit 1; }
cp "$tmp/sse.txt" "$out/wisdom-single-sse.txt"
{ echo "$avx"; tail -n +2 "$tmp/sse.txt"; } > "$out/wisdom-single.txt"
echo "make_wisdom: $out/wisdom-single.txt (CPUs with AVX), $out/wisdom-single-sse.txt (without)"
