#!/usr/bin/env bash
# install.run_installed: an installed nvstim runs a shipped scenario from any directory.
#
# Step 1: `cmake --install BUILD --prefix P` into a fresh temporary prefix.
# Step 2: from an empty temporary directory, with NVS_CONFIG_DIR unset (so that only the
#         installed <bin>/../share/nvstim/config can be found), render 5 frames of the
#         installed thesis-nolight scenario to x.y4m.
# Step 3: x.y4m is a YUV4MPEG2 stream of exactly 5 frames: its size is the header plus
#         5 × ("FRAME\n" + W·H·bytes per sample), and every frame starts with "FRAME".
# Step 4: the data came from the installed config, not from the source tree's config/ (the
#         last fallback, which exists while the build tree does): with an unknown key added to
#         the installed camera preset, the same run must stop with a setup error (status 2)
#         naming the installed preset.
# Usage: install_test.sh CMAKE_COMMAND BUILD_DIR
# NVS_INSTALL_TEST_USE_ENV=1 sets NVS_CONFIG_DIR to the installed config instead of relying on
# the binary's own lookup: it checks the install and steps 2-4 apart from that lookup.
set -euo pipefail
cmake_cmd=$1
build=$2
frames=5

tmp=$(mktemp -d "${TMPDIR:-/tmp}/nvs-install-test.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
work=$tmp/work
mkdir -p "$work"

# Step 1: install.
"$cmake_cmd" --install "$build" --prefix "$prefix" >"$tmp/install.log" \
  || { cat "$tmp/install.log" >&2; echo "install_test: cmake --install failed" >&2; exit 1; }
for f in bin/nvstim share/nvstim/config share/nvstim/scenarios/thesis-nolight/scenario.toml; do
  [ -e "$prefix/$f" ] || { echo "install_test: $f not installed" >&2; exit 1; }
done
if find "$prefix" -name check-failures -o -name __pycache__ | grep -q .; then
  echo "install_test: check-failures or __pycache__ installed" >&2; exit 1
fi

# Step 2: run from an empty directory without the environment override.
cd "$work"
unset NVS_CONFIG_DIR
if [ "${NVS_INSTALL_TEST_USE_ENV:-0}" = 1 ]; then export NVS_CONFIG_DIR=$prefix/share/nvstim/config; fi
run_installed() {
  "$prefix/bin/nvstim" run "$prefix/share/nvstim/scenarios/thesis-nolight" --clock sim \
    --frames "$frames" --output "y4m:$1"
}
run_installed x.y4m

# Step 3: count the frames.
[ -s x.y4m ] || { echo "install_test: x.y4m missing or empty" >&2; exit 1; }
header=$(head -n 1 x.y4m)
read -r magic rest <<<"$header"
[ "$magic" = YUV4MPEG2 ] || { echo "install_test: not a y4m stream: $header" >&2; exit 1; }
width=$(sed -n 's/.* W\([0-9]*\).*/\1/p' <<<"$header")
height=$(sed -n 's/.* H\([0-9]*\).*/\1/p' <<<"$header")
case " $header " in
  *" Cmono16 "*) bytes=2 ;;
  *" Cmono "*) bytes=1 ;;
  *) echo "install_test: unexpected colour space in: $header" >&2; exit 1 ;;
esac
frame_bytes=$((6 + width * height * bytes))
expected=$((${#header} + 1 + frames * frame_bytes))
actual=$(stat -c %s x.y4m)
[ "$actual" -eq "$expected" ] \
  || { echo "install_test: x.y4m is $actual bytes, $frames frames of ${width}x$height need $expected" >&2; exit 1; }
for ((k = 0; k < frames; ++k)); do
  marker=$(dd if=x.y4m bs=1 skip=$((${#header} + 1 + k * frame_bytes)) count=6 2>/dev/null | tr '\n' '|')
  [ "$marker" = "FRAME|" ] || { echo "install_test: frame $k does not start with FRAME" >&2; exit 1; }
done

# Step 4: an installed preset with an unknown key must be what stops the run.
preset=$prefix/share/nvstim/config/cameras/pulnix-ag5745ef3.toml
echo "nvs_install_test_unknown_key = 1" >>"$preset"
status=0
run_installed y.y4m 2>"$tmp/broken.err" || status=$?
if [ "$status" -ne 2 ] || ! grep -q "share/nvstim/config/cameras/pulnix-ag5745ef3.toml" "$tmp/broken.err"; then
  echo "install_test: the installed nvstim did not read the installed config (it ignored an" \
       "unknown key in $preset; status $status, stderr: $(head -c 300 "$tmp/broken.err"))" >&2
  exit 1
fi
echo "install_test: $frames frames of ${width}x$height from the installed nvstim and its installed config"
