#!/usr/bin/env bash
# deb.install_run_remove: the Debian package `make deb` builds installs with dpkg -i, runs the
# default scenario from /usr/bin, and removes cleanly.
#
# Step 1: cpack (the build's CPackConfig.cmake, DEB generator) into a temporary folder; the
#         package's control file names dependencies dpkg-shlibdeps computed (libembree3-3 among
#         them: the renderer links it) and its contents hold every installed path of
#         cmake/Packaging.cmake.
# Step 2: dpkg -i. The package's files are then where the system looks: /usr/bin/nvstim on
#         PATH, the manual page for man -w, the completion where bash-completion loads it, the
#         GStreamer plugin for gst-inspect-1.0, the Python module for Debian's /usr/bin/python3
#         (a python3 earlier on PATH, from pyenv or a venv, has its own search path).
# Step 3: from an empty directory, with no NVS_* variable, /usr/bin/nvstim runs the default
#         scenario (thesis-nolight, as `make run` does) for 3 frames to a y4m file of exactly
#         3 frames, reading /usr/share/nvstim/config.
# Step 4: dpkg -r: every file the package listed is gone, /usr/share/nvstim with it, and dpkg
#         knows no nvstim.
# The test changes the machine's /usr, so it runs only as root (or with passwordless sudo) and
# never where an nvstim package or a /usr/bin/nvstim is already installed: it says SKIPPED and
# why. A failing step removes the package again before it exits.
# Usage: deb_test.sh BUILD_DIR
set -euo pipefail
build=$1
frames=3

if [ "$(id -u)" = 0 ]; then
  SUDO=""
elif sudo -n true 2>/dev/null; then
  SUDO="sudo -n"
else
  echo "SKIPPED: dpkg -i needs root (not root, and sudo asks for a password)"; exit 0
fi
if dpkg-query -W -f='${Status}' nvstim 2>/dev/null | grep -q 'install ok installed'; then
  echo "SKIPPED: an nvstim package is installed on this machine; the test will not replace it"
  exit 0
fi
if [ -e /usr/bin/nvstim ]; then
  echo "SKIPPED: /usr/bin/nvstim exists (not from a package); the test will not overwrite it"
  exit 0
fi
for tool in cpack dpkg-deb dpkg-shlibdeps; do
  command -v "$tool" >/dev/null || { echo "SKIPPED: $tool not found (dpkg-dev, cmake)"; exit 0; }
done

tmp=$(mktemp -d "${TMPDIR:-/tmp}/nvs-deb-test.XXXXXX")
installed=0
cleanup() {
  if [ "$installed" = 1 ]; then $SUDO dpkg -r nvstim >/dev/null 2>&1 || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT

# Step 1: the package.
(cd "$build" && cpack --config CPackConfig.cmake -B "$tmp/pkg") >"$tmp/cpack.log" 2>&1 \
  || { cat "$tmp/cpack.log" >&2; echo "deb_test: cpack failed" >&2; exit 1; }
deb=$(ls "$tmp"/pkg/nvstim_*.deb)
depends=$(dpkg-deb -f "$deb" Depends)
echo "deb_test: $(basename "$deb"), $(du -k "$deb" | cut -f1) kB; Depends: $depends"
for dep in libembree3 libopenexr libc6 python3; do
  echo "$depends" | grep -q "$dep" || { echo "deb_test: Depends lacks $dep" >&2; exit 1; }
done
dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|' >"$tmp/contents"
want=(/usr/bin/nvstim /usr/share/nvstim/config/cameras/ /usr/share/nvstim/scenarios/thesis-nolight/scenario.toml
      /usr/share/man/man1/nvstim.1.gz /usr/share/bash-completion/completions/nvstim)
for f in "${want[@]}"; do
  grep -qx "$f" "$tmp/contents" || { echo "deb_test: the package lacks $f" >&2; exit 1; }
done

# Step 2: install.
$SUDO dpkg -i "$deb" >"$tmp/dpkg-i.log" 2>&1 \
  || { cat "$tmp/dpkg-i.log" >&2; echo "deb_test: dpkg -i failed" >&2; $SUDO dpkg -r nvstim >/dev/null 2>&1 || true; exit 1; }
installed=1
[ "$(command -v nvstim)" = /usr/bin/nvstim ] || { echo "deb_test: nvstim is not /usr/bin/nvstim on PATH" >&2; exit 1; }
man -w nvstim | grep -q '^/usr/share/man/man1/nvstim.1.gz$' || { echo "deb_test: man -w nvstim does not find the page" >&2; exit 1; }
# The completion completes a subcommand and an option.
words=$(bash -c 'source /usr/share/bash-completion/completions/nvstim; COMP_WORDS=(nvstim ru); COMP_CWORD=1; _nvstim; echo "${COMPREPLY[*]}"')
[ "$words" = run ] || { echo "deb_test: completion of 'nvstim ru' gave '$words'" >&2; exit 1; }
words=$(bash -c 'source /usr/share/bash-completion/completions/nvstim; COMP_WORDS=(nvstim run --clo); COMP_CWORD=2; _nvstim; echo "${COMPREPLY[*]}"')
[ "$words" = --clock ] || { echo "deb_test: completion of 'nvstim run --clo' gave '$words'" >&2; exit 1; }
# The GStreamer plugin and the Python module, where the package has them.
if grep -q 'gstreamer-1.0/libgstnvstim.so$' "$tmp/contents"; then
  GST_REGISTRY=$tmp/registry.bin gst-inspect-1.0 nvstimsrc >"$tmp/inspect.log" 2>&1 \
    || { cat "$tmp/inspect.log" >&2; echo "deb_test: gst-inspect-1.0 does not find the installed nvstimsrc" >&2; exit 1; }
else
  echo "deb_test: the package has no GStreamer plugin" >&2; exit 1
fi
if grep -q '^/usr/lib/python3/dist-packages/nvstim' "$tmp/contents"; then
  (cd "$tmp" && env -u PYTHONPATH /usr/bin/python3 -c 'import nvstim, sys; assert nvstim.__file__.startswith("/usr/lib/python3/dist-packages"), nvstim.__file__') \
    || { echo "deb_test: python3 does not import the installed nvstim module" >&2; exit 1; }
else
  echo "deb_test: the package has no Python module" >&2; exit 1
fi

# Step 3: the default scenario from /usr/bin, from an empty directory, no NVS_* variables.
mkdir "$tmp/work" && cd "$tmp/work"
env -u NVS_CONFIG_DIR NVS_CACHE_DIR="$tmp/cache" /usr/bin/nvstim run /usr/share/nvstim/scenarios/thesis-nolight \
  --clock sim --frames $frames --output y4m:x.y4m >"$tmp/run.log" 2>&1 \
  || { cat "$tmp/run.log" >&2; echo "deb_test: the installed nvstim failed on the default scenario" >&2; exit 1; }
header=$(head -n 1 x.y4m)
w=$(echo "$header" | tr ' ' '\n' | sed -n 's/^W//p')
h=$(echo "$header" | tr ' ' '\n' | sed -n 's/^H//p')
bytes=1
echo "$header" | grep -q 'C mono16' && bytes=2
expect=$(( ${#header} + 1 + frames * (6 + w * h * bytes) ))
[ "$(stat -c %s x.y4m)" = "$expect" ] || { echo "deb_test: x.y4m is $(stat -c %s x.y4m) bytes, $frames frames of ${w}x${h} are $expect" >&2; exit 1; }
echo "deb_test: /usr/bin/nvstim ran thesis-nolight: $frames frames ${w}x${h}"

# Step 4: remove.
cd "$tmp"
$SUDO dpkg -r nvstim >"$tmp/dpkg-r.log" 2>&1 || { cat "$tmp/dpkg-r.log" >&2; echo "deb_test: dpkg -r failed" >&2; exit 1; }
installed=0
left=0
while read -r f; do
  case "$f" in */) continue ;; esac
  if [ -e "$f" ] && [[ "$f" == /usr/bin/* || "$f" == /usr/share/nvstim/* || "$f" == */nvstim* ]]; then
    echo "deb_test: $f is still there after dpkg -r" >&2; left=1
  fi
done <"$tmp/contents"
[ ! -e /usr/share/nvstim ] || { echo "deb_test: /usr/share/nvstim is still there" >&2; left=1; }
[ "$left" = 0 ] || exit 1
if dpkg-query -W -f='${Status}' nvstim 2>/dev/null | grep -q 'install ok installed'; then
  echo "deb_test: dpkg still lists nvstim as installed" >&2; exit 1
fi
echo "deb_test: installed, ran and removed cleanly"
