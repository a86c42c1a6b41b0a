#!/usr/bin/env python3
"""Checks what the HIL virtual machine captured (tests/hil/init.sh) against the host reference
(the same nvstim, scenarios and candump log, replayed to y4m on the host). Prints one line per
check and exits 1 when any fails.

Per case (grey: GREY, 8-bit; y16: Y16, 16-bit):
  * the client's format: 160x120, the FourCC asked for, bytes per line = width x bytes/pixel;
  * every captured frame is byte-identical to the reference frame of its index, the frames are
    consecutive (no frame lost), and v4l2-ctl's sequence numbers are the frame indices — except
    for the buffers written before the client's VIDIOC_REQBUFS, whose sequence v4l2loopback 0.12
    resets to 0 (init_buffers): their index follows from the first trusted one;
  * a client that ran to the end got every frame, 0 … N−1;
  * the content follows the replayed pose: the test pattern's pose strip is yaw/360 of the width
    (make_log.yaw_deg at the frame's time, within what the loop's extrapolation of one period
    can add), and grows, then shrinks, as the yaw does;
  * nvstim: exit 0, N frames emitted, no sink error, the V4L2 output's frame count N, the five
    malformed frames counted (unknown id 2, truncated 3), the lockstep's time marks counted, no
    frame dropped by the kernel's receive queue;
  * grey: the first client, killed mid-stream, had frames 0 … ≥ K−1 (identical), nvstim ran on
    to the end, and a second client then got K consecutive, identical frames.
"""
import argparse
import hashlib
import json
import math
import os
import re
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_log  # noqa: E402

failures = []


def check(ok, what):
    print("hil: %s %s" % ("ok  " if ok else "FAIL", what))
    if not ok:
        failures.append(what)
    return ok


def read_y4m(path):
    """Frames of a YUV4MPEG2 mono file (Cmono / Cmono16), as bytes."""
    data = open(path, "rb").read()
    head_end = data.index(b"\n")
    header = data[:head_end].decode()
    w = int(re.search(r" W(\d+)", header).group(1))
    h = int(re.search(r" H(\d+)", header).group(1))
    bpp = 2 if "Cmono16" in header else 1
    size = w * h * bpp
    frames, pos = [], head_end + 1
    while pos < len(data):
        assert data[pos:pos + 6] == b"FRAME\n", "y4m: FRAME expected at %d" % pos
        pos += 6
        frames.append(data[pos:pos + size])
        pos += size
    return frames


def read_capture(raw_path, log_path, frame_bytes):
    """(frames, sequences): whole frames of the raw file; sequence numbers of v4l2-ctl's
    'cap dqbuf' lines (None where the log was lost)."""
    raw = open(raw_path, "rb").read() if os.path.exists(raw_path) else b""
    frames = [raw[i:i + frame_bytes] for i in range(0, len(raw) - frame_bytes + 1, frame_bytes)]
    seqs = []
    if os.path.exists(log_path):
        for line in open(log_path, errors="replace"):
            m = re.search(r"cap dqbuf: \d+ seq:\s*(\d+)", line)
            if m:
                seqs.append(int(m.group(1)))
    return frames, seqs


def indices(frames, seqs, ref):
    """Frame index of each captured frame: from the sequence numbers where they are trusted
    (non-zero, or zero for the first frame of the stream), the frames before them counted back.
    Returns (indices, message) — indices None when they are inconsistent."""
    n = len(frames)
    trusted = next((i for i in range(min(n, len(seqs))) if seqs[i] > 0), None)
    if trusted is None:
        if n == 0:
            return None, "no frames"
        # No trusted sequence number: place the frames by content (first frame's index).
        first = next((k for k, r in enumerate(ref) if r == frames[0]), None)
        if first is None:
            return None, "the first frame matches no reference frame"
        return list(range(first, first + n)), "placed by content"
    first = seqs[trusted] - trusted
    idx = list(range(first, first + n))
    for i in range(trusted, min(n, len(seqs))):
        if seqs[i] != idx[i]:
            return None, "sequence %d at capture %d, expected %d (a frame lost?)" % (
                seqs[i], i, idx[i])
    return idx, "sequence numbers %d..%d consecutive from capture %d on" % (
        seqs[trusted], seqs[min(n, len(seqs)) - 1], trusted)


def compare(name, frames, seqs, ref, expect_first=None, expect_count=None,
            ref_name="the host's y4m"):
    idx, how = indices(frames, seqs, ref)
    if not check(idx is not None, "%s: frame indices (%s)" % (name, how)):
        return None
    if expect_first is not None:
        check(idx[0] == expect_first, "%s: first frame is %d (got %d)" % (name, expect_first, idx[0]))
    if expect_count is not None:
        check(len(frames) == expect_count, "%s: %d frames captured (got %d)" % (
            name, expect_count, len(frames)))
    in_range = all(0 <= k < len(ref) for k in idx)
    if not check(in_range, "%s: indices within the run" % name):
        return None
    same = [frames[i] == ref[k] for i, k in enumerate(idx)]
    bad = [idx[i] for i, s in enumerate(same) if not s]
    check(not bad, "%s: %d frames byte-identical to %s (frames %d..%d)%s" % (
        name, len(frames), ref_name, idx[0], idx[-1], "; differ: %s" % bad[:10] if bad else ""))
    return idx


def strip_px(frame, w, h, bpp):
    """Length of the pose strip: lit pixels of the pattern's top pose row (row 3h/4, above the
    target, which occupies the last h/8 rows)."""
    y = 3 * h // 4
    row = frame[y * w * bpp:(y + 1) * w * bpp]
    vals = [row[x * bpp] | (row[x * bpp + 1] << 8 if bpp == 2 else 0) for x in range(w)]
    lit = [v > 0 for v in vals]
    return lit.index(False) if False in lit else w


def check_pose(name, ref, w, h, bpp, rate_hz):
    """The reference's strip follows the log's yaw: length = floor(w·yaw/360) where yaw is the
    pose at t_k, extrapolated from the telemetry up to t_(k−1) (one period: at most 150°/s·dt,
    at the triangle's apex)."""
    slack_px = 1 + w * make_log.YAW_RATE_DEG_S / rate_hz / 360.0 * 2
    worst, lengths = 0.0, []
    for k, f in enumerate(ref):
        got = strip_px(f, w, h, bpp)
        lengths.append(got)
        want = w * make_log.yaw_deg(k / rate_hz) / 360.0
        worst = max(worst, abs(got - want))
    check(worst <= slack_px, "%s: pose strip = yaw/360 of the width within %.1f px (worst %.1f)" % (
        name, slack_px, worst))
    apex = int(make_log.APEX_S * rate_hz)
    rising = all(b >= a for a, b in zip(lengths[:apex - 2], lengths[1:apex - 1]))
    falling = all(b <= a for a, b in zip(lengths[apex + 2:-1], lengths[apex + 3:]))
    check(rising and falling and max(lengths) - min(lengths) > w // 2,
          "%s: the strip grows to %d px and shrinks back to %d px with the yaw" % (
              name, max(lengths), lengths[-1]))


def check_nvstim(name, d, frames, fourcc):
    rc = open(os.path.join(d, "nvstim.rc")).read().strip()
    check(rc == "0", "%s: nvstim exit status 0 (got %s)" % (name, rc))
    st = json.load(open(os.path.join(d, "stats.json")))
    check(st["frames_emitted"] == frames and st["sink_errors"] == 0,
          "%s: nvstim emitted %d frames, no sink error (got %d, %d)" % (
              name, frames, st["frames_emitted"], st["sink_errors"]))
    out = st["outputs"][0]
    m = re.search(r"frames (\d+), bytes (\d+), busy (\d+), errors (\d+)", out)
    check(m and int(m.group(1)) == frames and int(m.group(4)) == 0 and fourcc in out,
          "%s: V4L2 output counted %s frames, errors 0: %s" % (name, frames, out))
    tel = st["telemetry"]
    check("unknown id 2," in tel and "truncated 3," in tel,
          "%s: malformed frames counted (unknown id 2, truncated 3): %s" % (name, tel))
    # Frame N−1 is rendered at now = t_(N−2): every mark up to then, and the one after it (held
    # back), were read; no more (the log goes on).
    want = int(math.floor(make_log.RATE_HZ * (frames - 2) / 30.0 + 1e-9)) + 2
    marks = re.search(r"time marks (\d+)", tel)
    check(marks and int(marks.group(1)) == want,
          "%s: lockstep read %d time marks, up to the first past the last frame's (got %s)" % (
              name, want, marks.group(1) if marks else "none"))
    dropped = re.search(r"dropped (\d+)", tel)
    check(dropped is not None and dropped.group(1) == "0",
          "%s: no CAN frame dropped by the kernel's receive queue" % name)


def check_format(name, d, w, h, fourcc, bpp):
    fmt = open(os.path.join(d, "fmt.txt")).read()
    ok = ("Width/Height      : %d/%d" % (w, h) in fmt and "'%s'" % fourcc in fmt and
          "Bytes per Line    : %d" % (w * bpp) in fmt)
    check(ok, "%s: capture format %dx%d '%s', %d bytes per line" % (name, w, h, fourcc, w * bpp))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--ref", required=True)
    ap.add_argument("--frames", type=int, required=True)
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--height", type=int, required=True)
    ap.add_argument("--kill-after", type=int, required=True)
    ap.add_argument("--kill-tail", type=int, required=True)
    ap.add_argument("--nvstim", required=True)
    ap.add_argument("--cases", default="grey y16 gpio full")
    ap.add_argument("--gpio", type=int, default=0, help="1: the GPIO case ran (check_gpio.py)")
    a = ap.parse_args()
    cases = a.cases.split()
    w, h, n = a.width, a.height, a.frames

    host = hashlib.sha256(open(a.nvstim, "rb").read()).hexdigest()
    vm = open(os.path.join(a.out, "nvstim.sha256")).read().split()[0]
    check(host == vm, "the VM ran the host's nvstim binary (sha256 %s…)" % host[:12])
    print("hil: kernel %s; %s" % (open(os.path.join(a.out, "kernel.txt")).read().strip(),
                                  " ".join(open(os.path.join(a.out, "v4l2-info.txt")).read().split()[:12])))

    for name, fourcc, bpp in (("grey", "GREY", 1), ("y16", "Y16 ", 2)):
        if name not in cases:
            continue
        d = os.path.join(a.out, name)
        ref = read_y4m(os.path.join(a.ref, name + ".y4m"))
        check(len(ref) == n, "%s: host reference has %d frames" % (name, len(ref)))
        check_format(name, d, w, h, fourcc, bpp)
        check_nvstim(name, d, n, fourcc)
        check_pose(name, ref, w, h, bpp, 30.0)
        fb = w * h * bpp
        frames, seqs = read_capture(os.path.join(d, "cap0.raw"), os.path.join(d, "cap0.log"), fb)
        if name == "grey":
            # Killed mid-stream: its frames so far, from 0; then a second client.
            compare(name + " client 1 (killed)", frames, seqs, ref, expect_first=0)
            check(len(frames) >= a.kill_after - 1, "%s: client 1 had %d frames when killed" % (
                name, len(frames)))
            f1, s1 = read_capture(os.path.join(d, "cap1.raw"), os.path.join(d, "cap1.log"), fb)
            idx = compare(name + " client 2 (after the kill)", f1, s1, ref,
                          expect_count=a.kill_tail)
            if idx:
                check(idx[0] >= len(frames), "%s: client 2 starts after client 1's last frame" % name)
        else:
            compare(name + " client", frames, seqs, ref, expect_first=0, expect_count=n)
        check(not os.path.exists(os.path.join(d, "stuck")), "%s: no client left waiting" % name)

    if a.gpio:
        import check_gpio  # noqa: E402
        check_gpio.check_all(os.path.join(a.out, "gpio"), check)

    if failures:
        print("hil: %d check(s) failed" % len(failures))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
