#!/bin/busybox sh
# /init of the HIL test's virtual machine (tests/hil/hil.sh builds the initramfs around it).
# Debian's kernel with real drivers: v4l2loopback and vcan. For each case (GREY, Y16) it runs
# nvstim under the sim clock with V4L2 output and CAN telemetry, replays the candump log onto
# vcan0 with canplayer, captures with v4l2-ctl (a real V4L2 client), and writes everything
# the host checks (tests/hil/check.py) as a tar archive onto the second disk, /dev/vda.
# Progress goes to the serial console; the host reads it too.
export PATH=/bin:/usr/bin:/usr/local/bin
/bin/busybox --install -s /bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
OUT=/tmp/out
mkdir -p "$OUT"
. /hil/env                     # FRAMES, FRAME_W, FRAME_H, KILL_AFTER, KILL_TAIL, V4L_VER

say() { echo "hil-vm: $*"; echo "$*" >> "$OUT/steps.log"; }
finish() {
    say "done: $1"
    echo "$1" > "$OUT/result"
    dmesg > "$OUT/dmesg.txt"
    tar -cf /dev/vda -C "$OUT" .
    sync
    poweroff -f
}
# wait_for SECONDS COMMAND…: polls every 0.1 s; false on timeout.
wait_for() {
    n=$(($1 * 10)); shift
    while [ "$n" -gt 0 ]; do
        if "$@" > /dev/null 2>&1; then return 0; fi
        sleep 0.1; n=$((n - 1))
    done
    return 1
}
has_output() { v4l2-ctl -d /dev/video10 --all | grep -q "Video Output"; }
has_capture() { v4l2-ctl -d /dev/video10 --all | grep -q "Video Capture"; }
started() { grep -q "lockstep:" "$1" || ! kill -0 "$2"; }
file_at_least() { [ "$(stat -c %s "$1" 2> /dev/null || echo 0)" -ge "$2" ]; }

# ---- drivers --------------------------------------------------------------------------------
# v4l2loopback (docs/hil.md): exclusive_caps=1 (OUTPUT until a writer streams, then CAPTURE),
# video_nr=10, eight buffers so that a reader a few frames behind is never overwritten.
V4L_PARAMS="devices=1 video_nr=10 exclusive_caps=1 max_buffers=8 card_label=nvstim"
for m in $(cat /hil/modules.load); do
    p=""
    [ "$m" = v4l2loopback.ko ] && p=$V4L_PARAMS
    insmod "/hil/modules/$m" $p || finish "insmod $m failed"
done
ip link add dev vcan0 type vcan || finish "ip link add vcan0 failed"
ip link set vcan0 up || finish "ip link set vcan0 up failed"
uname -r > "$OUT/kernel.txt"
v4l2-ctl -d /dev/video10 --info > "$OUT/v4l2-info.txt" 2>&1
sha256sum /usr/local/bin/nvstim > "$OUT/nvstim.sha256"
export NVS_CONFIG_DIR=/hil/config NVS_CACHE_DIR=/tmp/cache

# ---- one case ---------------------------------------------------------------------------------
# run_case NAME SCENARIO FORMAT KILL: nvstim waits for the telemetry's time signal;
# canplayer plays the first 20 ms of the log (frames 0 and 1 written); the capture client starts
# and gets every frame from 0 (v4l2loopback serves a new reader from the oldest kept frame while
# it is at most two behind); then the rest of the log. KILL=1: the client is killed mid-stream and
# a second one takes KILL_TAIL frames of what follows.
run_case() {
    name=$1 scen=$2 fmt=$3 kill=$4
    d="$OUT/$name"
    mkdir -p "$d"
    # v4l2loopback 0.12.7 with exclusive_caps=1 announces OUTPUT again only after a writer that
    # streamed (STREAMON) closes; one that used write() never becomes a "writer" to it, so after
    # it the node announces neither capture nor output until the module is loaded again.
    if ! has_output; then
        say "$name: /dev/video10 announces no output after the last writer (v4l2loopback $V4L_VER): reloading the module"
        echo "no output after write() writer closed" >> "$OUT/v4l2loopback-quirk.txt"
        rmmod v4l2loopback || finish "rmmod v4l2loopback failed"
        insmod /hil/modules/v4l2loopback.ko $V4L_PARAMS || finish "insmod v4l2loopback failed"
        wait_for 10 has_output || finish "$name: /dev/video10 is no output device"
    fi
    say "$name: nvstim run $scen, v4l2 $fmt, can:vcan0 (lockstep)"
    nvstim run "/hil/$scen" --clock sim --frames "$FRAMES" \
        --output "v4l2:/dev/video10?format=$fmt" --telemetry "can:vcan0?idle_s=120" \
        --stats "$d/stats.json" > "$d/nvstim.out" 2> "$d/nvstim.log" &
    nv=$!
    # Started (or already dead: then say so at once).
    wait_for 120 started "$d/nvstim.log" "$nv" || finish "$name: nvstim did not start"
    kill -0 "$nv" 2> /dev/null || finish "$name: nvstim stopped: $(tail -2 "$d/nvstim.log")"
    # Malformed frames, sent while nvstim listens: two of an unknown identifier, three too short
    # for NVS_ATTITUDE (6 bytes in the DBC). Counted; the pose ignores them.
    cansend vcan0 7FF#0102
    cansend vcan0 7FF#03
    cansend vcan0 110#01
    cansend vcan0 110#0102
    cansend vcan0 110#010203
    canplayer -I /hil/telemetry.log.pre vcan0=can0 || finish "$name: canplayer (prefix) failed"
    wait_for 60 has_capture || finish "$name: /dev/video10 never offered capture"
    v4l2-ctl -d /dev/video10 --get-fmt-video > "$d/fmt.txt" 2>&1
    # The client runs SCHED_FIFO above nvstim (normal scheduling): on the one virtual CPU it
    # takes each frame as soon as it is written, so v4l2loopback never has to skip it ahead
    # (0.12 moves a reader more than two frames behind to the newest frame).
    $CLIENT --stream-count="$FRAMES" --verbose \
        --stream-to="$d/cap0.raw" > "$d/cap0.log" 2>&1 &
    c0=$!
    wait_for 60 grep -q "VIDIOC_STREAMON" "$d/cap0.log" || sleep 1
    canplayer -I /hil/telemetry.log.rest vcan0=can0 &
    pl=$!
    if [ "$kill" = 1 ]; then
        wait_for 120 file_at_least "$d/cap0.raw" $((KILL_AFTER * FRAME_BYTES_GREY)) ||
            finish "$name: the client got fewer than $KILL_AFTER frames"
        kill -9 "$c0"
        say "$name: capture client killed at $(stat -c %s "$d/cap0.raw") bytes"
        echo "$(stat -c %s "$d/cap0.raw")" > "$d/killed_at_bytes"
        $CLIENT --stream-count="$KILL_TAIL" --verbose \
            --stream-to="$d/cap1.raw" > "$d/cap1.log" 2>&1 &
        c1=$!
    fi
    wait "$nv"
    echo $? > "$d/nvstim.rc"
    say "$name: nvstim exited with $(cat "$d/nvstim.rc")"
    wait "$pl"
    for c in $c0 ${c1:-}; do
        [ "$kill" = 1 ] && [ "$c" = "$c0" ] && continue
        # A client that still waits for frames is stuck: stop it, and say so.
        n=50
        while kill -0 "$c" 2> /dev/null && [ $n -gt 0 ]; do sleep 0.1; n=$((n - 1)); done
        if kill -0 "$c" 2> /dev/null; then kill -9 "$c"; echo "client $c stuck" >> "$d/stuck"; fi
        wait "$c" 2> /dev/null
    done
    c1=""
}

FRAME_BYTES_GREY=$((FRAME_W * FRAME_H))
CLIENT="chrt -f 50 v4l2-ctl -d /dev/video10 --stream-mmap=8"
# canplayer keeps the log's timing (a faster-than-real-time player, -t, overruns the socket's
# receive queue while the loop waits: the kernel drops frames, counted as "dropped").
# GREY: the client is killed mid-stream, a second one takes over.
run_case grey grey.toml GREY 1
run_case y16 y16.toml Y16 0

# A full-size shipped scenario (the RIT roof at 768 x 494 with the street lamp, the Moon and
# mirror rays). This CPU has no AVX-512: Embree traces the renderer's 16-ray packets with its
# 8- or 4-wide kernels, which read every lane (docs/portability.md). The host compares frames.
if [ "$FULL_FRAMES" -gt 0 ]; then
    say "full: nvstim run $FULL_SCENARIO, $FULL_FRAMES frames at full size"
    mkdir -p "$OUT/full"
    nvstim run "/hil/scenarios/$FULL_SCENARIO/scenario.toml" --clock sim --frames "$FULL_FRAMES" \
        --output "exr:$OUT/full/exr" --output "pgm:$OUT/full/pgm" \
        > "$OUT/full/nvstim.out" 2> "$OUT/full/nvstim.log"
    echo $? > "$OUT/full/nvstim.rc"
    say "full: nvstim exited with $(cat "$OUT/full/nvstim.rc")"
fi
finish ok
