#!/bin/bash
# Hardware-in-the-loop test against real kernel drivers (v4l2loopback, vcan, gpio-sim) in a
# virtual machine: Debian 12's kernel under qemu-system-x86_64 (TCG: no KVM needed) with a
# busybox initramfs that holds this build's nvstim, can-utils, v4l2-ctl and libgpiod's tools.
# What it checks: docs/hil.md.
#
#   hil.sh NVSTIM SOURCE_DIR WORK_DIR [ISA_COMPARE [HIL_GPIO]]
#
# Exit 0 pass, 1 fail, 77 skipped (ctest SKIP_RETURN_CODE) with the reason on stdout: no QEMU
# or a tool missing, or Debian's kernel packages cannot be fetched. Environment: NVS_HIL_CACHE
# (kernel layer cache), NVS_HIL_QEMU (the emulator, default qemu-system-x86_64),
# NVS_HIL_VM_TIMEOUT_S (default 660), NVS_HIL_FULL_FRAMES (frames of the full-size scenario,
# default 2; 0 leaves it out), NVS_HIL_CASES (the cases run, default "grey y16 gpio fusion full"),
# NVS_HIL_FUSION_FRAMES (frames a channel in the fusion case, default 8), NVS_HIL_FUSION_CACHE
# (1, the default: the fusion case's thermal heat balance and atmosphere tables are the host's,
# carried in the initramfs; 0: the VM solves them).
# The GPIO case alone is skipped, with "hil: gpio: SKIPPED: reason" on stdout, where gpio-sim
# could not be built (make_kernel.sh's gpio-sim.skip), libgpiod's tools (Debian package gpiod)
# are missing or no HIL_GPIO helper (tests/hil/hil_gpio.cpp) was given; the fusion case alone,
# with "hil: fusion: SKIPPED: reason", where /usr/bin/python3 has no numpy or OpenCV (the
# reference fusion consumer, examples/fusion, needs them).
#
# Steps: (1) the kernel layer (tests/hil/make_kernel.sh, cached under NVS_HIL_CACHE, default
# ~/.cache/nvstim/hil); (2) the host reference: the same nvstim, scenarios and candump log
# replayed (`--telemetry replay:`) to y4m files; (3) the initramfs, cached in WORK_DIR by a hash
# of everything in it; (4) the VM runs tests/hil/init.sh and leaves a tar on its second disk;
# (5) tests/hil/check.py compares, and tests/hil/check_fusion_hil.py for the fusion case;
# ISA_COMPARE (tests/isa's nvs_isa_compare) compares the VM's frames of a full-size shipped
# scenario (thesis-stlamp, 768 x 494) with the host's: the VM's CPU (-cpu max under TCG) has no
# AVX-512 (docs/portability.md).
set -uo pipefail

nvstim=$(realpath "${1:?usage: hil.sh NVSTIM SOURCE_DIR WORK_DIR}")
src=$(realpath "${2:?}")
work=${3:?}
isa_compare=${4:-}
hil_gpio=${5:-}
CASES=${NVS_HIL_CASES:-grey y16 gpio fusion full}
here="$src/tests/hil"
FULL_SCENARIO=thesis-stlamp
FULL_FRAMES=${NVS_HIL_FULL_FRAMES:-2}  # 0: no full-size scenario (the debug-asan preset's)
case " ${NVS_HIL_CASES:-full} " in *" full "*) ;; *) FULL_FRAMES=0 ;; esac
FRAMES=90          # 3 s at 30 Hz
KILL_AFTER=20      # frames the first client takes before it is killed
KILL_TAIL=20       # frames the second client then takes
VM_TIMEOUT_S=${NVS_HIL_VM_TIMEOUT_S:-660}
FUSION_FRAMES=${NVS_HIL_FUSION_FRAMES:-8}   # frames a channel (both runs of the fusion case)
FUSION_CACHE=${NVS_HIL_FUSION_CACHE:-1}
FUSION_RUNS="nofault:fusion faults:fusion_faults"  # run name : scenario (tests/hil/NAME.toml)

skip() { echo "hil: SKIPPED: $*"; exit 77; }
fail() { echo "hil: FAILED: $*"; exit 1; }
t_start=$(date +%s.%N)
elapsed() { awk -v a="$t_start" -v b="$(date +%s.%N)" 'BEGIN {printf "%.1f", b - a}'; }

# ---- (0) can QEMU run here? -------------------------------------------------------------------
qemu=${NVS_HIL_QEMU:-qemu-system-x86_64}
command -v "$qemu" > /dev/null ||
    skip "$qemu not found (Debian package qemu-system-x86; 'make test' installs it)"
"$qemu" -accel help 2> /dev/null | grep -qx tcg || skip "$qemu has no TCG accelerator"
for tool in busybox v4l2-ctl canplayer cansend chrt cpio depmod modprobe dpkg-deb apt-get python3 make; do
    command -v "$tool" > /dev/null || skip "'$tool' not found (see PACKAGES in the Makefile)"
done
ldd "$(command -v busybox)" > /dev/null 2>&1 &&
    skip "busybox is dynamically linked: the VM needs busybox-static"

mkdir -p "$work"
work=$(realpath "$work")
cache=${NVS_HIL_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/nvstim/hil}

# ---- (1) kernel layer ---------------------------------------------------------------------------
if ! kdir=$("$here/make_kernel.sh" "$cache" 2> "$work/kernel.log"); then
    cat "$work/kernel.log"
    if grep -qE "Failed to fetch|Unable to locate|Temporary failure|Could not resolve|cannot resolve" \
        "$work/kernel.log"; then
        skip "Debian's kernel packages cannot be fetched here (see above)"
    fi
    fail "building the kernel layer (see above)"
fi
grep -h "^hil:" "$work/kernel.log"
echo "hil: kernel $(cat "$kdir/version") [$(elapsed) s]"
# The GPIO case: gpio-sim in the kernel layer, libgpiod's tools here, the helper built.
GPIO=0
gpio_skip=""
if [ -f "$kdir/gpio-sim.skip" ]; then
    gpio_skip="gpio-sim could not be built: $(cat "$kdir/gpio-sim.skip")"
elif ! command -v gpiomon > /dev/null || ! command -v gpioinfo > /dev/null; then
    gpio_skip="gpiomon/gpioinfo not found (Debian package gpiod; 'make test' installs it)"
elif [ -z "$hil_gpio" ] || [ ! -x "$hil_gpio" ]; then
    gpio_skip="no nvs_hil_gpio helper given (tests/hil/CMakeLists.txt builds it)"
fi
case " $CASES " in
    *" gpio "*) if [ -n "$gpio_skip" ]; then echo "hil: gpio: SKIPPED: $gpio_skip"; else GPIO=1; fi ;;
    *) echo "hil: gpio: left out (NVS_HIL_CASES=\"$CASES\")" ;;
esac
# The fusion case: the reference consumer's Python (numpy, OpenCV) on the host.
FUSION=0
case " $CASES " in
    *" fusion "*)
        if /usr/bin/python3 -c "import numpy, cv2" 2> /dev/null; then FUSION=1; else
            echo "hil: fusion: SKIPPED: /usr/bin/python3 has no numpy or OpenCV (Debian packages python3-numpy, python3-opencv)"
        fi ;;
    *) echo "hil: fusion: left out (NVS_HIL_CASES=\"$CASES\")" ;;
esac

# ---- (2) telemetry and host reference ------------------------------------------------------------
ref="$work/ref"
rm -rf "$ref" "$work/out"
mkdir -p "$ref"
python3 "$here/make_log.py" "$ref/telemetry.log" 0.02 || fail "make_log.py"
for c in grey y16; do
    NVS_CONFIG_DIR="$src/config" NVS_CACHE_DIR="$work/cache" "$nvstim" run "$here/$c.toml" \
        --clock sim --frames "$FRAMES" --telemetry "replay:$ref/telemetry.log" \
        --output "y4m:$ref/$c.y4m" --output "meta:$ref/$c.jsonl" > "$ref/$c.log" 2>&1 ||
        { cat "$ref/$c.log"; fail "host reference run ($c)"; }
done
if [ "$FULL_FRAMES" -gt 0 ]; then
    NVS_CONFIG_DIR="$src/config" NVS_CACHE_DIR="$work/cache" "$nvstim" run \
        "$src/scenarios/$FULL_SCENARIO/scenario.toml" --clock sim --frames "$FULL_FRAMES" \
        --output "exr:$ref/full/exr" --output "pgm:$ref/full/pgm" > "$ref/full.log" 2>&1 ||
        { cat "$ref/full.log"; fail "host reference run ($FULL_SCENARIO)"; }
fi
# The fusion case's rig: each channel's y4m and metadata, with a cache of its own that the VM
# gets (NVS_HIL_FUSION_CACHE=1): the thermal channel's heat balance and the tables.
if [ "$FUSION" = 1 ]; then
    mkdir -p "$ref/fusion-cache"
    for run in $FUSION_RUNS; do
        name=${run%%:*} scen=${run#*:}
        mkdir -p "$ref/fusion/$name"
        NVS_CONFIG_DIR="$src/config" NVS_CACHE_DIR="$ref/fusion-cache" "$nvstim" run \
            "$here/$scen.toml" --clock sim --frames "$FUSION_FRAMES" \
            --output "y4m:$ref/fusion/$name/ii.y4m?channel=ii" \
            --output "meta:$ref/fusion/$name/ii.jsonl?channel=ii" \
            --output "y4m:$ref/fusion/$name/lwir.y4m?channel=lwir" \
            --output "meta:$ref/fusion/$name/lwir.jsonl?channel=lwir" \
            > "$ref/fusion/$name/nvstim.log" 2>&1 ||
            { cat "$ref/fusion/$name/nvstim.log"; fail "host reference run (fusion $name)"; }
    done
fi
echo "hil: host reference written (replay of the same log to y4m) [$(elapsed) s]"

# ---- (3) initramfs ----------------------------------------------------------------------------------
# Executables with every shared library ldd names (and the loader), at their own paths.
stage="$work/initramfs.d"
rm -rf "$stage"
mkdir -p "$stage"/{bin,dev,proc,sys,tmp,usr/local/bin,hil/modules}
copy_exe() { # copy_exe FILE [DEST]
    local f=$1 d=${2:-$1}
    mkdir -p "$stage$(dirname "$d")"
    cp -L "$f" "$stage$d"
    ldd "$f" | awk '/=>/ && $3 ~ /^\// {print $3} /^\t\/[^ ]+ \(/ {print $1}' | while read -r lib; do
        [ -e "$stage$lib" ] && continue
        mkdir -p "$stage$(dirname "$lib")"
        cp -L "$lib" "$stage$lib"
    done
}
cp "$(command -v busybox)" "$stage/bin/busybox"
copy_exe "$nvstim" /usr/local/bin/nvstim
for t in v4l2-ctl canplayer cansend candump chrt; do copy_exe "$(command -v "$t")"; done
if [ "$GPIO" = 1 ]; then
    for t in gpiodetect gpioinfo gpiomon gpioset; do copy_exe "$(command -v "$t")"; done
    copy_exe "$hil_gpio" /usr/local/bin/nvs_hil_gpio
    cp "$here/trigger.toml" "$here/gate_frame.toml" "$here/gate_interlaced.toml" "$stage/hil/"
fi
cp "$kdir"/modules/*.ko "$stage/hil/modules/"
cp "$kdir/modules.load" "$here/grey.toml" "$here/y16.toml" "$ref"/telemetry.log* "$stage/hil/"
cp -r "$src/config" "$stage/hil/config"
mkdir -p "$stage/hil/scenarios/$FULL_SCENARIO"
cp "$src/scenarios/$FULL_SCENARIO/scenario.toml" "$stage/hil/scenarios/$FULL_SCENARIO/"
cp -r "$src/scenarios/rit" "$stage/hil/scenarios/rit"
rm -rf "$stage/hil/scenarios/rit/__pycache__"
if [ "$FUSION" = 1 ]; then
    # The rig's scenarios at their place in the repository (their paths are relative to it).
    mkdir -p "$stage/hil/tests/hil" "$stage/hil/fusion-cache"
    for run in $FUSION_RUNS; do cp "$here/${run#*:}.toml" "$stage/hil/tests/hil/"; done
    [ "$FUSION_CACHE" = 1 ] && cp "$ref/fusion-cache"/* "$stage/hil/fusion-cache/"
fi
cp "$here/init.sh" "$stage/init"
chmod +x "$stage/init"
cat > "$stage/hil/env" << EOF
FRAMES=$FRAMES
FRAME_W=160
FRAME_H=120
FULL_SCENARIO=$FULL_SCENARIO
FULL_FRAMES=$FULL_FRAMES
KILL_AFTER=$KILL_AFTER
KILL_TAIL=$KILL_TAIL
CASES="$CASES"
GPIO=$GPIO
FUSION=$FUSION
FUSION_FRAMES=$FUSION_FRAMES
FUSION_CACHE=$FUSION_CACHE
V4L_VER=$(sed -n 's/^v4l2loopback-dkms=//p' "$kdir/packages")
EOF
key=$( (cd "$stage" && find . -type f -print0 | LC_ALL=C sort -z | xargs -0 sha256sum;
        cat "$kdir/version") | sha256sum | cut -c1-16)
image="$work/initramfs-$key.cpio"
if [ -f "$image" ]; then
    echo "hil: initramfs cached: $image"
else
    rm -f "$work"/initramfs-*.cpio
    (cd "$stage" && find . | LC_ALL=C sort | cpio -o -H newc --quiet > "$image.part") &&
        mv "$image.part" "$image" || fail "writing the initramfs"
    echo "hil: initramfs written: $image ($(($(stat -c %s "$image") / 1048576)) MiB)"
fi
rm -rf "$stage"

# ---- (4) the virtual machine ----------------------------------------------------------------------
disk="$work/out.img"
rm -f "$disk"
truncate -s 128M "$disk"
echo "hil: booting (qemu-system-x86_64 -accel tcg) [$(elapsed) s]"
t_vm=$(date +%s.%N)
# One virtual CPU: inside it the capture client's SCHED_FIFO priority (init.sh) decides who runs
# when a frame is written, whatever the host's load does to the VM as a whole.
timeout "$VM_TIMEOUT_S" "$qemu" -accel tcg -cpu max -smp 1 -m 1536 \
    -nographic -no-reboot -monitor none -serial stdio \
    -kernel "$kdir/vmlinuz" -initrd "$image" \
    -append "console=ttyS0 quiet panic=-1 oops=panic" \
    -drive "file=$disk,format=raw,if=virtio" < /dev/null > "$work/console.log" 2>&1
vm_rc=$?
vm_s=$(awk -v a="$t_vm" -v b="$(date +%s.%N)" 'BEGIN {printf "%.1f", b - a}')
echo "hil: VM finished in $vm_s s (status $vm_rc)"
grep "hil-vm:" "$work/console.log" | tr -d '\r'
[ "$vm_rc" -eq 124 ] && { tail -30 "$work/console.log"; fail "the VM ran past ${VM_TIMEOUT_S} s"; }
mkdir -p "$work/out"
tar -xf "$disk" -C "$work/out" 2> /dev/null || { tail -30 "$work/console.log"; fail "no results on the VM's disk"; }
[ "$(cat "$work/out/result" 2> /dev/null)" = ok ] ||
    { tail -30 "$work/console.log"; fail "inside the VM: $(cat "$work/out/result" 2> /dev/null)"; }

# ---- (5) checks -----------------------------------------------------------------------------------
# Every case is checked, whichever fails first.
failed=""
python3 "$here/check.py" --out "$work/out" --ref "$ref" --frames "$FRAMES" --width 160 --height 120 \
    --kill-after "$KILL_AFTER" --kill-tail "$KILL_TAIL" --nvstim "$nvstim" --cases "$CASES" \
    --gpio "$GPIO" || failed="checks"
# The fusion case: the captured streams, and the reference fusion consumer on them.
if [ "$FUSION" = 1 ]; then
    /usr/bin/python3 "$here/check_fusion_hil.py" --out "$work/out/fusion" --ref "$ref/fusion" \
        --src "$src" --frames "$FUSION_FRAMES" --runs "$FUSION_RUNS" \
        ${isa_compare:+--isa-compare "$isa_compare"} || failed="${failed:+$failed and }fusion checks"
fi
[ -z "$failed" ] || fail "$failed (above); VM output kept in $work/out"
# The full-size scenario: it ran (the VM's log says so), and gave the host's frames within the
# cross-ISA tolerance.
if [ "$FULL_FRAMES" -eq 0 ]; then
    echo "hil: the full-size scenario left out (NVS_HIL_FULL_FRAMES=0, or not in NVS_HIL_CASES)"
elif [ "$(cat "$work/out/full/nvstim.rc" 2> /dev/null)" != 0 ]; then
    tail -5 "$work/out/full/nvstim.log"
    fail "$FULL_SCENARIO in the VM: exit $(cat "$work/out/full/nvstim.rc" 2> /dev/null)"
else
    if [ -n "$isa_compare" ]; then
        "$isa_compare" radiance "$ref/full/exr" "$work/out/full/exr" &&
            "$isa_compare" run-frames "$ref/full/pgm" "$work/out/full/pgm" ||
            fail "$FULL_SCENARIO: the VM's frames are not the host's (above)"
    fi
    echo "hil: $FULL_SCENARIO at full size: $FULL_FRAMES frames in the VM, as on the host"
fi
echo "hil: passed in $(elapsed) s (VM $vm_s s)"
