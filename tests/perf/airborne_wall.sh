#!/bin/sh
# The moving-platform real-time check of docs/performance.md: the airborne-pass scene
# (scenarios/airborne-pass: RIT site from 300 m, 768×494 interlaced, every camera stage on) for a
# set time on the wall clock at 29.97 frames/s of 59.94 fields/s, the platform orbiting the site
# the whole time (telemetry replayed from a CAN log this script writes: radius 400 m, 300 m up,
# 60 m/s, the camera turned toward the site), y4m to /dev/null and the metadata to a file.
# Reports deadline misses (repeated frames and ticks with nothing sent) in the first second and
# after it, the emission period p50/p99/max, render → emission latency and the CPU per field.
#
# With WALL_SCENARIO=airborne-pass-fusion, the same flight seen by the fusion rig (the intensified
# camera and a thermal one on one time line, docs/fusion.md): each channel's outputs, misses and
# period apart.
#
# Not run by `make test` (it takes the time it is given). Usage:
#   tests/perf/airborne_wall.sh [BUILD_DIR]       # default build/release
# Environment: WALL_SECONDS (60), WALL_SCENARIO (airborne-pass, airborne-pass-fusion, or a
# scenario folder's path),
# WALL_OUT (a folder to keep the files; default temporary),
# WALL_REALTIME=1 ([runtime] realtime = true: SCHED_FIFO threads and mlockall; needs the
# privilege to use them).
set -eu

here=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$here/build/release}
nvstim=$build/rt/cli/nvstim
[ -x "$nvstim" ] || { echo "airborne_wall: $nvstim not built" >&2; exit 2; }
command -v python3 >/dev/null || { echo "airborne_wall: python3 is needed" >&2; exit 2; }
seconds=${WALL_SECONDS:-60}
if [ -n "${WALL_OUT:-}" ]; then
  out=$WALL_OUT; mkdir -p "$out"; keep=1
else
  out=$(mktemp -d "${TMPDIR:-/tmp}/nvstim-wall-XXXXXX"); keep=0
fi
scenario=${WALL_SCENARIO:-airborne-pass}
# A shipped scenario's name, or the path of a scenario folder modelled on one (its relative paths
# are those of a folder in scenarios/).
case $scenario in */*) sdir=$scenario ;; *) sdir=$here/scenarios/$scenario ;; esac
# A rig's channels (their [[channel]] names), each with outputs of its own.
channels=$(python3 -c "import sys, tomllib; print(' '.join(c['name'] for c in tomllib.load(open(sys.argv[1], 'rb')).get('channel', [])))" "$sdir/scenario.toml")

# Telemetry (config/can/nvstim.dbc, Intel order, as scenarios/airborne-pass/make_flight.py
# writes it): position 50 Hz, attitude 100 Hz, time 10 Hz, for the run and 5 s more.
python3 - "$out/orbit.candump" "$seconds" <<'PY'
import math, struct, sys
path, seconds = sys.argv[1], float(sys.argv[2]) + 5.0
LAT0, LON0, H0 = 43.16856, -77.61583, 218.0
UNIX0 = 904708800
R, ALT, SPEED = 400.0, 300.0, 60.0
A, E2 = 6378137.0, 6.69437999014e-3
sl = math.sin(math.radians(LAT0))
N = A / math.sqrt(1 - E2 * sl * sl)
M = A * (1 - E2) / (1 - E2 * sl * sl) ** 1.5
w = SPEED / R
PITCH = -math.degrees(math.atan2(ALT, R))
def frame(t, can_id, data):
    return (t, can_id, "(%d.%06d) can0 %03X#%s\n" % (UNIX0 + int(math.floor(t)),
            round((t - math.floor(t)) * 1e6) % 1000000, can_id, data.hex().upper()))
lines = []
for k in range(int(seconds * 50) + 1):
    t = k / 50.0
    a = w * t                      # angle of the aircraft around the site, from north, clockwise
    east, north = R * math.sin(a), R * math.cos(a)
    lat = LAT0 + math.degrees(north / (M + H0))
    lon = LON0 + math.degrees(east / ((N + H0) * math.cos(math.radians(LAT0))))
    lines.append(frame(t, 0x100, struct.pack("<ii", round(lat * 1e7), round(lon * 1e7))))
    lines.append(frame(t, 0x101, struct.pack("<i", round((H0 + ALT) * 1000))))
for k in range(int(seconds * 100) + 1):
    t = k / 100.0
    yaw = (math.degrees(w * t) + 180.0) % 360.0   # toward the site
    lines.append(frame(t, 0x110, struct.pack("<hhH", 0, round(PITCH * 100), round(yaw * 100))))
for k in range(int(seconds * 10) + 1):
    t = k / 10.0
    u = UNIX0 + t
    lines.append(frame(t, 0x120, struct.pack("<II", int(math.floor(u)), round((u - math.floor(u)) * 1e6))))
lines.sort(key=lambda x: (x[0], x[1]))
with open(path, "w") as f:
    f.writelines(l for _, _, l in lines)
PY

sed -e "s#\"\.\./rit/#\"$here/scenarios/rit/#" -e "s#\"\.\./\.\./config/#\"$here/config/#" \
    -e "s#replay:[^\"]*flight.candump#replay:$out/orbit.candump#" \
    -e "s#^duration_s = .*#duration_s = $seconds#" \
    "$sdir/scenario.toml" > "$out/scenario.toml"
if [ "${WALL_REALTIME:-0}" = 1 ]; then
  printf '\n[runtime]\nrealtime = true\n' >> "$out/scenario.toml"
fi

if [ -z "$channels" ]; then
  outputs="--output y4m:/dev/null --output meta:$out/meta.jsonl"
else
  outputs=""
  for c in $channels; do
    outputs="$outputs --output y4m:/dev/null?channel=$c --output meta:$out/meta-$c.jsonl?channel=$c"
  done
fi

echo "airborne_wall: $scenario, $seconds s on the wall clock (realtime ${WALL_REALTIME:-0}), load $(cut -d' ' -f1-3 /proc/loadavg)" >&2
status=0
# shellcheck disable=SC2086  # $outputs is a list of words
/usr/bin/time -f "%U %S" -o "$out/cpu" "$nvstim" run "$out/scenario.toml" --clock wall \
    $outputs --stats "$out/stats.json" 2>"$out/run.log" || status=$?
python3 - "$out" "$status" $channels <<'PY'
import json, sys
out, status, channels = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
stats = json.load(open(out + "/stats.json"))
user, sys_ = (float(x) for x in open(out + "/cpu").read().split())
per = stats["channels"] if channels else [dict(stats, channel="")]
work = 0
for st in per:
    name = st["channel"]
    label = "airborne_wall: " + (name + ": " if name else "")
    early = late = 0
    ticks = []
    for line in open(out + ("/meta-%s.jsonl" % name if name else "/meta.jsonl")):
        m = json.loads(line)
        ticks.append(m["tick"])
        if m["repeat"]:
            if m["t_sample_s"] < 1.0: early += 1
            else: late += 1
    gaps = sum(b - a - 1 for a, b in zip(ticks, ticks[1:]) if b - a > 1)
    # Ticks before the first frame was ready (nothing to send yet): at the start, in the first
    # second.
    lead = ticks[0] if ticks else 0
    early += lead
    p, r = st["period"], st["render_latency"]
    exposures = (2 if st["scan"] == "interlaced" else 1) * st["frames_rendered"]
    work += exposures
    print("%sexit %d, %d ticks, %d frames emitted, %d rendered; deadline misses %d (%.3f %%): in "
          "the first second %d (%d of them before the first frame), after it %d (repeated %d, "
          "nothing sent %d)" % (label, status, st["ticks"], st["frames_emitted"],
          st["frames_rendered"], st["deadline_misses"],
          100.0 * st["deadline_misses"] / max(st["ticks"], 1), early, lead, late + gaps, late, gaps))
    print("%speriod p50 %.2f p99 %.2f max %.2f ms; render to emission p50 %.1f p99 %.1f max %.1f ms"
          % (label, p["p50_s"] * 1e3, p["p99_s"] * 1e3, p["max_s"] * 1e3, r["p50_s"] * 1e3,
             r["p99_s"] * 1e3, r["max_s"] * 1e3))
print("airborne_wall: CPU %.1f ms per exposure (field or frame) over every channel; load %s"
      % ((user + sys_) / max(work, 1) * 1e3, " ".join(open("/proc/loadavg").read().split()[:3])))
PY
[ "$keep" = 1 ] || rm -rf "$out"
exit "$status"
