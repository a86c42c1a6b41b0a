"""The HIL test's GPIO checks (tests/hil/check.py calls check_all): what the virtual machine's
GPIO case (tests/hil/init.sh, gpio_case) recorded on a gpio-sim chip. Every time is
CLOCK_MONOTONIC in ns: the kernel's line-event stamps, the helper's readings around each write
of `pull` and each read of `value` (tests/hil/hil_gpio.cpp), and nvstim's run clock, whose
origin is the --stats key clock_origin_ns (a frame's exposure window is origin + t_sample_s
± exposure_s/2; its trigger edge is origin + t_sample_s − exposure_s/2).

  * the chip: gpiodetect shows it (label nvs-sim, 4 lines); gpioinfo names lines 0 and 1;
  * gpiomon: each of 20 edges' kernel stamps lies between the helper's clock readings just
    before and just after its write of `pull` (within STAMP_SLACK_NS after): the write
    brackets are the edges' kernel stamps, independently of nvstim;
  * trigger: 40 edges at 200 ms ± 40 ms with 1.6 s more silence after the 25th: nvstim exits 0,
    one frame per edge, in order (frame i's edge is inside edge i's bracket), each frame's
    metadata arrives at a reader of the pipe within TRIGGER_LATENCY_NS of its edge's stamp,
    --stats counts 40 edges and frames, no extra edge or overrun, two stalls (before the first
    edge, and the silence), the missing edges the silence implies; the live status said TRIGGER STALLED and then ran on;
  * gate (frame scan, interlaced): nvstim exits 0; every tick of the run is either a frame
    emitted (in the metadata, frame = tick) or a miss nvstim reports (deadline_misses, and the
    tick absent or a repeat in the metadata); each emitted frame's exposure windows (per field
    when interlaced) from the metadata, from the first frame on: every sample of the gate
    line's `value` whose reading interval lies inside a window shrunk by GUARD_NS at each end
    reads 1, every one that lies GUARD_NS or more away from every window reads 0 — from before
    nvstim started to after it ended, so a missed frame, and the start-up, must leave the line
    low. No pulse may rise late. Not judged, and counted: the first reading after the sampler
    was held up longer than GUARD_NS (the VM stopped by the host), and windows with no reading
    inside (at most UNSAMPLED_MAX of them). The rise and fall delays' bounds are printed.
"""
import json
import os
import re

# Bounds stated in docs/hil.md (the HIL test's GPIO case), from the VM's measured figures.
STAMP_SLACK_NS = 1_000_000        # kernel stamp after the helper's reading after the write
TRIGGER_LATENCY_NS = 200_000_000  # edge's kernel stamp → the frame's metadata read from a pipe:
#                                   out before the next edge (one period at the nominal 5 Hz)
# Gate: samples this close to a window's edge are not judged. The line's edges lag the window
# by the pulse thread's wake-up: measured in the VM (docs/hil.md) p50 0.45-0.75 ms, at most
# 0.99 ms where two samples bracket the edge within 1 ms, and nvstim's own worst rise (its
# status, `max … ms`) up to 3.7 ms at load average 6-8 on the host; 5 ms covers that.
GUARD_NS = 5_000_000
EDGES = 40
GATE_FRAMES = 120       # each gate run (12 s at 10 Hz)
UNSAMPLED_MAX = 0.02    # windows with no sample inside (the sampler held up): at most 2 %
STALL_AFTER = 25
PERIOD_NS = 200_000_000


def read_lines(path):
    return [l.split() for l in open(path)] if os.path.exists(path) else []


def quantiles(xs):
    """'p50 a, p99 b, max c ms' of a list of ns."""
    if not xs:
        return "none"
    s = sorted(xs)
    q = lambda p: s[min(len(s) - 1, int(p * (len(s) - 1) + 0.5))]  # noqa: E731
    return "p50 %.3f, p99 %.3f, max %.3f ms (n %d)" % (q(0.5) / 1e6, q(0.99) / 1e6, s[-1] / 1e6,
                                                         len(s))


def run_ok(d, name, frames, check):
    """nvstim's exit status and --stats; `frames`: how many must have been emitted (None:
    any)."""
    rc = open(os.path.join(d, "nvstim.rc")).read().strip() if os.path.exists(
        os.path.join(d, "nvstim.rc")) else "none"
    if not check(rc == "0", "gpio %s: nvstim exit status 0 (got %s)" % (name, rc)):
        log = os.path.join(d, "nvstim.log")
        if os.path.exists(log):
            print("".join(open(log).readlines()[-5:]))
        return None
    st = json.load(open(os.path.join(d, "stats.json")))
    check((frames is None or st["frames_emitted"] == frames) and st["sink_errors"] == 0,
          "gpio %s: %s frames emitted, no sink error (got %d, %d)" % (
              name, frames if frames is not None else "the", st["frames_emitted"],
              st["sink_errors"]))
    check(st.get("clock_origin_ns", 0) > 0, "gpio %s: --stats gives the run clock's origin" % name)
    return st


def windows(metas, origin_ns):
    """Exposure windows [start, end) in ns of the frames' metadata: each field's when
    interlaced; a repeated frame adds none."""
    out = []
    for m in metas:
        if m["repeat"]:
            continue
        e = m["exposure_s"]
        # Each exposure's own gate (the frame-level gate_s is the last field's).
        for f in m["fields"] if "fields" in m else [m]:
            width = f["gate_s"] if 0 < f["gate_s"] < e else e
            start = origin_ns + round((f["t_sample_s"] - e / 2) * 1e9)
            out.append((start, start + round(width * 1e9)))
    return sorted(set(out))


def judge_samples(name, samples, wins, check, guard_ns=GUARD_NS):
    """Samples (before, after, value) against the windows: inside (shrunk by the guard) must
    read 1, outside (by the guard) must read 0; samples within the guard of a window's edge are
    not judged. No exception: a pulse that rose late (low readings inside its window) fails, as
    does one outside every window (an exposure marked that no emitted frame has). Returns the
    wrong samples and the windows without a high reading."""
    high_ok = low_ok = guard = 0
    bad = []
    j = 0
    judged_in = set()
    stalled = []  # first readings after the sampler was held up longer than the guard
    stall_flags = [k > 0 and samples[k][0] - samples[k - 1][1] > guard_ns
                   for k in range(len(samples))]
    for (tb, ta, v), after_stall in zip(samples, stall_flags):
        while j < len(wins) and wins[j][1] + guard_ns < tb:
            j += 1
        near = [k for k in range(max(0, j - 1), min(len(wins), j + 2))
                if wins[k][0] - guard_ns < ta and tb < wins[k][1] + guard_ns]
        inside = [k for k in near if wins[k][0] + guard_ns <= tb and ta <= wins[k][1] - guard_ns]
        if after_stall:
            # The VM's one CPU came back from the host: this reading may come before the pulse
            # thread (above the sampler) has caught up with the edges due while it was held.
            want = "1" if inside else ("0" if not near else None)
            stalled.append(want is None or v == want)
            continue
        if inside:
            judged_in.add(inside[0])
            if v == "1":
                high_ok += 1
            else:
                bad.append((tb, ta, v, "low inside window %d" % inside[0]))
        elif not near:
            if v == "0":
                low_ok += 1
            else:
                bad.append((tb, ta, v, "high outside every window"))
        else:
            guard += 1
    # A window with no sample inside it lies in a gap of the sampler's (the VM's one CPU held
    # by the host): it cannot be judged; a few may, no more than UNSAMPLED_MAX of the windows.
    gaps = []
    used = [x for x, st in zip(samples, stall_flags) if not st]
    for k in (k for k in range(len(wins)) if k not in judged_in):
        a, b = wins[k][0] + guard_ns, wins[k][1] - guard_ns
        before = max((ta for tb, ta, _ in used if ta <= b), default=None)
        after = min((tb for tb, ta, _ in used if tb >= a), default=None)
        gaps.append((after - before) / 1e6 if before is not None and after is not None else -1)
    check(not bad and len(gaps) <= UNSAMPLED_MAX * len(wins) and high_ok > 0 and
          low_ok > 0,
          "gpio %s: gate line high at %d sampled instants inside the %d exposure windows (%d "
          "windows judged, %d in the sampler's gaps%s), low at %d outside; guard %.1f ms at each "
          "window edge: %d samples not judged; the first reading after each of %d sampler stalls "
          "over the guard not judged (%d of them off); wrong samples %d%s" % (
              name, high_ok, len(wins), len(wins) - len(gaps), len(gaps),
              " of %s ms" % ", ".join("%.1f" % g for g in gaps) if gaps else "", low_ok,
              guard_ns / 1e6, guard, len(stalled), stalled.count(False), len(bad),
              ": %s" % bad[:5] if bad else ""))
    return bad


RESOLVED_NS = 1_000_000  # an edge's delay is measured where two samples bracket it this closely


def edge_delay(samples, t, new):
    """The delay of the line's change to `new` expected at t [ns], as (lower, upper) bounds:
    the last sample from t on that still read the old value (its reading began before the
    change) and the first that read the new one (its reading ended after it). None when the
    samples do not show the change within 50 ms."""
    old = "0" if new == "1" else "1"
    lo, i = 0, 0
    while i < len(samples) and samples[i][0] < t:
        i += 1
    while i < len(samples) and samples[i][2] == old and samples[i][0] < t + 50_000_000:
        lo = samples[i][0] - t
        i += 1
    if i < len(samples) and samples[i][2] == new and samples[i][0] < t + 50_000_000:
        return lo, samples[i][1] - t
    return None


def edge_delays(samples, wins):
    """Upper bounds [ns] of each window's rise and fall delay where the samples resolve them
    (bounds within RESOLVED_NS), and how many edges were resolved."""
    rise, fall = [], []
    for start, end in wins:
        for t, new, out in ((start, "1", rise), (end, "0", fall)):
            b = edge_delay(samples, t, new)
            if b is not None and b[1] - b[0] <= RESOLVED_NS:
                out.append(b[1])
    return rise, fall


def read_samples(d):
    return [(int(a), int(b), v) for a, b, v in read_lines(os.path.join(d, "samples.txt"))]


def check_chip(d, check):
    det = open(os.path.join(d, "gpiodetect.txt")).read() if os.path.exists(
        os.path.join(d, "gpiodetect.txt")) else ""
    check(re.search(r"gpiochip\d+ \[nvs-sim\] \(4 lines\)", det) is not None,
          "gpio: gpio-sim chip made through configfs: %s" % det.strip())
    info = open(os.path.join(d, "gpioinfo.txt")).read() if os.path.exists(
        os.path.join(d, "gpioinfo.txt")) else ""
    check('"trigger"' in info and '"gate"' in info, "gpio: gpioinfo names lines 0 and 1 trigger, gate")


def check_gpiomon(d, check):
    stamps = [int(s) * 1_000_000_000 + int(n) for s, n in read_lines(os.path.join(d, "gpiomon.txt"))]
    edges = [(int(b), int(a)) for _, _, b, a in read_lines(os.path.join(d, "edges.txt"))]
    if not check(len(stamps) == len(edges) == 20,
                 "gpio gpiomon: 20 rising edges stamped (got %d of %d)" % (len(stamps), len(edges))):
        return
    after = [s - b for s, (b, a) in zip(stamps, edges)]
    past = [s - a for s, (b, a) in zip(stamps, edges)]
    ok = all(s >= b and s <= a + STAMP_SLACK_NS for s, (b, a) in zip(stamps, edges))
    check(ok, "gpio gpiomon: each kernel stamp within its write of `pull` (stamp − before: %s; "
          "stamp − after: max %.3f ms, bound %.1f ms)" % (quantiles(after), max(past) / 1e6,
                                                          STAMP_SLACK_NS / 1e6))


def check_trigger(d, check):
    st = run_ok(d, "trigger", EDGES, check)
    if st is None:
        return
    origin = st["clock_origin_ns"]
    edges = [(int(b), int(a)) for _, _, b, a in read_lines(os.path.join(d, "edges.txt"))]
    check(len(edges) == EDGES, "gpio trigger: %d edges made (got %d)" % (EDGES, len(edges)))
    frames = []
    for line in open(os.path.join(d, "meta.stamped")):
        arrival, _, js = line.partition(" ")
        if js.startswith("{"):
            frames.append((int(arrival), json.loads(js)))
    check([m["frame"] for _, m in frames] == list(range(EDGES)) and
          not any(m["repeat"] for _, m in frames),
          "gpio trigger: frames 0..%d, in order, none repeated (got %d)" % (EDGES - 1, len(frames)))
    # Frame i's edge, from its metadata, inside edge i's bracket.
    fedge = [origin + round((m["t_sample_s"] - m["exposure_s"] / 2) * 1e9) for _, m in frames]
    pairs = list(zip(fedge, edges))
    own = all(b <= e <= a + STAMP_SLACK_NS for e, (b, a) in pairs)
    check(own and len(pairs) == EDGES,
          "gpio trigger: each frame's edge is its own edge's kernel stamp (inside the write of "
          "`pull`: stamp − before %s)" % quantiles([e - b for e, (b, a) in pairs]))
    intervals = [b2 - b1 for (b1, _), (b2, _) in zip(edges, edges[1:])]
    normal = intervals[:STALL_AFTER - 1] + intervals[STALL_AFTER:]
    if normal:
        print("hil: gpio trigger: edge intervals %.1f..%.1f ms (200 ms ± 40 ms asked), silence "
              "%.1f ms after edge %d" % (min(normal) / 1e6, max(normal) / 1e6,
                                         intervals[STALL_AFTER - 1] / 1e6, STALL_AFTER))
    lat = [arr - e for (arr, _), e in zip(frames, fedge)]
    check(lat and all(0 < x <= TRIGGER_LATENCY_NS for x in lat),
          "gpio trigger: edge stamp → frame's metadata at the reader %s; bound %.0f ms" % (
              quantiles(lat), TRIGGER_LATENCY_NS / 1e6))
    t = st.get("trigger", {})
    missing = sum(max(0, (2 * d + PERIOD_NS) // (2 * PERIOD_NS) - 1) for d in intervals)
    # Two stalls: before the first edge (the edges start after nvstim's first status line, a
    # second after its start, past the 0.5-s timeout) and in the silence after edge 25.
    check(t.get("edges") == EDGES and t.get("frames") == EDGES and t.get("extra") == 0 and
          t.get("overruns") == 0 and t.get("stalls") == 2 and t.get("missing") == missing,
          "gpio trigger: --stats: edges %s, frames %s, extra %s, overruns %s, stalls %s, missing %s"
          " (expected %d, %d, 0, 0, 2, %d); nvstim's edge → emission %s" % (
              t.get("edges"), t.get("frames"), t.get("extra"), t.get("overruns"), t.get("stalls"),
              t.get("missing"), EDGES, EDGES, missing,
              "p50 %.3f p99 %.3f max %.3f ms" % (t["latency"]["p50_s"] * 1e3,
                                                  t["latency"]["p99_s"] * 1e3,
                                                  t["latency"]["max_s"] * 1e3)
              if "latency" in t else "none"))
    status = [l for l in open(os.path.join(d, "nvstim.log")) if l.startswith("nvstim run: frame")]
    # The silence after edge 25: a stalled status line between two that are not (once a second:
    # the 5 s of edges before the silence and the 3 s after it each have some).
    flags = "".join("S" if "TRIGGER STALLED" in l else "r" for l in status)
    check(re.search(r"rS+r", flags) is not None,
          "gpio trigger: the live status (once a second) said TRIGGER STALLED in the silence "
          "and ran on after it: %s (S stalled, r running)" % flags)
    # The gate under the trigger clock: the exposure starts at the edge, and its pulse is
    # scheduled once the edge is read, so it rises after the edge by about the edge → frame
    # latency (docs/hil.md); printed, not judged.
    wins = windows([m for _, m in frames], origin)
    samples = read_samples(d)
    rise = [b for b in (edge_delay(samples, w[0], "1") for w in wins) if b is not None]
    fall = [b for b in (edge_delay(samples, w[1], "0") for w in wins) if b is not None]
    print("hil: gpio trigger: gate rise after the edge between %s and %s; fall after the "
          "window's end between %s and %s (lower and upper bounds)" % (
              quantiles([b[0] for b in rise]), quantiles([b[1] for b in rise]),
              quantiles([b[0] for b in fall]), quantiles([b[1] for b in fall])))


def ticks_accounted(metas, ticks, st):
    """Every tick 0 … ticks−1 either emitted a fresh frame (frame = tick in the metadata) or is
    a miss nvstim reports: counted in deadline_misses, and in the metadata a repeat or nothing.
    Returns (fresh frames, missed ticks, what is wrong or "")."""
    fresh = [m for m in metas if not m["repeat"]]
    wrong = [m["frame"] for m in fresh if m.get("tick", m["frame"]) != m["frame"]]
    emitted = {m["frame"] for m in fresh}
    missed = [k for k in range(ticks) if k not in emitted]
    if wrong:
        return fresh, missed, "fresh frames on another tick: %s" % wrong[:5]
    if len(fresh) != st["frames_emitted"] or len(emitted) != len(fresh):
        return fresh, missed, "%d fresh frames in the metadata, %d emitted" % (
            len(fresh), st["frames_emitted"])
    if len(missed) != st["deadline_misses"]:
        return fresh, missed, "%d ticks without their frame, nvstim reports %d misses" % (
            len(missed), st["deadline_misses"])
    return fresh, missed, ""


def check_gate(d, name, frames_n, check):
    st = run_ok(d, name, None, check)
    if st is None:
        return
    metas = [json.loads(l) for l in open(os.path.join(d, "meta.jsonl"))]
    fresh, missed, wrong = ticks_accounted(metas, frames_n, st)
    origin = st["clock_origin_ns"]
    gate = [o for o in st["outputs"] if o.startswith("gpio:")]
    wins = windows(fresh, origin)
    first = (wins[0][0] - origin) / 1e6 if wins else 0.0
    made = st.get("first_frame_made_s", 0) * 1e3
    check(not wrong and fresh,
          "gpio %s: every tick accounted for: %d frames emitted, %d missed and reported (ticks "
          "%s)%s; start-up: loop threads made in %.1f ms before the origin; frame %s made at "
          "%.1f ms on the run clock, %.1f ms before its first exposure starts (%.1f ms)" % (
              name, len(fresh), len(missed), missed[:12] if missed else "-",
              "; wrong: " + wrong if wrong else "", st.get("loop_start_s", 0) * 1e3,
              st.get("first_frame"), made, first - made, first))
    if not wins:
        return
    fields = 2 if "fields" in fresh[0] else 1
    # Judged: every sample, from before nvstim started to after it ended (no pulse before the
    # first frame, none for a missed one, none after the last).
    samples = read_samples(d)
    judge_samples(name, samples, wins, check)
    # On the wall clock a frame is due at its first exposure's start: none is handed to the
    # pulse thread after it (a frame made later is dropped, with no pulse).
    m = re.search(r"handed over after it (\d+)", gate[0]) if gate else None
    check(m is not None and m.group(1) == "0",
          "gpio %s: pulses handed to the pulse thread after their exposure's start: %s" % (
              name, m.group(1) if m else "not in the status line"))
    # The missed ticks' nominal windows (each exposure at origin + t ± exposure/2, t = k·T, and
    # k·T − T/2 for an interlaced frame's first field): the line stayed low there (judged above
    # as outside every window; counted here).
    period = 1e9 / st["frame_rate_hz"]
    e = fresh[0]["exposure_s"] * 1e9
    nominal = [(origin + k * period - f * period / fields - e / 2,
                origin + k * period - f * period / fields + e / 2)
               for k in missed for f in range(fields)]
    lows = sum(1 for tb, ta, v in samples
               if v == "0" and any(a <= tb and ta <= b for a, b in nominal))
    rise, fall = edge_delays(samples, wins)
    print("hil: gpio %s: %d windows (%d per frame) from frame %d; %s; missed ticks %d (samples "
          "low in their nominal windows %d); where two samples within %.0f ms bracket it: "
          "rise after the window's start (upper bound) %s; fall after its end %s; sampling "
          "interval %s" % (
              name, len(wins), fields, fresh[0]["frame"], gate[0] if gate else "no gpio output",
              len(missed), lows, RESOLVED_NS / 1e6, quantiles(rise), quantiles(fall),
              quantiles([b[0] - a[0] for a, b in zip(samples, samples[1:])])))


def check_all(d, check):
    if not check(not os.path.exists(os.path.join(d, "error")), "gpio: the chip was made"):
        return
    check_chip(d, check)
    check_gpiomon(os.path.join(d, "gpiomon"), check)
    check_trigger(os.path.join(d, "trigger"), check)
    check_gate(os.path.join(d, "frame"), "frame", GATE_FRAMES, check)
    check_gate(os.path.join(d, "interlaced"), "interlaced", GATE_FRAMES, check)
