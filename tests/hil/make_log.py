#!/usr/bin/env python3
"""Writes the HIL test's telemetry: a candump log (as candump -l writes and canplayer reads) of
the CAN bus of config/can/nvstim.dbc, and the pose it carries, for tests/hil/check.py.

  make_log.py LOG [PREFIX_S]     LOG, and LOG.pre / LOG.rest split after PREFIX_S seconds

At 100 Hz, each group is a time mark first (NVS_TIME, 0x120: UnixTime_s, SubSecond_s), then the
attitude valid at that time (NVS_ATTITUDE, 0x110: Roll_deg, Pitch_deg, Yaw_deg, Intel order):
the order the sim clock's lockstep reads time from (rt/telemetry/sources.h). The log's own
timestamps are the marks' times, so `--telemetry replay:LOG` gives the same sample times.

Yaw is a triangle, 0 → 225° at 150°/s, then back to 0 at 3 s (the test pattern's pose strip
grows, then shrinks: content that follows the pose, not the clock); roll 1°, pitch −2°.
"""
import math
import struct
import sys

UNIX0 = 946692000          # 2000-01-01T02:00:00Z, the HIL scenarios' utc_start
RATE_HZ = 100
DURATION_S = 3.3           # 90 frames at 30 Hz need time marks past 89/30 s
YAW_RATE_DEG_S = 150.0
APEX_S = 1.5


def yaw_deg(t):
    """The commanded yaw [deg] at t [s] (also used by check.py)."""
    return YAW_RATE_DEG_S * (t if t <= APEX_S else max(0.0, 2 * APEX_S - t))


def lines():
    out = []
    for k in range(int(round(DURATION_S * RATE_HZ)) + 1):
        us = k * 1000000 // RATE_HZ
        sec, usec = UNIX0 + us // 1000000, us % 1000000
        t = us * 1e-6
        stamp = "(%d.%06d) can0 " % (sec, usec)
        # NVS_TIME: UnixTime_s 0|32 (1 s), SubSecond_s 32|20 (1 µs).
        out.append((t, stamp + "120#" + struct.pack("<II", sec, usec).hex().upper()))
        # NVS_ATTITUDE: Roll_deg 0|16 signed, Pitch_deg 16|16 signed, Yaw_deg 32|16 unsigned, 0.01°.
        att = struct.pack("<hhH", 100, -200, int(round(yaw_deg(t) * 100)))
        out.append((t, stamp + "110#" + att.hex().upper()))
    return out


def main():
    path = sys.argv[1]
    prefix_s = float(sys.argv[2]) if len(sys.argv) > 2 else None
    ls = lines()
    with open(path, "w") as f:
        f.writelines(l + "\n" for _, l in ls)
    if prefix_s is not None:
        with open(path + ".pre", "w") as f:
            f.writelines(l + "\n" for t, l in ls if t <= prefix_s + 1e-9)
        with open(path + ".rest", "w") as f:
            f.writelines(l + "\n" for t, l in ls if t > prefix_s + 1e-9)


if __name__ == "__main__":
    main()
