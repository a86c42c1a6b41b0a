#!/usr/bin/python3
"""ctest: `nvstim ephem` prints exactly the JSON of docs/design.md §7 and agrees with PyEphem; bad input
gives a non-zero exit and one line on stderr; `nvstim illum` carries the four illuminance keys.

    /usr/bin/python3 check_cli.py PATH/TO/nvstim
"""
import json
import math
import subprocess
import sys

import ephem

NVSTIM = sys.argv[1]
failures = []


def run(args):
    p = subprocess.run([NVSTIM] + args, capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def expect(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


# 1. Keys, exactly.
rc, out, err = run(["ephem", "--lat", "43.16856", "--lon", "-77.61583", "--height-m", "218",
                    "--utc", "2024-01-25T17:54:00Z", "--pressure-hpa", "1010",
                    "--temperature-c", "10"])
expect(rc == 0, "ephem exit 0 (got %d: %s)" % (rc, err))
doc = json.loads(out)
expect(sorted(doc) == ["moon", "sun"], "top-level keys")
expect(sorted(doc["sun"]) == ["alt_deg", "alt_geometric_deg", "az_deg"], "sun keys")
expect(sorted(doc["moon"]) == ["alt_deg", "alt_geometric_deg", "az_deg", "distance_km",
                               "illuminated_fraction", "phase_angle_deg"], "moon keys")

# 2. Against PyEphem at the same instant (UT1 = UTC, PyEphem's own ΔT: at 2024 its ΔT is 3 s
#    off the leap-second value, 1.5" of Moon motion — negligible).
o = ephem.Observer()
o.lat, o.lon, o.elevation = "43.16856", "-77.61583", 218
o.date = "2024/1/25 17:54:00"
o.pressure, o.temp = 1010, 10
m, s = ephem.Moon(o), ephem.Sun(o)
expect(abs(doc["moon"]["alt_deg"] - math.degrees(m.alt)) < 0.02, "moon alt vs PyEphem")
expect(abs(doc["sun"]["alt_deg"] - math.degrees(s.alt)) < 0.02, "sun alt vs PyEphem")
d = abs(doc["moon"]["az_deg"] - math.degrees(m.az)) % 360
expect(min(d, 360 - d) * math.cos(m.alt) < 0.02, "moon az vs PyEphem")
expect(abs(doc["moon"]["illuminated_fraction"] - m.moon_phase) < 0.005, "fraction vs PyEphem")

# 3. Bad input: non-zero exit, one line naming the argument.
for args, name in ((["--lat", "95", "--lon", "0", "--utc", "2024-01-01T00:00Z"], "--lat"),
                   (["--lat", "45", "--lon", "0", "--utc", "2024-01-01T25:61Z"], "--utc"),
                   (["--lat", "45", "--lon", "0", "--utc", "3000-01-01T00:00Z"], "--utc"),
                   (["--lat", "45", "--lon", "0", "--utc", "yesterday"], "--utc")):
    rc, out, err = run(["ephem"] + args)
    lines = [l for l in err.splitlines() if l.strip() and not l.startswith("Run with --help")]
    expect(rc != 0, "%s: non-zero exit" % args)
    expect(out == "", "%s: nothing on stdout" % args)
    expect(len(lines) == 1 and name in lines[0], "%s: one line naming %s, got %r" %
           (args, name, err))

# 4. illum keys.
rc, out, err = run(["illum", "--lat", "43.16856", "--lon", "-77.61583", "--utc",
                    "1998-09-06T03:00Z"])
expect(rc == 0, "illum exit 0 (%s)" % err)
doc = json.loads(out)
il = doc["illuminance_lux"]
expect(sorted(il) == ["moon_direct", "moon_sky", "night_sky", "total"], "illum keys")
expect(abs(il["total"] - (il["moon_direct"] + il["moon_sky"] + il["night_sky"])) < 1e-6,
       "total is the sum")
expect(doc["moon"]["alt_deg"] > 5 and il["moon_sky"] > 0.01 * il["moon_direct"] and
       il["moon_sky"] < 0.5 * il["moon_direct"], "moon_sky a few % to tens of % of moon_direct")
expect(abs(il["night_sky"] - 0.0012) < 0.00006, "night sky 0.0012 lx")


# 5. illum with haze, a camera, and bad atmosphere input.
rc, out5, err = run(["illum", "--lat", "43.16856", "--lon", "-77.61583", "--utc",
                     "1998-09-06T03:00Z", "--visibility-km", "5", "--camera", "pulnix-ag5745ef3"])
expect(rc == 0, "illum --camera exit 0 (%s)" % err)
hazy = json.loads(out5)
expect(hazy["illuminance_lux"]["moon_sky"] / hazy["illuminance_lux"]["moon_direct"] >
       il["moon_sky"] / il["moon_direct"], "moon_sky share grows with haze")
pe = hazy.get("photoelectron_irradiance_pe_s_m2", {})
expect(sorted(pe) == ["moon_direct", "moon_sky", "night_sky", "total"] and pe["total"] > 0,
       "photoelectron terms for --camera")
rc, out, err = run(["illum", "--lat", "43", "--lon", "-77", "--utc", "1998-09-06T03:00Z",
                    "--visibility-km", "0"])
expect(rc != 0 and out == "" and len(err.strip().splitlines()) == 1 and "visibility" in err,
       "--visibility-km 0: one line naming it, got %r" % err)

print("%d failure(s)" % len(failures))
sys.exit(1 if failures else 0)
