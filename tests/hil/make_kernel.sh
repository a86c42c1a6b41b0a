#!/bin/bash
# The virtual machine's kernel layer for the HIL test, built from Debian packages and cached:
#   Debian 12's kernel (linux-image-amd64, 6.1), v4l2loopback built for exactly that kernel
#   (its source from v4l2loopback-dkms, compiled with make against the matching
#   linux-headers / linux-kbuild packages: what DKMS would do, without installing a kernel on
#   this machine), gpio-sim built out of tree the same way from linux-source-6.1 (below), and
#   the modules the test loads (vcan, can-raw, v4l2loopback, virtio-blk, configfs, gpio-sim)
#   with their dependencies, in load order.
#
# gpio-sim: Debian's 6.1 kernel has CONFIG_GPIO_SIM and CONFIG_IRQ_SIM unset. Its source comes
# from linux-source-6.1 of the kernel's own version: drivers/gpio/gpio-sim.c (with gpiolib.h,
# internal to the kernel and absent from linux-headers) and kernel/irq/irq_sim.c, compiled as
# one module. irq_sim.c calls handle_simple_irq(irq_to_desc(irq)), and 6.1 does not export
# irq_to_desc to modules; generic_handle_irq(irq) runs the same handler (the one irq_sim
# sets, handle_simple_irq) and is exported. Where linux-source cannot be fetched or the module
# does not build, the layer is made without it and gpio-sim.skip says why (the HIL test then
# skips its GPIO case and says so).
#
# Nothing is installed on the host: the packages are fetched with `apt-get download` and
# unpacked with dpkg-deb into a scratch folder. The result goes to DEST/kernel-KEY/, KEY being
# the kernel and v4l2loopback package versions and this script's hash; an existing one is reused.
#
#   make_kernel.sh DEST      prints the kernel folder on stdout (progress on stderr)
#
# The folder holds: vmlinuz, modules/ (the .ko files), modules.load (one "file [params]" a line,
# in insmod order), version (the kernel release), packages (what it was built from), and either
# gpio-sim (the module's name: it was built) or gpio-sim.skip (the reason it was not).
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
# The version of package $1 to fetch for the kernel's $pkgver: that one where the archive still
# has it, else the newest with the same upstream version (Debian's security archive moves a
# package built from the kernel's source to a new upload, e.g. linux-kbuild-6.1 6.1.192-3 beside
# linux-image-6.1.0-56-amd64 6.1.192-2: the same kernel source, so the same host tools and
# headers), else the archive's candidate, with a note.
pick() {
    local all want=${pkgver%-*}
    all=$(apt-cache madison "$1" | awk '{print $3}')
    if echo "$all" | grep -qxF "$pkgver"; then echo "$pkgver"; return; fi
    local same
    same=$(echo "$all" | awk -v u="$want" '{v = $0; sub(/-[^-]*$/, "", v); if (v == u) {print; exit}}')
    if [ -n "$same" ]; then
        say "$1: $pkgver is gone from the archive; $same (the same upstream $want)"
        echo "$same"
        return
    fi
    say "$1: no $want in the archive; its candidate $(echo "$all" | head -n1)"
    echo "$all" | head -n1
}
pkgs=("$kpkg=$pkgver" "linux-headers-$kver=$(pick "linux-headers-$kver")"
      "linux-headers-$kabi-common=$(pick "linux-headers-$kabi-common")"
      "linux-kbuild-$kseries=$(pick "linux-kbuild-$kseries")" "v4l2loopback-dkms=$v4lver")
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

# gpio-sim (see the top). The source tarball (≈ 140 MB) is unpacked for three files only.
gpio_skip=""
srcpkg="linux-source-$kseries=$(pick "linux-source-$kseries")"
if ! apt-get download -q "$srcpkg" >&2 2> >(grep -v "unsandboxed" >&2); then
    gpio_skip="$srcpkg cannot be fetched (apt-get download failed)"
else
    say "building gpio-sim from $srcpkg"
    dpkg-deb -x ./linux-source-"$kseries"_*.deb "$work/lsrc"
    gs="$work/gpio-sim"
    mkdir -p "$gs"
    tar -xJf "$work/lsrc/usr/src/linux-source-$kseries.tar.xz" -C "$gs" --strip-components=3 \
        --wildcards "*/drivers/gpio/gpio-sim.c" "*/drivers/gpio/gpiolib.h" "*/kernel/irq/irq_sim.c" ||
        gpio_skip="$srcpkg has no drivers/gpio/gpio-sim.c, gpiolib.h or kernel/irq/irq_sim.c"
    rm -rf "$work/lsrc"
    if [ -z "$gpio_skip" ]; then
        # One module named gpio-sim from two objects (Documentation/kbuild/modules.rst §3.3).
        mv "$gs/gpio-sim.c" "$gs/gpio-sim-main.c"
        grep -q "handle_simple_irq(irq_to_desc(irqnum));" "$gs/irq_sim.c" &&
            sed -i "s/handle_simple_irq(irq_to_desc(irqnum));/generic_handle_irq(irqnum);/" \
                "$gs/irq_sim.c" ||
            gpio_skip="irq_sim.c of $srcpkg has no handle_simple_irq(irq_to_desc(irqnum)) to replace"
    fi
    printf 'obj-m := gpio-sim.o\ngpio-sim-y := gpio-sim-main.o irq_sim.o\n' > "$gs/Kbuild"
    if [ -z "$gpio_skip" ]; then
        if make -s -C "$hdr" M="$gs" modules >&2 2> >(grep -v "Skipping BTF" >&2); then
            strip --strip-debug "$gs/gpio-sim.ko"
            cp "$gs/gpio-sim.ko" "$mod/extra/"
        else
            gpio_skip="gpio-sim from $srcpkg did not build against linux-headers-$kver (above)"
        fi
    fi
fi
depmod -b "$root" "$kver"

# The modules and their dependencies in load order (kmod's modprobe resolves modules.dep).
mkdir -p "$work/out/modules"
: > "$work/out/modules.load"
mods="virtio_pci virtio_blk can_raw vcan v4l2loopback"
[ -z "$gpio_skip" ] && mods="$mods gpio-sim"
for m in $mods; do
    modprobe -d "$root" -S "$kver" --show-depends "$m" | awk '$1 == "insmod" {print $2}'
done | awk '!seen[$0]++' | while read -r ko; do
    name=$(basename "$ko")
    cp "$ko" "$work/out/modules/$name"
    echo "$name" >> "$work/out/modules.load"
done
cp "$root/boot/vmlinuz-$kver" "$work/out/vmlinuz"
echo "$kver" > "$work/out/version"
printf '%s\n' "${pkgs[@]}" > "$work/out/packages"
if [ -z "$gpio_skip" ]; then
    echo "$srcpkg" >> "$work/out/packages"
    echo "gpio-sim.ko" > "$work/out/gpio-sim"
else
    say "gpio-sim not built: $gpio_skip"
    echo "$gpio_skip" > "$work/out/gpio-sim.skip"
fi
rm -rf "$out"
mv "$work/out" "$out"
say "kernel layer ready: $out"
echo "$out"
