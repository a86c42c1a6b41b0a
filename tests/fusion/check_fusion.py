#!/usr/bin/python3
"""The reference fusion consumer (examples/fusion/nvstim_fusion_reference.py) against nvstim's
rig scenarios: nvstim runs the scenario on the simulated clock into a temporary folder, the
consumer reads both channels (A = lwir warped into B = ii), and its summary is checked against
what the scenario injected.

  reference_consumer         scenarios/rit-fusion: every lwir frame matched to an ii frame within
                             half a period; skew recovered from the stamps |skew| < 0.1 ms;
                             the fiducials seen in both channels within 1 px after warping.
  reference_consumer_faults  scenarios/rit-fusion-faults: the skew recovered from the stamps
                             within 0.1 ms of the injected one; the dropped frames seen as gaps
                             equal to the metadata's dropped_before; each fiducial's offset after
                             warping within 1 px of the shift the misregistration predicts.

The expectations are computed here from the published geometry and the injected faults, not by
the consumer: the misregistration as a rotation of the thermal camera about its centre, whose
pixels move by K R K^-1 (Hartley & Zisserman, Multiple View Geometry, 2nd ed., 2004, §8.4,
rotation about the camera centre), then carried into ii by the published ground homography.

Usage: check_fusion.py NVSTIM SOURCE_DIR CASE [--keep DIR]
Exit: 0 pass, 1 fail (what failed, one line each), 77 skipped (numpy or OpenCV missing).
"""
import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile

# The consumer needs numpy and OpenCV: without them the test is skipped, not failed.
_missing = [m for m in ("numpy", "cv2") if importlib.util.find_spec(m) is None]
if _missing:
    print(f"SKIP: no module {', '.join(_missing)} (Debian: python3-numpy, python3-opencv)")
    sys.exit(77)
import numpy as np  # noqa: E402 (after the check above)

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fusion_geometry import predicted_offset_px, records  # noqa: E402

CASES = {
    "reference_consumer": "rit-fusion",
    "reference_consumer_faults": "rit-fusion-faults",
}
A, B = "lwir", "ii"           # A is warped into B
RATE_HZ = {"lwir": "30", "ii": "30000/1001"}
SKEW_TOLERANCE_S = 1e-4
OFFSET_TOLERANCE_PX = 1.0


def run(cmd, cwd, timeout_s):
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=timeout_s)
    return p.returncode, p.stdout


def check(case, nvstim, src, work):
    failures = []
    scenario = os.path.join(src, "scenarios", CASES[case])
    consumer = os.path.join(src, "examples", "fusion", "nvstim_fusion_reference.py")
    fiducials_tool = os.path.join(src, "examples", "fusion", "rit_fiducials.py")

    outputs = []
    for ch in (B, A):
        outputs += ["--output", f"y4m:{ch}.y4m?channel={ch}", "--output",
                    f"meta:{ch}.jsonl?channel={ch}"]
    rc, out = run([nvstim, "run", scenario, "--clock", "sim"] + outputs, work, 120)
    if rc != 0:
        return [f"nvstim run {CASES[case]} exited {rc}:\n{out}"]

    rc, out = run([sys.executable, fiducials_tool, "-o", "fiducials.json"], work, 60)
    if rc != 0:
        return [f"rit_fiducials.py exited {rc}:\n{out}"]
    print(out.rstrip())

    cmd = [sys.executable, consumer, "--a", f"{A}.y4m", f"{A}.jsonl", "--b", f"{B}.y4m",
           f"{B}.jsonl", "--rate-a", RATE_HZ[A], "--rate-b", RATE_HZ[B], "--fiducials",
           "fiducials.json", "--json", "summary.json", "--fused-dir", "fused", "--fused-max", "2"]
    rc, out = run(cmd, work, 120)
    print(out.rstrip())
    if rc != 0:
        return [f"the consumer exited {rc}"]
    with open(os.path.join(work, "summary.json"), encoding="utf-8") as f:
        s = json.load(f)
    ra, rb = records(os.path.join(work, f"{A}.jsonl")), records(os.path.join(work, f"{B}.jsonl"))

    # Pairing: every lwir frame has an ii frame within half the longer period.
    half_period_s = 0.5 * max(1.0 / 30.0, 1001.0 / 30000.0)
    p = s["pairs"]
    if p["total"] != len(ra) or p["matched"] != len(ra):
        failures.append(f"pairs: {p['matched']} of {p['total']} {A} frames matched, "
                        f"{len(ra)} {A} frames emitted")
    if not p["max_abs_dt_s"] <= half_period_s:
        failures.append(f"pairs: max |dt| {p['max_abs_dt_s'] * 1e3:.3f} ms > half a period "
                        f"{half_period_s * 1e3:.3f} ms")

    # Skew from the stamps; the consumer's skew is B's offset less A's, so lwir vs ii = -skew_s.
    skew_lwir_vs_ii_s = -s["skew_s"]
    injected_s = ra[0]["faults"]["skew_s"] - rb[0]["faults"]["skew_s"]
    if case == "reference_consumer_faults" and not injected_s > 0:
        failures.append(f"the scenario injected no skew ({injected_s} s): nothing to recover")
    err_s = skew_lwir_vs_ii_s - injected_s
    print(f"check: skew of {A} vs {B} from the stamps {skew_lwir_vs_ii_s * 1e3:+.4f} ms, "
          f"injected {injected_s * 1e3:+.4f} ms, error {err_s * 1e3:+.4f} ms "
          f"(tolerance {SKEW_TOLERANCE_S * 1e3:.1f} ms)")
    if not abs(err_s) < SKEW_TOLERANCE_S:
        failures.append(f"skew: {skew_lwir_vs_ii_s * 1e3:+.4f} ms recovered, "
                        f"{injected_s * 1e3:+.4f} ms injected")

    # Drops: the gaps in the sequence (and any before the first frame: sequences start at 0)
    # are the frames the fault dropped.
    truth_dropped = sum(r["faults"]["dropped_before"] for r in ra)
    d = s["drops"][A]
    seen = d["missing"] + d["first_frame"]
    print(f"check: {A} frames dropped: {seen} seen as gaps, {truth_dropped} in the metadata")
    if seen != truth_dropped:
        failures.append(f"drops: {seen} gaps in {A}'s sequence, the metadata says {truth_dropped}")
    if case == "reference_consumer_faults" and truth_dropped == 0:
        failures.append("drops: the scenario dropped no frame: nothing to see")
    if s["drops"][B]["missing"] != 0:
        failures.append(f"drops: {B} has {s['drops'][B]['missing']} gaps and no fault")

    # Fiducials: B's centroid less A's mapped through H, against what the geometry predicts:
    # the projection into ii less the true thermal camera's pixel mapped by H (with no
    # misregistration, the parallax of the fiducial's height alone, about 0.1 px).
    f = s.get("fiducials") or {}
    measured = [r for r in f.get("list", []) if r["status"] == "measured"]
    if not measured:
        failures.append("fiducials: none measured in both channels")
    for r in measured:
        expected = predicted_offset_px(ra[0], rb[0], r["xyz_m"])
        got = np.array(r["offset_px"])
        miss = float(np.hypot(*(got - expected)))
        print(f"check: fiducial {r['name']}: offset ({got[0]:+.2f}, {got[1]:+.2f}) px, expected "
              f"({expected[0]:+.2f}, {expected[1]:+.2f}) px, apart {miss:.2f} px")
        if not miss <= OFFSET_TOLERANCE_PX:
            failures.append(f"fiducial {r['name']}: offset ({got[0]:+.2f}, {got[1]:+.2f}) px, "
                            f"expected ({expected[0]:+.2f}, {expected[1]:+.2f}) px: {miss:.2f} px "
                            f"apart (tolerance {OFFSET_TOLERANCE_PX} px)")
        if case == "reference_consumer" and not r["offset_abs_px"] <= OFFSET_TOLERANCE_PX:
            failures.append(f"fiducial {r['name']}: |offset| {r['offset_abs_px']:.2f} px after "
                            f"warping, more than {OFFSET_TOLERANCE_PX} px")
    if not os.path.isfile(os.path.join(work, "fused", "overlay_mean.png")):
        failures.append("no overlay written")
    return failures


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("nvstim")
    ap.add_argument("source_dir")
    ap.add_argument("case", choices=sorted(CASES))
    ap.add_argument("--keep", metavar="DIR", help="work in DIR and keep what was written")
    args = ap.parse_args()
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
        failures = check(args.case, os.path.abspath(args.nvstim), os.path.abspath(args.source_dir),
                         args.keep)
    else:
        with tempfile.TemporaryDirectory(prefix="nvs_fusion_") as work:
            failures = check(args.case, os.path.abspath(args.nvstim),
                             os.path.abspath(args.source_dir), work)
    for line in failures:
        print(f"FAIL: {line}")
    print(f"fusion.{args.case}: {'FAILED' if failures else 'passed'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
