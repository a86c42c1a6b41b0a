#!/bin/sh
# Soak test of `nvstim run` (docs/reliability.md): a wall-clock run at 59.94 Hz for a set time
# (default 10 minutes) with replayed CAN telemetry, a real consumer (ffmpeg decoding the y4m
# stream from a pipe, as a recorder or a tracker would), a metadata file beside it, and a CPU
# hog on every core (niced, so it takes what the run leaves). Reports deadline misses, repeats,
# telemetry → emission and render → emission latency (p50/p99/max), the output period and its
# jitter, queue drops per output, and the resident memory of nvstim over the run.
#
# Not run by `make test` (it takes the time it is given). Usage:
#   tests/soak/soak.sh [BUILD_DIR]            # default build/release
# Environment: SOAK_SECONDS (600), SOAK_HOGS (number of hog processes, default: one per core;
# 0: none), SOAK_NICE (nice value of the hogs, 10), SOAK_WIDTH/SOAK_HEIGHT (320x240),
# SOAK_OUT (a folder to keep the run's files; default a temporary folder, removed).
set -eu

here=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$here/build/release}
nvstim=$build/rt/cli/nvstim
[ -x "$nvstim" ] || { echo "soak: $nvstim not built" >&2; exit 2; }
command -v ffmpeg >/dev/null || { echo "soak: ffmpeg is needed (the consumer)" >&2; exit 2; }
command -v python3 >/dev/null || { echo "soak: python3 is needed (telemetry, report)" >&2; exit 2; }

seconds=${SOAK_SECONDS:-600}
hogs=${SOAK_HOGS:-$(nproc)}
niceness=${SOAK_NICE:-10}
width=${SOAK_WIDTH:-320}
height=${SOAK_HEIGHT:-240}
if [ -n "${SOAK_OUT:-}" ]; then
  out=$SOAK_OUT; mkdir -p "$out"; keep=1
else
  out=$(mktemp -d "${TMPDIR:-/tmp}/nvstim-soak-XXXXXX"); keep=0
fi
frames=$(python3 -c "import math; print(math.ceil($seconds * 60000 / 1001))")

# Telemetry: a CAN log (config/can/nvstim.dbc) covering the whole run — position 50 Hz, attitude
# 100 Hz, time 10 Hz — of a platform circling at 1 rad per 10 s.
python3 - "$out/flight.candump" "$seconds" <<'EOF'
import math, struct, sys
path, seconds = sys.argv[1], float(sys.argv[2]) + 5.0
unix0 = 904708800
def line(t, cid, data):
    s = math.floor(t)
    return "(%d.%06d) can0 %03X#%s\n" % (unix0 + s, round((t - s) * 1e6) % 1000000, cid, data.hex().upper())
with open(path, "w") as f:
    for k in range(int(seconds * 100) + 1):
        t = k / 100.0
        if k % 2 == 0:
            lat = 43.16856 + 1e-4 * math.sin(0.1 * t)
            lon = -77.61583 + 1e-4 * math.cos(0.1 * t)
            f.write(line(t, 0x100, struct.pack("<ii", round(lat * 1e7), round(lon * 1e7))))
            f.write(line(t, 0x101, struct.pack("<i", round(518.0 * 1000))))
        yaw = math.degrees(0.1 * t) % 360.0
        f.write(line(t, 0x110, struct.pack("<hhH", round(2.0 * math.sin(t) * 100), -4500, round(yaw * 100) % 36000)))
        if k % 10 == 0:
            u = unix0 + t
            f.write(line(t, 0x120, struct.pack("<II", int(math.floor(u)), round((u - math.floor(u)) * 1e6))))
EOF

cat > "$out/soak.toml" <<EOF
[scenario]
name = "soak"
description = "soak: test pattern through the PULNiX camera chain at 59.94 Hz"
frame_rate_hz = 59.94
width = $width
height = $height
[runtime]
late_policy = "repeat"
[camera]
preset = "pulnix-ag5745ef3"
[[source]]
kind = "test_pattern"
EOF

hogpids=""
i=0
while [ "$i" -lt "$hogs" ]; do
  nice -n "$niceness" sh -c 'while :; do :; done' &
  hogpids="$hogpids $!"
  i=$((i + 1))
done
cleanup() {
  for p in $hogpids; do kill "$p" 2>/dev/null || true; done
  [ "$keep" = 1 ] || rm -rf "$out"
}
trap cleanup EXIT INT TERM

echo "soak: $seconds s at 59.94 Hz ($frames frames, ${width}x$height), $hogs hog(s) at nice $niceness, files in $out" >&2
mkfifo "$out/video"
# The consumer: ffmpeg decodes every frame and keeps only a per-frame checksum.
ffmpeg -v error -f yuv4mpegpipe -i "$out/video" -f framemd5 "$out/frames.md5" &
ffpid=$!
NVS_CONFIG_DIR=$here/config "$nvstim" run "$out/soak.toml" --clock wall --frames "$frames" \
  --telemetry "replay:$out/flight.candump" --output y4m:- --output "meta:$out/meta.jsonl" \
  --stats "$out/stats.json" > "$out/video" 2> "$out/run.log" &
pid=$!
# Resident memory of nvstim every 10 s.
: > "$out/rss.txt"
while kill -0 "$pid" 2>/dev/null; do
  awk -v t="$(date +%s)" '/^VmRSS/ {print t, $2}' "/proc/$pid/status" >> "$out/rss.txt" 2>/dev/null || true
  sleep 10
done
wait "$pid" && rc=0 || rc=$?
wait "$ffpid" && ffrc=0 || ffrc=$?
echo "soak: nvstim exit $rc, ffmpeg exit $ffrc" >&2

python3 - "$out" "$frames" "$rc" "$ffrc" <<'EOF'
import json, sys
out, frames, rc, ffrc = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
s = json.load(open(out + "/stats.json"))
decoded = sum(1 for l in open(out + "/frames.md5") if l[:1].isdigit())
rss = [int(l.split()[1]) for l in open(out + "/rss.txt") if l.strip()]
ms = lambda h, k: "%.3f" % (h[k] * 1e3)
hist = lambda name: "p50 %s p99 %s max %s ms (n %d)" % (ms(s[name], "p50_s"), ms(s[name], "p99_s"), ms(s[name], "max_s"), s[name]["n"])
period = s["period"]
print("nvstim exit status      %d (ffmpeg %d)" % (rc, ffrc))
print("elapsed                 %.1f s, ticks %d of %d" % (s["elapsed_s"], s["ticks"], frames))
print("frames emitted (fresh)  %d; rendered %d" % (s["frames_emitted"], s["frames_rendered"]))
print("deadline misses         %d (repeated %d, nothing sent %d, skipped ticks %d); late frames %d, skipped renders %d"
      % (s["deadline_misses"], s["repeats"], s["dropped_frames"], s["skipped_ticks"], s["late_frames"], s["skipped_renders"]))
print("period                  " + hist("period") + "; jitter p99 - p50 = %.3f ms, max - nominal = %.3f ms"
      % ((period["p99_s"] - period["p50_s"]) * 1e3, (period["max_s"] - 1001 / 60000) * 1e3))
print("wake late               " + hist("wake_late"))
print("render -> emission      " + hist("render_latency"))
print("telemetry -> emission   " + hist("telemetry_latency"))
print("frame time              " + hist("frame_time"))
for k in s["sinks"]:
    print("output %-16s written %d, queue drops %d, errors %d, failed %s; hand-off -> written p50 %s p99 %s max %s ms"
          % (k["name"], k["written"], k["queue_drops"], k["errors"], k["failed"], ms(k["write_latency"], "p50_s"),
             ms(k["write_latency"], "p99_s"), ms(k["write_latency"], "max_s")))
print("ffmpeg decoded          %d frames" % decoded)
if rss:
    base = rss[1] if len(rss) > 1 else rss[0]
    print("nvstim RSS              %d kB at 10 s, %d kB at the end, max %d kB (growth %+d kB over %d samples)"
          % (base, rss[-1], max(rss), rss[-1] - base, len(rss)))
EOF
