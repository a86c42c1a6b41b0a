#!/bin/bash
# The virtual machine's kernel layer for the HIL test, built from Debian packages and cached:
#   Debian 12's kernel (linux-image-amd64, 6.1), v4l2loopback built for exactly that kernel
#   (its source from v4l2loopback-dkms, compiled with make against the matching
#   linux-headers / linux-kbuild packages: what DKMS would do, without installing a kernel on
#   this machine), and the modules the test loads (vcan, can-raw, v4l2loopback, virtio-blk)
#   with their dependencies, in load order.
#
# Nothing is installed on the host: the packages are fetched with `apt-get download` and
# unpacked with dpkg-deb into a scratch folder. The result goes to DEST/kernel-KEY/, KEY being
# the kernel and v4l2loopback package versions and this script's hash; an existing one is reused.
#
#   make_kernel.sh DEST      prints the kernel folder on stdout (progress on stderr)
#
# The folder holds: vmlinuz, modules/ (the .ko files), modules.load (one "file [params]" a line,
# in insmod order), version (the kernel release), packages (what it was built from).
set -euo pipefail

dest=${1:?usage: make_kernel.sh DEST}
say() { echo "hil: $*" >&2; }

# Resolve the current Debian 12 kernel: linux-image-amd64 → linux-image-6.1.0-N-amd64.
resolve() {
    apt-cache depends linux-image-amd64 2>/dev/null |
        awk '/Depends: linux-image-[0-9]/ {print $2; exit}'
}
kpkg=$(resolve || true)
if [ -z "$kpkg" ]; then
    say "apt lists have no linux-image-amd64: apt-get update"
    apt-get update -qq >&2
    kpkg=$(resolve)
fi
[ -n "$kpkg" ] || { say "cannot resolve linux-image-amd64"; exit 1; }
kver=${kpkg#linux-image-}                       # 6.1.0-56-amd64
kabi=${kver%-amd64}                             # 6.1.0-56
pkgver=$(apt-cache show --no-all-versions "$kpkg" | awk '/^Version:/ {print $2; exit}')
kseries=$(echo "$kver" | cut -d. -f1,2)         # 6.1
v4lver=$(apt-cache show --no-all-versions v4l2loopback-dkms | awk '/^Version:/ {print $2; exit}')
self=$(sha256sum "$0" | cut -c1-12)
key="${kver}_${pkgver}_v4l2loopback-${v4lver}_${self}"
out="$dest/kernel-$key"
if [ -f "$out/modules.load" ]; then
    say "kernel layer cached: $out"
    echo "$out"
    exit 0
fi

say "building the kernel layer $key"
mkdir -p "$dest"
work=$(mktemp -d "$dest/.work.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work"
# apt-get download writes into the current folder; _apt must be able to write it.
chmod 0777 "$work"
pkgs=("$kpkg=$pkgver" "linux-headers-$kver=$pkgver" "linux-headers-$kabi-common=$pkgver"
      "linux-kbuild-$kseries=$pkgver" "v4l2loopback-dkms=$v4lver")
apt-get download -q "${pkgs[@]}" >&2 2> >(grep -v "unsandboxed" >&2)
root="$work/root"
for d in ./*.deb; do dpkg-deb -x "$d" "$root"; done

# v4l2loopback against the unpacked headers. The headers' Makefile includes the common part
# by its installed (absolute) path; point it at the unpacked one. Kernel docs:
# Documentation/kbuild/modules.rst ("make -C <headers> M=$PWD").
hdr="$root/usr/src/linux-headers-$kver"
sed -i "s#^include /usr/src/#include $root/usr/src/#" "$hdr/Makefile"
src=$(echo "$root"/usr/src/v4l2loopback-*)
make -s -C "$hdr" M="$src" modules >&2 2> >(grep -v "Skipping BTF" >&2)
mod="$root/lib/modules/$kver"
mkdir -p "$mod/extra"
cp "$src/v4l2loopback.ko" "$mod/extra/"
depmod -b "$root" "$kver"

# The modules and their dependencies in load order (kmod's modprobe resolves modules.dep).
mkdir -p "$work/out/modules"
: > "$work/out/modules.load"
for m in virtio_pci virtio_blk can_raw vcan v4l2loopback; do
    modprobe -d "$root" -S "$kver" --show-depends "$m" | awk '$1 == "insmod" {print $2}'
done | awk '!seen[$0]++' | while read -r ko; do
    name=$(basename "$ko")
    cp "$ko" "$work/out/modules/$name"
    echo "$name" >> "$work/out/modules.load"
done
cp "$root/boot/vmlinuz-$kver" "$work/out/vmlinuz"
echo "$kver" > "$work/out/version"
printf '%s\n' "${pkgs[@]}" > "$work/out/packages"
rm -rf "$out"
mv "$work/out" "$out"
say "kernel layer ready: $out"
echo "$out"
