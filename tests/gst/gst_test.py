#!/usr/bin/env python3
"""Tests of nvstimsrc, the GStreamer source (rt/gst, docs/gstreamer.md), one case per run.

Each case runs GStreamer's own tools on the plugin and compares with what `nvstim run` of the
same scenario writes, an independent path: the y4m header (size, rate, interlacing, depth), the
y4m frames (the bytes), the meta: output's t_sample_s (the time stamps).

  gst_test.py CASE --plugin-dir DIR --nvstim NVSTIM --work DIR

CASE: inspect, interlaced, interlaced_bff, progressive, wall, bad_setup. Prints SKIPPED: and
exits 0 where GStreamer's tools are missing.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
from decimal import Decimal
from fractions import Fraction

HERE = os.path.dirname(os.path.abspath(__file__))
PROPERTIES = ["scenario", "channel", "clock", "frames", "camera", "set", "telemetry",
              "config-dir", "cache-dir"]
# GStreamer's video buffer flags (gst/video/video-frame.h): GST_BUFFER_FLAG_LAST << 0, << 1.
FLAG_INTERLACED = 0x100000
FLAG_TFF = 0x200000
FLAG_DISCONT = 0x40

# The cases run under the sim clock: scenario, element properties, `nvstim run` arguments, and
# what the y4m header must say.
CASES = {
    "interlaced": dict(
        scenario="interlaced.toml",
        props=["frames=4", "set=width=160,height=120"],
        cli=["--frames", "4", "--set", "width=160", "--set", "height=120"],
        frames=4, y4m=("W160", "H120", "F30000:1001", "It", "Cmono")),
    # The CCIR preset by `camera`, bottom field first and 10 bits by `set` (';' between items,
    # blanks around them); the scenario's duration (0.2 s at 25 Hz) by frames=-1.
    "interlaced_bff": dict(
        scenario="interlaced.toml",
        props=["frames=-1", "camera=pulnix-ag5745ef3-ccir",
               "set=width=160; height=120 ;video.field_order=bottom;video.adc_bits=10"],
        cli=["--camera", "pulnix-ag5745ef3-ccir", "--set", "width=160", "--set", "height=120",
             "--set", "video.field_order=bottom", "--set", "video.adc_bits=10"],
        frames=5, y4m=("W160", "H120", "F25:1", "Ib", "Cmono16")),
    "progressive": dict(
        scenario="progressive.toml", props=[], cli=[],
        frames=9, y4m=("W64", "H48", "F30:1", "Ip", "Cmono")),
}


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def check(cond, msg):
    if not cond:
        fail(msg)
    print("ok: " + msg)


def run(cmd, env, timeout=60):
    print("$ " + " ".join(cmd), flush=True)
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)


def gst_env(args):
    env = dict(os.environ)
    env["GST_PLUGIN_PATH"] = args.plugin_dir
    env["GST_REGISTRY"] = os.path.join(args.work, "registry.bin")  # not the user's
    env.pop("GST_DEBUG", None)
    return env


def parse_y4m(path):
    """The header's tags and the frames' payloads."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"\n")
    tags = data[:end].decode().split()
    assert tags[0] == "YUV4MPEG2", tags
    w = int(next(t for t in tags if t.startswith("W"))[1:])
    h = int(next(t for t in tags if t.startswith("H"))[1:])
    size = w * h * (2 if "Cmono16" in tags else 1)
    frames, pos = [], end + 1
    while pos < len(data):
        nl = data.index(b"\n", pos)
        assert data[pos:nl].startswith(b"FRAME"), data[pos:nl]
        frames.append(data[nl + 1:nl + 1 + size])
        pos = nl + 1 + size
    return tags, frames


def t_samples_ns(meta_path):
    """t_sample_s of each frame of a meta: output, in integer nanoseconds (as printed)."""
    out = []
    with open(meta_path) as f:
        for line in f:
            rec = json.loads(line, parse_float=Decimal)
            out.append((int(rec["frame"]), int(rec["t_sample_s"] * Decimal(10**9))))
    return out


def clock_ns(text):
    """GStreamer's H:MM:SS.nnnnnnnnn as nanoseconds."""
    h, m, s = text.split(":")
    sec, frac = s.split(".")
    return ((int(h) * 60 + int(m)) * 60 + int(sec)) * 10**9 + int(frac.ljust(9, "0"))


BUFFER_RE = re.compile(
    r"last-message = chain.*?\((\d+) bytes, dts: ([^,]+), pts: ([^,]+), duration: ([^,]+), "
    r"offset:\s*(-?\d+), offset_end:\s*(-?\d+), flags:\s*([0-9a-fA-F]+)")
CAPS_RE = re.compile(r"GstNvstimSrc:[^.]*\.GstPad:src: caps = (.*)$", re.M)


def buffers(stdout):
    """The buffers identity silent=false reported: (bytes, pts_ns, duration_ns, offset, flags)."""
    out = []
    for m in BUFFER_RE.finditer(stdout):
        pts = None if m.group(3) == "none" else clock_ns(m.group(3))
        dur = None if m.group(4) == "none" else clock_ns(m.group(4))
        out.append((int(m.group(1)), pts, dur, int(m.group(5)), int(m.group(7), 16)))
    return out


def caps_fields(stdout):
    m = CAPS_RE.search(stdout)
    if not m:
        fail("no caps of nvstimsrc's src pad in gst-launch -v's output")
    caps = m.group(1).strip()
    fields = {}
    for part in caps.split(", ")[1:]:
        key, _, value = part.partition("=")
        fields[key] = re.sub(r"^\([a-z]+\)", "", value)
    return caps, fields


def expected_caps(tags):
    """What the caps must say, from the y4m header alone."""
    rate = next(t for t in tags if t.startswith("F"))[1:].split(":")
    inter = next(t for t in tags if t.startswith("I"))
    exp = {
        "format": "GRAY16_LE" if "Cmono16" in tags else "GRAY8",
        "width": next(t for t in tags if t.startswith("W"))[1:],
        "height": next(t for t in tags if t.startswith("H"))[1:],
        "framerate": "%s/%s" % (Fraction(int(rate[0]), int(rate[1])).numerator,
                                Fraction(int(rate[0]), int(rate[1])).denominator),
        "interlace-mode": "progressive" if inter == "Ip" else "interleaved",
    }
    aspect = next((t for t in tags if t.startswith("A")), "A1:1")[1:].split(":")
    par = Fraction(int(aspect[0]), int(aspect[1]))
    exp["pixel-aspect-ratio"] = "%d/%d" % (par.numerator, par.denominator)
    if inter != "Ip":
        exp["field-order"] = "top-field-first" if inter == "It" else "bottom-field-first"
    return exp, Fraction(int(rate[1]), int(rate[0]))


def case_inspect(args, env):
    r = run(["gst-inspect-1.0", "nvstimsrc"], env)
    check(r.returncode == 0, "gst-inspect-1.0 nvstimsrc exits 0 (%d: %s)" %
          (r.returncode, r.stderr.strip()[-300:]))
    for p in PROPERTIES:
        check(re.search(r"^\s+%s\s+:" % re.escape(p), r.stdout, re.M) is not None,
              "property '%s' listed" % p)
    check("GRAY8" in r.stdout and "GRAY16_LE" in r.stdout, "pad template names GRAY8, GRAY16_LE")
    check(re.search(r"\(0\): sim", r.stdout) and re.search(r"\(1\): wall", r.stdout),
          "clock enumerates sim and wall")
    check("libgstnvstim.so" in r.stdout, "plugin file libgstnvstim.so")


def case_sim(args, env, name):
    c = CASES[name]
    scenario = os.path.join(HERE, c["scenario"])
    y4m, meta, raw = (os.path.join(args.work, n) for n in ("run.y4m", "run.jsonl", "gst.raw"))
    r = run([args.nvstim, "run", scenario, "--clock", "sim", "--output", "y4m:" + y4m,
             "--output", "meta:" + meta] + c["cli"], env)
    check(r.returncode == 0, "nvstim run exits 0 (%d: %s)" % (r.returncode, r.stderr[-300:]))
    tags, frames = parse_y4m(y4m)
    check(all(t in tags for t in c["y4m"]), "y4m header %s has %s" % (" ".join(tags), c["y4m"]))
    samples = t_samples_ns(meta)
    check(len(frames) == c["frames"] and len(samples) == c["frames"],
          "nvstim run wrote %d frames (y4m %d, meta %d)" % (c["frames"], len(frames), len(samples)))

    cmd = ["gst-launch-1.0", "-v", "nvstimsrc", "scenario=" + scenario, "clock=sim"]
    cmd += c["props"] + ["!", "identity", "silent=false", "!", "filesink", "location=" + raw]
    r = run(cmd, env)
    check(r.returncode == 0, "gst-launch-1.0 exits 0 (%d: %s)" % (r.returncode, r.stderr[-300:]))
    caps, fields = caps_fields(r.stdout)
    exp, period = expected_caps(tags)
    for k, v in exp.items():
        check(fields.get(k) == v, "caps %s = %s (%s)" % (k, v, caps))
    bufs = buffers(r.stdout)
    check(len(bufs) == c["frames"], "%d buffers pushed (%d)" % (c["frames"], len(bufs)))
    size = len(frames[0])
    period_ns = period.numerator * 10**9 // period.denominator  # floor, as gst_util_uint64_scale
    for i, ((nbytes, pts, dur, off, flags), (frame, t_ns)) in enumerate(zip(bufs, samples)):
        check(nbytes == size, "buffer %d: %d bytes" % (i, size))
        check(pts is not None and abs(pts - t_ns) <= 1,
              "buffer %d: pts %s = t_sample_s %d ns of frame %d" % (i, pts, t_ns, frame))
        check(dur == period_ns, "buffer %d: duration %s = one period %d ns" % (i, dur, period_ns))
        check(off == frame, "buffer %d: offset %d = frame %d" % (i, off, frame))
        inter = exp["interlace-mode"] == "interleaved"
        tff = exp.get("field-order") == "top-field-first"
        check(bool(flags & FLAG_INTERLACED) == inter and bool(flags & FLAG_TFF) == tff,
              "buffer %d: flags %06x: interlaced %s, tff %s" % (i, flags, inter, tff))
    with open(raw, "rb") as f:
        got = f.read()
    want = b"".join(frames)
    first = next((i for i in range(min(len(got), len(want))) if got[i] != want[i]), None)
    check(got == want, "filesink bytes (%d) = y4m payloads (%d); first difference at %s" %
          (len(got), len(want), first))


def case_wall(args, env):
    scenario = os.path.join(HERE, "progressive.toml")
    cmd = ["gst-launch-1.0", "-v", "nvstimsrc", "scenario=" + scenario, "clock=wall",
           "frames=20", "!", "identity", "silent=false", "!", "fakesink", "sync=true"]
    r = run(cmd, env)
    check(r.returncode == 0, "gst-launch-1.0 exits 0 (%d: %s)" % (r.returncode, r.stderr[-300:]))
    check("Pipeline is live" in r.stdout, "the pipeline is live")
    bufs = buffers(r.stdout)
    # Frames exposed while the pipeline was still PAUSED are left out (docs/gstreamer.md).
    check(10 <= len(bufs) <= 20, "10 to 20 buffers pushed (%d)" % len(bufs))
    period_ns = 10**9 // 30
    for i in range(1, len(bufs)):
        (_, p0, _, o0, _), (_, p1, _, o1, _) = bufs[i - 1], bufs[i]
        step = (p1 - p0) - (o1 - o0) * 10**9 / 30
        check(o1 > o0 and abs(step) < 2e6,
              "buffer %d: pts step %d ns = %d periods within 2 ms" % (i, p1 - p0, o1 - o0))
        check(bufs[i][2] == period_ns, "buffer %d: duration one period" % i)
    check(bufs[0][1] >= 0, "first pts %d >= 0" % bufs[0][1])


def case_bad_setup(args, env):
    missing = os.path.join(args.work, "no-such-scenario")
    progressive = os.path.join(HERE, "progressive.toml")
    interlaced = os.path.join(HERE, "interlaced.toml")
    for what, cli, props in [
            ("missing scenario", [missing], ["scenario=" + missing]),
            ("unknown preset key", [interlaced, "--set", "no_such_key=1"],
             ["scenario=" + interlaced, "set=no_such_key=1"]),
            ("camera on a test pattern", [progressive, "--camera", "pulnix-ag5745ef3"],
             ["scenario=" + progressive, "camera=pulnix-ag5745ef3"])]:
        r = run([args.nvstim, "run"] + cli + ["--clock", "sim", "--frames", "1", "--output",
                                               "meta:" + os.path.join(args.work, "bad.jsonl")],
                env)
        lines = [l for l in r.stderr.splitlines() if l.startswith("nvstim: ")]
        check(r.returncode == 2 and len(lines) == 1,
              "%s: nvstim run exits 2 with one line (%d: %s)" % (what, r.returncode, r.stderr))
        r = run(["gst-launch-1.0", "nvstimsrc", "clock=sim"] + props + ["!", "fakesink"], env)
        check(r.returncode != 0, "%s: gst-launch-1.0 fails (%d)" % (what, r.returncode))
        check(lines[0] in r.stderr, "%s: its stderr has '%s' (%s)" % (what, lines[0], r.stderr))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("--plugin-dir", required=True)
    ap.add_argument("--nvstim", required=True)
    ap.add_argument("--work", required=True)
    args = ap.parse_args()
    for tool in ("gst-launch-1.0", "gst-inspect-1.0"):
        if shutil.which(tool) is None:
            print("SKIPPED: %s not found (Debian: gstreamer1.0-tools)" % tool)
            return
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    env = gst_env(args)
    if args.case == "inspect":
        case_inspect(args, env)
    elif args.case in CASES:
        case_sim(args, env, args.case)
    elif args.case == "wall":
        case_wall(args, env)
    elif args.case == "bad_setup":
        case_bad_setup(args, env)
    else:
        fail("unknown case " + args.case)
    print("PASS: " + args.case)


if __name__ == "__main__":
    main()
