#!/usr/bin/env python3
"""Self-test of the HIL test's GPIO checks (tests/hil/check_gpio.py), without the VM: the gate
judge on sampled lines made here from a pulse train with known faults (a late rise, a drop-out,
a late fall, a pulse outside every window), and the start-up rule on frame indices. Each fault
must fail the check that is meant to catch it, and the clean train must pass (ctest
hil.check_gpio_selftest). Exit 0 when every case behaves, 1 otherwise."""
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_gpio  # noqa: E402

MS = 1_000_000


def train(wins, rise_ns=0.5 * MS, fall_ns=0.5 * MS, period_ns=0.5 * MS, read_ns=0.05 * MS,
          faults=()):
    """Samples of a line that rises rise_ns after each window's start and falls fall_ns after
    its end; `faults`: (t0, t1, level) spans forced to a level."""
    t_end = wins[-1][1] + 30 * MS
    out, t = [], wins[0][0] - 30 * MS
    while t < t_end:
        mid = t + read_ns / 2
        v = any(a + rise_ns <= mid < b + fall_ns for a, b in wins)
        for f0, f1, lvl in faults:
            if f0 <= mid < f1:
                v = lvl
        out.append((int(t), int(t + read_ns), "1" if v else "0"))
        t += period_ns
    return out


def judged(samples, wins, late_reported=0):
    results = []
    check_gpio.judge_samples("t", samples, wins, late_reported,
                             lambda ok, what: results.append(ok) or ok)
    return all(results)


def main():
    failures = []

    def expect(ok, what):
        print("check_gpio selftest: %s %s" % ("ok  " if ok else "FAIL", what))
        if not ok:
            failures.append(what)

    # 10-Hz windows of 40 ms (frame scan) and 20-Hz windows of 25 ms (interlaced fields).
    frame = [(1_000 * MS + k * 100 * MS, 1_040 * MS + k * 100 * MS) for k in range(30)]
    fields = [(1_000 * MS + k * 50 * MS, 1_025 * MS + k * 50 * MS) for k in range(60)]
    for name, wins in (("frame", frame), ("interlaced", fields)):
        expect(judged(train(wins), wins), "%s: a pulse per window, 0.5 ms late, passes" % name)
        expect(judged(train(wins, rise_ns=4 * MS, fall_ns=4 * MS), wins),
               "%s: edges 4 ms late (inside the 5-ms guard) pass" % name)
        a, b = wins[7]
        expect(not judged(train(wins, faults=[(a + 10 * MS, a + 12 * MS, False)]), wins),
               "%s: a 2-ms drop-out inside a window fails" % name)
        expect(not judged(train(wins, fall_ns=8 * MS), wins),
               "%s: every fall 8 ms late fails (high outside the windows)" % name)
        gap = (wins[3][1] + wins[4][0]) // 2
        expect(not judged(train(wins, faults=[(gap - MS, gap + MS, True)]), wins),
               "%s: a pulse between two windows fails" % name)
        late = train(wins, faults=[(a, a + 12 * MS, False)])
        expect(not judged(late, wins, late_reported=0),
               "%s: a pulse 12 ms late fails where nvstim counted none late" % name)
        expect(judged(late, wins, late_reported=1),
               "%s: the same passes where nvstim counted it late" % name)
        b1, b2 = wins[9], wins[12]
        two = train(wins, faults=[(b1[0], b1[0] + 12 * MS, False), (b2[0], b2[0] + 12 * MS, False)])
        expect(not judged(two, wins, late_reported=1),
               "%s: two late pulses fail where nvstim counted one" % name)
        d = check_gpio.edge_delay(train(wins, rise_ns=2 * MS), wins[5][0], "1")
        expect(d is not None and d[0] <= 2 * MS <= d[1] and d[1] - d[0] <= MS,
               "%s: a 2-ms rise delay is bracketed within a sampling period: %s" % (name, d))

    # The steady state: the longest run of consecutive frames, less its first ten.
    metas = [{"frame": k, "repeat": False} for k in list(range(0, 5)) + list(range(9, 60))]
    s = check_gpio.steady(metas)
    expect(s[0]["frame"] == 19 and s[-1]["frame"] == 59,
           "steady state of frames 0-4, 9-59: 19..59 (got %d..%d)" % (s[0]["frame"], s[-1]["frame"]))
    metas[30]["repeat"] = True
    s = check_gpio.steady(metas)
    expect(s[0]["frame"] == 44 and s[-1]["frame"] == 59,
           "a repeated frame 35 splits the run: 44..59 (got %d..%d)" % (s[0]["frame"], s[-1]["frame"]))

    # Exposure windows from metadata: progressive, interlaced, gated.
    origin = 5_000 * MS
    w = check_gpio.windows([{"repeat": False, "t_sample_s": 0.1, "exposure_s": 0.04, "gate_s": 0}],
                           origin)
    expect(w == [(origin + 80 * MS, origin + 120 * MS)], "progressive window: %s" % w)
    w = check_gpio.windows([{"repeat": False, "t_sample_s": 0.1, "exposure_s": 0.02, "gate_s": 0.005,
                             "fields": [{"t_sample_s": 0.05, "gate_s": 0.008},
                                        {"t_sample_s": 0.1, "gate_s": 0.005}]}], origin)
    expect(w == [(origin + 40 * MS, origin + 48 * MS), (origin + 90 * MS, origin + 95 * MS)],
           "interlaced, each field's own gate (8 ms, 5 ms) within 20-ms exposures: %s" % w)
    print("check_gpio selftest: %d failed" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
