#!/usr/bin/python3
"""Checks the HIL test's fusion case (tests/hil/init.sh, fusion_run) on the host: a rig of two
channels (ii: the intensified camera, 29.97 frames/s interlaced; lwir: the thermal core, 30 Hz)
ran in the VM under the sim clock, each channel on its own v4l2loopback node (/dev/video10,
/dev/video11, GREY), and a real V4L2 client (v4l2-ctl) captured each node. Per run (no fault;
faults: the thermal channel 1 ms late and misregistered 0.2° in yaw):

  * nvstim exited 0, emitted N frames a channel with no sink error and no dropped frame, and its
    V4L2 outputs counted N frames each;
  * each client's format is the channel's size, GREY; it captured N frames, each byte-identical
    to the frame nvstim wrote to y4m in the same run, in order from frame 0 (v4l2-ctl's sequence
    numbers, where v4l2loopback keeps them, are the metadata's frame numbers): the client got
    both streams whole;
  * the VM's frames against the host's run of the same scenario: bit-identical, or within the
    cross-ISA frame tolerance (nvs_isa_compare run-frames; the VM's CPU has no AVX-512); the
    metadata's stamps, geometry, homographies and faults identical;
  * the reference fusion consumer (examples/fusion/nvstim_fusion_reference.py) on the captured
    streams (wrapped as y4m) and the metadata, lwir warped into ii:
      - every lwir frame is paired with an ii frame by its stamps within half a period, and the
        pair's frames have the same sequence number;
      - the skew recovered from the stamps is within 0.1 ms of the injected one (0 without a
        fault, 1 ms with it);
      - the RIT scene's aluminium fiducials (examples/fusion/rit_fiducials.py), measured in both
        channels, are within 1 px of each other after warping with the published homography
        without a fault, and within 1 px of the shift the injected misregistration predicts with
        it (expected: proj_ii(X) - H(K R^T K^-1 proj_lwir(X)), R the misregistration's rotation
        in the thermal camera's axes; Hartley & Zisserman, Multiple View Geometry, 2nd ed.,
        §8.4.2), which is itself over 2 px, so that it is seen.

Usage: check_fusion_hil.py --out VM_OUT/fusion --ref REF/fusion --src SOURCE_DIR --frames N
           [--runs "nofault:fusion faults:fusion_faults"] [--isa-compare NVS_ISA_COMPARE]
Prints one line per check ("hil: ok" / "hil: FAIL") and exits 1 when any fails.
"""
import argparse
import json
import os
import re
import subprocess
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check as hil  # noqa: E402  (check(), read_capture(), compare(): the GREY case's)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fusion"))
from fusion_geometry import predicted_offset_px, records  # noqa: E402

import numpy as np  # noqa: E402

A, B = "lwir", "ii"            # A is warped into B
SKEW_TOLERANCE_S = 1e-4
OFFSET_TOLERANCE_PX = 1.0
MIN_MISREGISTRATION_SHIFT_PX = 2.0
MIN_FIDUCIALS = 2


def y4m_header(path):
    with open(path, "rb") as f:
        return f.readline()


def y4m_rate(header):
    m = re.search(rb" F(\d+):(\d+)", header)
    return "%s/%s" % (m.group(1).decode(), m.group(2).decode())


def write_y4m(path, header, frames):
    with open(path, "wb") as f:
        f.write(header)
        for fr in frames:
            f.write(b"FRAME\n")
            f.write(fr)


def write_pgms(folder, frames, w, h):
    os.makedirs(folder, exist_ok=True)
    for k, fr in enumerate(frames):
        with open(os.path.join(folder, "%06d.pgm" % k), "wb") as f:
            f.write(b"P5\n%d %d\n255\n" % (w, h))
            f.write(fr)


def run_tool(cmd, log_path, timeout_s=300):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=timeout_s)
    with open(log_path, "w", encoding="utf-8") as f:
        f.write(p.stdout)
    return p.returncode, p.stdout


def check_nvstim(name, d, n):
    check = hil.check
    rc = open(os.path.join(d, "nvstim.rc")).read().strip()
    check(rc == "0", "fusion %s: nvstim exit status 0 (got %s)" % (name, rc))
    st = json.load(open(os.path.join(d, "stats.json")))
    chans = {c["channel"]: c for c in st.get("channels", [])}
    for ch, dev in ((B, "/dev/video10"), (A, "/dev/video11")):
        c = chans.get(ch)
        if not check(c is not None, "fusion %s: --stats has channel %s" % (name, ch)):
            continue
        check(c["frames_emitted"] == n and c["sink_errors"] == 0 and c["fault_drops"] == 0,
              "fusion %s: %s emitted %d frames, no sink error, none dropped (got %d, %d, %d)" % (
                  name, ch, n, c["frames_emitted"], c["sink_errors"], c["fault_drops"]))
        out = [o for o in c["outputs"] if o.startswith("v4l2:%s" % dev)]
        m = re.search(r"frames (\d+), bytes (\d+), busy (\d+), errors (\d+)", out[0] if out else "")
        check(m and int(m.group(1)) == n and int(m.group(4)) == 0 and "GREY" in out[0],
              "fusion %s: %s's V4L2 output %s counted %d frames, errors 0: %s" % (
                  name, ch, dev, n, out[0] if out else "none"))


def check_run(name, d, ref_d, src, n, isa_compare, fiducials):
    check = hil.check
    work = os.path.join(d, "host")
    os.makedirs(work, exist_ok=True)
    check_nvstim(name, d, n)
    meta = {ch: records(os.path.join(d, ch + ".jsonl")) for ch in (A, B)}
    meta_ref = {ch: records(os.path.join(ref_d, ch + ".jsonl")) for ch in (A, B)}
    video = {}
    for ch in (B, A):
        cam = meta[ch][0]["camera"]
        w, h = cam["width"], cam["height"]
        check(len(meta[ch]) == n and [r["frame"] for r in meta[ch]] == list(range(n)),
              "fusion %s: %s metadata: frames 0..%d in order" % (name, ch, n - 1))
        fmt = open(os.path.join(d, "fmt_%s.txt" % ch)).read()
        check("Width/Height      : %d/%d" % (w, h) in fmt and "'GREY'" in fmt and
              "Bytes per Line    : %d" % w in fmt,
              "fusion %s: %s capture format %dx%d 'GREY', %d bytes per line" % (name, ch, w, h, w))
        # What nvstim wrote in the VM (y4m, the same run) and what the client captured.
        wrote = hil.read_y4m(os.path.join(d, ch + ".y4m"))
        frames, seqs = hil.read_capture(os.path.join(d, "cap_%s.raw" % ch),
                                        os.path.join(d, "cap_%s.log" % ch), w * h)
        idx = hil.compare("fusion %s %s client" % (name, ch), frames, seqs, wrote,
                          expect_first=0, expect_count=n,
                          ref_name="what nvstim wrote to y4m in the same run")
        if idx is not None:
            check(idx == [r["frame"] for r in meta[ch]][:len(idx)],
                  "fusion %s: %s: the captured frames' indices are the metadata's frame numbers"
                  % (name, ch))
        stuck = os.path.join(d, "stuck")
        check(not (os.path.exists(stuck) and "client %s " % ch in open(stuck).read()),
              "fusion %s: the %s client was not left waiting" % (name, ch))
        # The VM's run against the host's.
        ref = hil.read_y4m(os.path.join(ref_d, ch + ".y4m"))
        same = sum(1 for a, b in zip(wrote, ref) if a == b)
        if len(wrote) == len(ref) and same == len(ref):
            check(True, "fusion %s: %s: the VM's %d frames bit-identical to the host's" % (
                name, ch, same))
        elif isa_compare:
            write_pgms(os.path.join(work, "isa", ch, "host"), ref, w, h)
            write_pgms(os.path.join(work, "isa", ch, "vm"), wrote, w, h)
            rc, out = run_tool([isa_compare, "run-frames", os.path.join(work, "isa", ch, "host"),
                                os.path.join(work, "isa", ch, "vm")],
                               os.path.join(work, "isa_%s.log" % ch))
            print("\n".join("hil:   " + line for line in out.strip().splitlines()))
            check(rc == 0 and len(wrote) == len(ref),
                  "fusion %s: %s: the VM's frames within the cross-ISA frame tolerance of the "
                  "host's (%d of %d bit-identical)" % (name, ch, same, len(ref)))
        else:
            check(False, "fusion %s: %s: %d of %d frames bit-identical to the host's, and no "
                  "nvs_isa_compare given" % (name, ch, same, len(ref)))
        keys = ("frame", "t_sample_s", "exposure_start_s", "exposure_end_s", "fields", "camera",
                "channel", "rig", "faults")
        diff = [r["frame"] for r, q in zip(meta[ch], meta_ref[ch])
                if any(r.get(k) != q.get(k) for k in keys)]
        check(len(meta[ch]) == len(meta_ref[ch]) and not diff,
              "fusion %s: %s: the VM's metadata (stamps, camera, homographies, faults) is the "
              "host's%s" % (name, ch, "; differs in frames %s" % diff[:10] if diff else ""))
        # The capture as the consumer reads it: the client's frames under the y4m header nvstim
        # wrote for the channel.
        header = y4m_header(os.path.join(d, ch + ".y4m"))
        write_y4m(os.path.join(work, "cap_%s.y4m" % ch), header, frames)
        video[ch] = y4m_rate(header)

    # The reference consumer on the captured streams.
    consumer = os.path.join(src, "examples", "fusion", "nvstim_fusion_reference.py")
    cmd = ["/usr/bin/python3", consumer,
           "--a", os.path.join(work, "cap_%s.y4m" % A), os.path.join(d, A + ".jsonl"),
           "--b", os.path.join(work, "cap_%s.y4m" % B), os.path.join(d, B + ".jsonl"),
           "--rate-a", video[A], "--rate-b", video[B], "--fiducials", fiducials,
           "--json", os.path.join(work, "summary.json"),
           "--fused-dir", os.path.join(work, "fused"), "--fused-max", "1"]
    rc, out = run_tool(cmd, os.path.join(work, "consumer.log"))
    if not check(rc == 0, "fusion %s: the reference consumer ran (exit %d; %s)" % (
            name, rc, os.path.join(work, "consumer.log"))):
        print(out)
        return
    s = json.load(open(os.path.join(work, "summary.json")))

    # Pairs by the stamps, and by the sequence numbers.
    p = s["pairs"]
    half_s = 0.5 * max(1.0 / 30.0, 1001.0 / 30000.0)
    same_seq = sum(1 for q in p["list"] if q["frame_a"] == q["frame_b"])
    check(p["total"] == n and p["matched"] == n and p["max_abs_dt_s"] <= half_s,
          "fusion %s: %d/%d %s frames paired with an %s frame by their stamps, max |dt| %.3f ms "
          "(at most half a period, %.3f ms)" % (name, p["matched"], p["total"], A, B,
                                               p["max_abs_dt_s"] * 1e3, half_s * 1e3))
    check(same_seq == n, "fusion %s: every pair has one sequence number in both channels (%d/%d)"
          % (name, same_seq, n))

    # The skew from the stamps (the consumer's is B's offset less A's: lwir vs ii = -skew_s).
    injected_s = meta[A][0]["faults"]["skew_s"] - meta[B][0]["faults"]["skew_s"]
    got_s = -s["skew_s"]
    check(abs(got_s - injected_s) < SKEW_TOLERANCE_S,
          "fusion %s: skew of %s vs %s recovered from the stamps %+.4f ms, injected %+.4f ms "
          "(error %+.4f ms, tolerance %.1f ms)" % (name, A, B, got_s * 1e3, injected_s * 1e3,
                                                  (got_s - injected_s) * 1e3,
                                                  SKEW_TOLERANCE_S * 1e3))

    # The fiducials after warping.
    f = s.get("fiducials") or {}
    measured = [r for r in f.get("list", []) if r["status"] == "measured"]
    skipped = ["%s %s" % (r["name"], r["status"]) for r in f.get("list", [])
               if r["status"] != "measured"]
    check(len(measured) >= MIN_FIDUCIALS,
          "fusion %s: %d fiducials measured in both channels (at least %d; skipped: %s)" % (
              name, len(measured), MIN_FIDUCIALS, ", ".join(skipped) or "none"))
    ypr = meta[A][0]["faults"]["misregistration_deg"]
    faulted = any(abs(v) > 0 for v in ypr)
    for r in measured:
        expected = predicted_offset_px(meta[A][0], meta[B][0], r["xyz_m"])
        got = np.array(r["offset_px"])
        miss = float(np.hypot(*(got - expected)))
        if faulted:
            shift = float(np.hypot(*expected))
            check(miss < OFFSET_TOLERANCE_PX and shift > MIN_MISREGISTRATION_SHIFT_PX,
                  "fusion %s: fiducial %s off by (%+.2f, %+.2f) px after warping; the %s° "
                  "misregistration predicts (%+.2f, %+.2f) px: %.2f px apart (tolerance %.1f px)"
                  % (name, r["name"], got[0], got[1], "/".join("%g" % v for v in ypr),
                     expected[0], expected[1], miss, OFFSET_TOLERANCE_PX))
        else:
            check(r["offset_abs_px"] < OFFSET_TOLERANCE_PX,
                  "fusion %s: fiducial %s aligned after warping: offset (%+.2f, %+.2f) px, "
                  "|%.2f| px (tolerance %.1f px; parallax of its height %+.2f px)" % (
                      name, r["name"], got[0], got[1], r["offset_abs_px"], OFFSET_TOLERANCE_PX,
                      expected[0]))
    t = open(os.path.join(d, "vm_time_s")).read().split()
    heat = [l for l in open(os.path.join(d, "nvstim.log")) if "heat balance" in l]
    print("hil: fusion %s: nvstim ran %.1f s in the VM, %d frames a channel; %s" % (
        name, float(t[1]) - float(t[0]), n,
        heat[0].split("thermal: ")[-1].split(", weather")[0] if heat else "no thermal line"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="the VM's fusion folder (out/fusion)")
    ap.add_argument("--ref", required=True, help="the host's reference runs (ref/fusion)")
    ap.add_argument("--src", required=True, help="the source tree (examples/fusion)")
    ap.add_argument("--frames", type=int, required=True)
    ap.add_argument("--runs", default="nofault:fusion faults:fusion_faults")
    ap.add_argument("--isa-compare", help="tests/isa's nvs_isa_compare")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    fiducials = os.path.join(a.out, "fiducials.json")
    tool = os.path.join(a.src, "examples", "fusion", "rit_fiducials.py")
    scene = os.path.join(a.src, "scenarios", "rit", "scene_lamp_lit.toml")
    rc, out = run_tool(["/usr/bin/python3", tool, scene, "-o", fiducials],
                       os.path.join(a.out, "fiducials.log"), 120)
    if not hil.check(rc == 0, "fusion: the RIT scene's fiducials (rit_fiducials.py, exit %d)" % rc):
        print(out)
        return 1
    for run in a.runs.split():
        name = run.split(":")[0]
        d = os.path.join(a.out, name)
        if not hil.check(os.path.isdir(d), "fusion %s: the VM's output is there" % name):
            continue
        try:
            check_run(name, d, os.path.join(a.ref, name), a.src, a.frames, a.isa_compare,
                      fiducials)
        except (OSError, KeyError, ValueError, IndexError, subprocess.TimeoutExpired) as e:
            hil.check(False, "fusion %s: the VM's output is incomplete: %s: %s" % (
                name, type(e).__name__, e))
    if hil.failures:
        print("hil: fusion: %d check(s) failed" % len(hil.failures))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
