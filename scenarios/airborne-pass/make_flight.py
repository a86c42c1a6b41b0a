#!/usr/bin/env python3
"""Writes flight.candump: an aircraft passing over the RIT site at 300 m, as the CAN bus of
config/can/nvstim.dbc would carry it (Intel-order signals, as in the DBC).

Flight: heading 10 deg (true), 300 m above the site, 60 m/s, camera boresight pitched 45 deg
down, so the boresight crosses the site at t = 1 s. Position 50 Hz, attitude 100 Hz, time 10 Hz,
from t = 0 (the run starts at the first sample). Rerun to regenerate.
"""
import math
import struct

LAT0, LON0, H0 = 43.16856, -77.61583, 218.0       # the scenario site
UNIX0 = 904708800                                  # 1998-09-02T04:00:00Z (tghg night)
ALT, SPEED, HEADING, PITCH = 300.0, 60.0, 10.0, -45.0
A, E2 = 6378137.0, 6.69437999014e-3                # WGS84
sl = math.sin(math.radians(LAT0))
N = A / math.sqrt(1 - E2 * sl * sl)
M = A * (1 - E2) / (1 - E2 * sl * sl) ** 1.5


def pose(t):
    # Ground distance from the aim point: the boresight at 45 deg down meets the ground ALT ahead.
    s = SPEED * (t - 1.0) - ALT
    hd = math.radians(HEADING)
    east, north = s * math.sin(hd), s * math.cos(hd)
    lat = LAT0 + math.degrees(north / (M + H0))
    lon = LON0 + math.degrees(east / ((N + H0) * math.cos(math.radians(LAT0))))
    return lat, lon, H0 + ALT


def frame(t, can_id, data):
    return "(%d.%06d) can0 %03X#%s\n" % (UNIX0 + int(math.floor(t)), round((t - math.floor(t)) * 1e6) % 1000000,
                                         can_id, data.hex().upper())


lines = []
for k in range(0, 121):                            # 50 Hz position, t = 0 .. 2.4 s
    t = k / 50.0
    lat, lon, alt = pose(t)
    lines.append((t, 0x100, struct.pack("<ii", round(lat * 1e7), round(lon * 1e7))))
    lines.append((t, 0x101, struct.pack("<i", round(alt * 1000))))
for k in range(0, 241):                            # 100 Hz attitude (gentle roll oscillation)
    t = k / 100.0
    roll = 2.0 * math.sin(2 * math.pi * 0.5 * t)
    lines.append((t, 0x110, struct.pack("<hhH", round(roll * 100), round(PITCH * 100), round(HEADING * 100))))
for k in range(0, 25):                             # 10 Hz time
    t = k / 10.0
    u = UNIX0 + t
    lines.append((t, 0x120, struct.pack("<II", int(math.floor(u)), round((u - math.floor(u)) * 1e6))))
lines.sort(key=lambda x: (x[0], x[1]))
with open("flight.candump", "w") as f:
    for t, i, d in lines:
        f.write(frame(t, i, d))
