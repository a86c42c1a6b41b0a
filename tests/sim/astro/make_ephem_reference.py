#!/usr/bin/python3
"""Reference Sun/Moon positions from PyEphem (libastro, E. Downey), an ephemeris nvstim does not
use, for tests/sim/astro/ephemeris_test.cpp.

    /usr/bin/python3 make_ephem_reference.py OUT.csv          write the table
    /usr/bin/python3 make_ephem_reference.py --check IN.csv   recompute and compare (ctest)

Instants: 400 UT instants spread over 1950-2100 by a fixed pseudo-random sequence, at six sites.
For each: PyEphem's Delta T (TT - UT), geometric (pressure 0) and refracted (1010 hPa, 10 C)
topocentric altitude, azimuth, Moon distance, phase fraction and elongation.
"""
import csv
import math
import random
import sys

import ephem

SITES = [  # name, lat, lon (east +), height m
    ("rochester", 43.16856, -77.61583, 218.0),
    ("equator", 0.0, 0.0, 0.0),
    ("tromso", 69.6496, 18.9560, 100.0),
    ("sydney", -33.8688, 151.2093, 50.0),
    ("la_paz", -16.5, -68.15, 3640.0),
    ("tokyo", 35.6762, 139.6503, 40.0),
]
COLUMNS = ["site", "lat_deg", "lon_deg", "height_m", "ut_jd", "delta_t_s",
           "sun_az_deg", "sun_alt_geometric_deg", "sun_alt_refracted_deg",
           "moon_az_deg", "moon_alt_geometric_deg", "moon_alt_refracted_deg",
           "moon_distance_km", "moon_phase_fraction", "moon_elongation_deg"]
DUBLIN_JD = 2415020.0  # ephem.Date 0 = 1899-12-31 12:00 UT


def rows():
    rng = random.Random(20240125)
    start = ephem.Date("1950/1/1 00:00:00")
    stop = ephem.Date("2100/12/31 00:00:00")
    for k in range(400):
        name, lat, lon, h = SITES[k % len(SITES)]
        d = ephem.Date(start + rng.random() * (stop - start))
        o = ephem.Observer()
        o.lat, o.lon, o.elevation, o.date = str(lat), str(lon), h, d
        out = {"site": name, "lat_deg": lat, "lon_deg": lon, "height_m": h,
               "ut_jd": "%.8f" % (float(d) + DUBLIN_JD),
               "delta_t_s": "%.4f" % ephem.delta_t(d)}
        for pressure, suffix in ((0.0, "geometric"), (1010.0, "refracted")):
            o.pressure, o.temp = pressure, 10.0
            s, m = ephem.Sun(o), ephem.Moon(o)
            out["sun_alt_%s_deg" % suffix] = "%.6f" % math.degrees(s.alt)
            out["moon_alt_%s_deg" % suffix] = "%.6f" % math.degrees(m.alt)
            if pressure == 0.0:
                out["sun_az_deg"] = "%.6f" % math.degrees(s.az)
                out["moon_az_deg"] = "%.6f" % math.degrees(m.az)
                out["moon_distance_km"] = "%.3f" % (m.earth_distance * ephem.meters_per_au / 1e3)
                out["moon_phase_fraction"] = "%.6f" % m.moon_phase
                out["moon_elongation_deg"] = "%.6f" % abs(math.degrees(m.elong))
        yield out


def write(path):
    with open(path, "w", newline="") as f:
        f.write("# Sun and Moon topocentric positions from PyEphem %s (libastro), the independent\n"
                % ephem.__version__)
        f.write("# reference for tests/sim/astro/ephemeris_test.cpp.\n")
        f.write("# source: tests/sim/astro/make_ephem_reference.py (Debian python3-ephem)\n")
        w = csv.DictWriter(f, COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in rows():
            w.writerow(r)


def check(path):
    with open(path) as f:
        stored = list(csv.DictReader(line for line in f if not line.startswith("#")))
    fresh = list(rows())
    if len(stored) != len(fresh):
        print("row count differs: %d stored, %d computed" % (len(stored), len(fresh)))
        return 1
    worst = 0.0
    for a, b in zip(stored, fresh):
        for c in COLUMNS[6:12]:
            d = abs(float(a[c]) - float(b[c]))
            d = min(d, 360.0 - d)
            worst = max(worst, d)
    print("max |stored - recomputed| = %.2e deg" % worst)
    return 0 if worst < 1e-4 else 1


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--check":
        sys.exit(check(sys.argv[2]))
    if len(sys.argv) == 2:
        write(sys.argv[1])
        sys.exit(0)
    print(__doc__)
    sys.exit(2)
