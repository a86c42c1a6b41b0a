#!/bin/busybox sh
# /init of the HIL test's virtual machine (tests/hil/hil.sh builds the initramfs around it).
# Debian's kernel with real drivers: v4l2loopback, vcan and gpio-sim. For each case (GREY, Y16)
# it runs nvstim under the sim clock with V4L2 output and CAN telemetry, replays the candump log
# onto vcan0 with canplayer, captures with v4l2-ctl (a real V4L2 client); the GPIO case runs
# nvstim on the wall clock against a gpio-sim chip (gpio_case below); the fusion case runs a rig
# of two channels, each on its own v4l2loopback node with its own v4l2-ctl client (fusion_run
# below). Everything the host checks (tests/hil/check.py, check_fusion_hil.py) goes as a tar
# archive onto the second disk, /dev/vda.
# Progress goes to the serial console; the host reads it too.
export PATH=/bin:/usr/bin:/usr/local/bin
/bin/busybox --install -s /bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
OUT=/tmp/out
mkdir -p "$OUT"
. /hil/env                     # FRAMES, FRAME_W, FRAME_H, KILL_AFTER, KILL_TAIL, V4L_VER, CASES, GPIO,
                              # FUSION, FUSION_FRAMES, FUSION_CACHE

say() { echo "hil-vm: $* [$(cut -d" " -f1 /proc/uptime) s]"; echo "$*" >> "$OUT/steps.log"; }
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
# has_output / has_capture [DEVICE] (default /dev/video10): the node announces OUTPUT; it has a
# capture format, i.e. a writer has written a frame (v4l2loopback answers VIDIOC_G_FMT for
# capture only then; `--all` prints "Streaming Parameters Video Capture" in either state).
has_output() { v4l2-ctl -d "${1:-/dev/video10}" --all | grep -q "Video Output"; }
has_capture() { v4l2-ctl -d "${1:-/dev/video10}" --get-fmt-video 2>&1 | grep -q "Width/Height"; }
started() { grep -q "lockstep:" "$1" || ! kill -0 "$2"; }
streaming() { grep -q "VIDIOC_STREAMON" "$1" || ! kill -0 "$2"; }  # (or dead)
file_at_least() { [ "$(stat -c %s "$1" 2> /dev/null || echo 0)" -ge "$2" ]; }

# ---- drivers --------------------------------------------------------------------------------
# v4l2loopback (docs/hil.md): two nodes, /dev/video10 and /dev/video11 (the fusion case's second
# channel), each with exclusive_caps=1 (OUTPUT until a writer streams, then CAPTURE); eight
# buffers so that a reader a few frames behind is never overwritten.
V4L_PARAMS="devices=2 video_nr=10,11 exclusive_caps=1,1 max_buffers=8 card_label=nvstim,nvstim-2"
for m in $(cat /hil/modules.load); do
    p=""
    [ "$m" = v4l2loopback.ko ] && p=$V4L_PARAMS
    insmod "/hil/modules/$m" $p || finish "insmod $m failed"
done
ip link add dev vcan0 type vcan || finish "ip link add vcan0 failed"
ip link set vcan0 up || finish "ip link set vcan0 up failed"
uname -r > "$OUT/kernel.txt"
v4l2-ctl -d /dev/video10 --info > "$OUT/v4l2-info.txt" 2>&1
v4l2-ctl -d /dev/video11 --info > "$OUT/v4l2-info-11.txt" 2>&1
sha256sum /usr/local/bin/nvstim > "$OUT/nvstim.sha256"
export NVS_CONFIG_DIR=/hil/config NVS_CACHE_DIR=/tmp/cache

# outputs_ready NAME DEVICE…: every DEVICE announces OUTPUT, the module reloaded where one does
# not. v4l2loopback 0.12.7 with exclusive_caps=1 announces OUTPUT again only after a writer that
# streamed (STREAMON) closes; one that used write() never becomes a "writer" to it, so after it
# the node announces neither capture nor output until the module is loaded again.
outputs_ready() {
    what=$1; shift
    for dev in "$@"; do
        has_output "$dev" && continue
        say "$what: $dev announces no output after the last writer (v4l2loopback $V4L_VER): reloading the module"
        echo "no output after write() writer closed" >> "$OUT/v4l2loopback-quirk.txt"
        rmmod v4l2loopback || finish "rmmod v4l2loopback failed"
        insmod /hil/modules/v4l2loopback.ko $V4L_PARAMS || finish "insmod v4l2loopback failed"
        break
    done
    for dev in "$@"; do
        wait_for 10 has_output "$dev" || finish "$what: $dev is no output device"
    done
}

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
    outputs_ready "$name" /dev/video10
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

# ---- GPIO: gpio-sim ------------------------------------------------------------------------------
# A chip of four lines through configfs (kernel docs: admin-guide/gpio/gpio-sim): line 0
# "trigger" (nvstim's trigger input; the test makes its edges by writing its sysfs `pull`),
# line 1 "gate" (nvstim's gate output; the test reads it back through `value`). Every time is
# CLOCK_MONOTONIC (nvs_hil_gpio), the clock of the kernel's line-event stamps and of nvstim's
# run clock (its origin is the --stats key clock_origin_ns).
GS=/sys/kernel/config/gpio-sim/nvs
gpio_chip() {
    mount -t configfs none /sys/kernel/config || return 1
    mkdir "$GS" "$GS/bank0" "$GS/bank0/line0" "$GS/bank0/line1" || return 1
    echo 4 > "$GS/bank0/num_lines"
    echo nvs-sim > "$GS/bank0/label"
    echo trigger > "$GS/bank0/line0/name"
    echo gate > "$GS/bank0/line1/name"
    echo 1 > "$GS/live" || return 1
    CHIP=$(cat "$GS/bank0/chip_name")
    SIM=/sys/devices/platform/$(cat "$GS/dev_name")/$CHIP
    [ -e "$SIM/sim_gpio0/pull" ] && [ -e "$SIM/sim_gpio1/value" ]
}
# used_by_nvstim LINE: gpioinfo shows the line requested by nvstim.
used_by_nvstim() { gpioinfo "$CHIP" | grep -q "line *$1:.*\"nvstim\""; }
# sampler_start DIR / sampler_stop DIR: the gate line's value every 0.5 ms, SCHED_FIFO 82: below
# nvstim's pulse thread (nvs-gpio, 85: the sampler never delays the pulse it samples), above its
# render, camera and output threads (70-80), so that rendering does not leave gaps in the samples.
sampler_start() {
    rm -f "$1/sample.stop"
    chrt -f 82 nvs_hil_gpio sample "$SIM/sim_gpio1/value" 500 "$1/sample.stop" 60 \
        > "$1/samples.txt" 2> "$1/sampler.log" &
    SAMPLER=$!
    sleep 0.3
}
sampler_stop() { sleep 0.2; touch "$1/sample.stop"; wait "$SAMPLER"; }
# gate_case NAME SCENARIO FRAMES: wall clock, the gate on line 1, the line sampled throughout.
gate_case() {
    d="$OUT/gpio/$1"
    mkdir -p "$d"
    say "gpio $1: nvstim run $2 --clock wall --output gpio:$CHIP:1, $3 frames, line sampled every 0.5 ms"
    sampler_start "$d"
    nvstim run "/hil/$2" --clock wall --frames "$3" --output "gpio:$CHIP:1" \
        --output "meta:$d/meta.jsonl" --stats "$d/stats.json" > "$d/nvstim.out" 2> "$d/nvstim.log"
    echo $? > "$d/nvstim.rc"
    sampler_stop "$d"
    say "gpio $1: nvstim exited with $(cat "$d/nvstim.rc"), $(wc -l < "$d/samples.txt") samples"
}
gpio_case() {
    mkdir -p "$OUT/gpio"
    gpio_chip || { echo "gpio-sim chip not made" > "$OUT/gpio/error"; say "gpio: no gpio-sim chip"; return; }
    gpiodetect > "$OUT/gpio/gpiodetect.txt" 2>&1
    gpioinfo "$CHIP" > "$OUT/gpio/gpioinfo.txt" 2>&1
    say "gpio: $(cat "$OUT/gpio/gpiodetect.txt")"
    # (1) The kernel's stamps against the helper's: gpiomon takes 20 rising edges made by
    # writing `pull`; the host checks each stamp lies between the helper's clock readings
    # around the write.
    d="$OUT/gpio/gpiomon"
    mkdir -p "$d"
    gpiomon -r -n 20 -F "%s %n" "$CHIP" 0 > "$d/gpiomon.txt" 2> "$d/gpiomon.log" &
    mon=$!
    wait_for 30 gpioinfo_used 0 || sleep 1
    chrt -f 60 nvs_hil_gpio edges "$SIM/sim_gpio0/pull" 20 50000 10000 1 > "$d/edges.txt"
    n=50
    while kill -0 "$mon" 2> /dev/null && [ $n -gt 0 ]; do sleep 0.1; n=$((n - 1)); done
    kill "$mon" 2> /dev/null
    wait "$mon"
    say "gpio: gpiomon read $(wc -l < "$d/gpiomon.txt") edges"
    # (2) The trigger clock: 40 rising edges at 200 ms ± 40 ms (5 Hz nominal), silent for
    # 1.6 s more after the 25th (stalled past the 0.5-s timeout, then recovers). The metadata goes
    # to a pipe whose reader stamps each line as it arrives (SCHED_FIFO 84: above nvstim's output
    # thread, 80, which writes it, and the sampler; below the pulse thread, 85).
    d="$OUT/gpio/trigger"
    mkdir -p "$d"
    sed "s/@CHIP@/$CHIP/" /hil/trigger.toml > /tmp/trigger.toml
    say "gpio trigger: nvstim run trigger.toml --clock wall (trigger gpio:$CHIP:0, gate gpio:$CHIP:1)"
    sampler_start "$d"
    ( nvstim run /tmp/trigger.toml --clock wall --frames 40 --output "gpio:$CHIP:1" \
        --output meta:- --stats "$d/stats.json" 2> "$d/nvstim.log"; echo $? > "$d/nvstim.rc" ) |
        chrt -f 84 nvs_hil_gpio stamp > "$d/meta.stamped" &
    nvp=$!
    # Edges once the loop runs (its first status line) and both lines are nvstim's.
    wait_for 60 grep -q "nvstim run: frame" "$d/nvstim.log" || say "gpio trigger: no status line"
    used_by_nvstim 0 && used_by_nvstim 1 || say "gpio trigger: lines not requested: $(gpioinfo "$CHIP")"
    gpioinfo "$CHIP" > "$d/gpioinfo.txt" 2>&1
    chrt -f 70 nvs_hil_gpio edges "$SIM/sim_gpio0/pull" 40 200000 40000 2 25 1600000 > "$d/edges.txt"
    n=150
    while kill -0 "$nvp" 2> /dev/null && [ $n -gt 0 ]; do sleep 0.1; n=$((n - 1)); done
    pkill_nvstim() { for p in $(pidof nvstim); do kill -INT "$p"; done; }
    kill -0 "$nvp" 2> /dev/null && { say "gpio trigger: nvstim still running: stopped"; pkill_nvstim; }
    wait "$nvp"
    sampler_stop "$d"
    say "gpio trigger: nvstim exited with $(cat "$d/nvstim.rc"), $(grep -c . "$d/meta.stamped") frames"
    # (3) The gate on the wall clock: frame scan and interlaced.
    gate_case frame gate_frame.toml 120
    gate_case interlaced gate_interlaced.toml 120
}
gpioinfo_used() { gpioinfo "$CHIP" | grep -q "line *$1:.*\"gpiomon\""; }

# ---- fusion: a rig on two v4l2loopback nodes ------------------------------------------------------
# fusion_run NAME SCENARIO: the rig (tests/hil/fusion*.toml: channel ii, 29.97 frames/s
# interlaced; channel lwir, 30 Hz) under the sim clock, ii on /dev/video10 and lwir on
# /dev/video11 as GREY, each channel's metadata and (the host's bit-identity check) its y4m to
# files. A capture client per node (v4l2-ctl, SCHED_FIFO 50 as in run_case) starts as soon as the
# node offers capture, that is after nvstim's first frame on it; nvstim is stopped (SIGSTOP)
# while the client starts and streams on, so the client finds that frame (or, polled late, two)
# written before it and gets every frame from 0 (v4l2loopback serves a new reader from the oldest
# kept frame while it is at most two behind). Nothing paces the sim clock but rendering; the client, above
# nvstim on the one CPU, takes each frame as it is written.
fusion_client() { # fusion_client DIR CHANNEL DEVICE: start its client, nvstim stopped meanwhile
    kill -STOP "$nv" 2> /dev/null
    v4l2-ctl -d "$3" --get-fmt-video > "$1/fmt_$2.txt" 2>&1
    chrt -f 50 v4l2-ctl -d "$3" --stream-mmap=8 --stream-count="$FUSION_FRAMES" --verbose \
        --stream-to="$1/cap_$2.raw" > "$1/cap_$2.log" 2>&1 &
    echo $! > "$1/client_$2.pid"
    wait_for 30 streaming "$1/cap_$2.log" "$(cat "$1/client_$2.pid")" || sleep 1
    got=$(stat -c %s "$1/cap_$2.raw" 2> /dev/null || echo 0)
    say "fusion $(basename "$1"): $2 client streaming on $3 ($got bytes captured so far)"
    kill -CONT "$nv" 2> /dev/null
}
fusion_run() {
    name=$1 scen=$2
    d="$OUT/fusion/$name"
    mkdir -p "$d"
    outputs_ready "fusion $name" /dev/video10 /dev/video11
    # The thermal channel's heat balance and the atmosphere's tables: the host's (hil.sh) unless
    # FUSION_CACHE=0, which has the VM solve them.
    cache=/tmp/fusion-cache-$name
    mkdir -p "$cache"
    [ "$FUSION_CACHE" = 1 ] && cp /hil/fusion-cache/* "$cache/" 2> /dev/null
    say "fusion $name: nvstim run $scen --clock sim --frames $FUSION_FRAMES: ii on /dev/video10, lwir on /dev/video11 (GREY)"
    t0=$(cut -d" " -f1 /proc/uptime)
    NVS_CACHE_DIR=$cache nvstim run "/hil/tests/hil/$scen" --clock sim --frames "$FUSION_FRAMES" \
        --output "v4l2:/dev/video10?channel=ii&format=GREY" --output "meta:$d/ii.jsonl?channel=ii" \
        --output "y4m:$d/ii.y4m?channel=ii" \
        --output "v4l2:/dev/video11?channel=lwir&format=GREY" \
        --output "meta:$d/lwir.jsonl?channel=lwir" --output "y4m:$d/lwir.y4m?channel=lwir" \
        --stats "$d/stats.json" > "$d/nvstim.out" 2> "$d/nvstim.log" &
    nv=$!
    ii=0 lwir=0 n=3000
    while [ $((ii + lwir)) -lt 2 ] && kill -0 "$nv" 2> /dev/null && [ $n -gt 0 ]; do
        if [ $ii = 0 ] && has_capture /dev/video10; then fusion_client "$d" ii /dev/video10; ii=1; fi
        if [ $lwir = 0 ] && has_capture /dev/video11; then fusion_client "$d" lwir /dev/video11; lwir=1; fi
        sleep 0.1; n=$((n - 1))
    done
    [ $((ii + lwir)) -lt 2 ] && say "fusion $name: a node never offered capture (ii $ii, lwir $lwir)"
    wait "$nv"
    echo $? > "$d/nvstim.rc"
    t1=$(cut -d" " -f1 /proc/uptime)
    echo "$t0 $t1" > "$d/vm_time_s"
    took=$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.1f", b - a}')
    heat=$(grep -h "heat balance" "$d/nvstim.log" | sed 's/.*thermal: //; s/, weather.*//')
    say "fusion $name: nvstim exited with $(cat "$d/nvstim.rc") after $took s: $heat"
    for ch in ii lwir; do
        [ -f "$d/client_$ch.pid" ] || continue
        c=$(cat "$d/client_$ch.pid")
        n=50
        while kill -0 "$c" 2> /dev/null && [ $n -gt 0 ]; do sleep 0.1; n=$((n - 1)); done
        if kill -0 "$c" 2> /dev/null; then kill -9 "$c"; echo "client $ch stuck" >> "$d/stuck"; fi
        wait "$c" 2> /dev/null
    done
    ls -l "$cache" > "$d/cache.txt" 2>&1
}

FRAME_BYTES_GREY=$((FRAME_W * FRAME_H))
CLIENT="chrt -f 50 v4l2-ctl -d /dev/video10 --stream-mmap=8"
# canplayer keeps the log's timing (a faster-than-real-time player, -t, overruns the socket's
# receive queue while the loop waits: the kernel drops frames, counted as "dropped").
# GREY: the client is killed mid-stream, a second one takes over.
case " $CASES " in *" grey "*) run_case grey grey.toml GREY 1 ;; esac
case " $CASES " in *" y16 "*) run_case y16 y16.toml Y16 0 ;; esac
case " $CASES " in *" gpio "*) [ "$GPIO" = 1 ] && gpio_case ;; esac
# Fusion: the rig without a fault, then with the thermal channel skewed and misregistered.
case " $CASES " in *" fusion "*)
    if [ "$FUSION" = 1 ]; then
        fusion_run nofault fusion.toml
        fusion_run faults fusion_faults.toml
    fi ;;
esac

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
