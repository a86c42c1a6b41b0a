#!/usr/bin/env python3
"""Self-test of the HIL test's GPIO checks (tests/hil/check_gpio.py), without the VM: the gate
judge on sampled lines made here from a pulse train with known faults (a late rise, a late first
pulse, a missing pulse, a drop-out, a late fall, a pulse outside every window, a pulse for a
frame that was not emitted), and the rule that every tick is a frame emitted or a miss nvstim
reports. Each fault must fail the check that is meant to catch it, and the clean train must
pass (ctest hil.check_gpio_selftest). Exit 0 when every case behaves, 1 otherwise."""
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


def judged(samples, wins):
    """The judge's verdict on samples read against the windows `wins` of the metadata."""
    results = []
    check_gpio.judge_samples("t", samples, wins, lambda ok, what: results.append(ok) or ok)
    return all(results)


def main():
    failures = []

    def expect(ok, what):
        print("check_gpio selftest: %s %s" % ("ok  " if ok else "FAIL", what))
        if not ok:
            failures.append(what)

    # 10-Hz windows of 40 ms (frame scan) and 20-Hz windows of 25 ms (interlaced fields).
    frame = [(1_000 * MS + k * 100 * MS, 1_040 * MS + k * 100 * MS) for k in range(60)]
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
        expect(not judged(late, wins), "%s: a pulse 12 ms late fails" % name)
        w0 = wins[0]
        expect(not judged(train(wins, faults=[(w0[0], w0[0] + 6 * MS, False)]), wins),
               "%s: the first pulse 6 ms late (the start-up) fails" % name)
        expect(not judged(train(wins, faults=[(w0[0], w0[1] + 0.5 * MS, False)]), wins),
               "%s: the first pulse missing fails" % name)
        expect(not judged(train(wins, faults=[(a, b + 0.5 * MS, False)]), wins),
               "%s: a missing pulse mid-run fails" % name)
        # A frame that was not emitted (its window absent from the metadata) whose exposure was
        # pulsed anyway: high outside every window of the metadata.
        expect(not judged(train(wins), wins[:7] + wins[8:]),
               "%s: a pulse for a frame missing from the metadata fails" % name)
        expect(judged(train(wins[:7] + wins[8:]), wins[:7] + wins[8:]),
               "%s: a frame missed and reported, with no pulse, passes" % name)
        # The sampler held up (the VM's CPU taken by the host): a window with no sample inside
        # cannot be judged; one passes, every window of a run does not.
        held = [x for x in train(wins) if not (a - 10 * MS <= x[0] <= b + 10 * MS)]
        expect(judged(held, wins), "%s: one window inside a 60-ms sampler gap passes" % name)
        sparse = [x for x in train(wins) if not any(p - MS <= x[0] <= q + MS for p, q in wins)]
        expect(not judged(sparse, wins), "%s: no window sampled fails" % name)
        # The VM held up 20 ms across a window's end: the first reading after it may still
        # see the pulse (the pulse thread not yet back); it is not judged, the next one is.
        t0 = b - 8 * MS
        stall = [x for x in train(wins, faults=[(b, b + 12.3 * MS, True)])
                 if not (t0 <= x[0] < b + 12 * MS)]
        expect(judged(stall, wins), "%s: a stale reading right after a 20-ms stall is not judged"
               % name)
        stall2 = [x for x in train(wins, faults=[(b, b + 12.8 * MS, True)])
                  if not (t0 <= x[0] < b + 12 * MS)]
        expect(not judged(stall2, wins), "%s: a second high reading after the stall fails" % name)
        d = check_gpio.edge_delay(train(wins, rise_ns=2 * MS), wins[5][0], "1")
        expect(d is not None and d[0] <= 2 * MS <= d[1] and d[1] - d[0] <= MS,
               "%s: a 2-ms rise delay is bracketed within a sampling period: %s" % (name, d))

    # Every tick a frame emitted or a reported miss.
    st = {"frames_emitted": 58, "deadline_misses": 2}
    metas = [{"frame": k, "tick": k, "repeat": False} for k in range(60) if k not in (0, 31)]
    _, missed, wrong = check_gpio.ticks_accounted(metas, 60, st)
    expect(not wrong and missed == [0, 31],
           "ticks 0, 31 missed and reported: %s %s" % (missed, wrong))
    _, _, wrong = check_gpio.ticks_accounted(metas, 60,
                                             {"frames_emitted": 58, "deadline_misses": 1})
    expect(wrong != "", "two ticks without a frame, one miss reported, fails: %s" % wrong)
    rep = metas[:30] + [{"frame": 30, "tick": 31, "repeat": True}] + metas[30:]
    _, missed, wrong = check_gpio.ticks_accounted(rep, 60, st)
    expect(not wrong and missed == [0, 31],
           "a repeat on a missed tick is no fresh frame: %s" % wrong)
    bad = [dict(m) for m in metas]
    bad[5]["tick"] = bad[5]["frame"] + 1
    _, _, wrong = check_gpio.ticks_accounted(bad, 60, st)
    expect(wrong != "", "a fresh frame on another tick fails: %s" % wrong)

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
