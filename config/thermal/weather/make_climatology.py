#!/usr/bin/env python3
"""Writes the climatological weather files of the thesis nights (config/thermal/weather/*.csv).

No hourly record of Rochester (KROC) for 1998 was at hand, so each file is a typical fair-weather
day of its date built from normals, stated as such in its header:
  - daily maximum/minimum: NWS Buffalo daily climate reports for Rochester NY (CLIROC), normals
    1971-2000: Sep 8 73/54 F; 1981-2010: Sep 20 70/51 F, so about -0.2 F/day in September, which
    gives Sep 1 about 75.5/56 F (24.2/13.3 C) and Sep 5 about 74/54.5 F (23.3/12.4 C);
    August 20: 78/58 F (25.6/14.4 C) is an estimate, not a normal: the Buffalo August normals
    1991-2020 (79.0/61.7 F, weather.gov/buf/newnormals) with Rochester's cooler nights;
  - diurnal shape: minimum at sunrise (10:30 UTC, 06:30 EDT), maximum at 19:00 UTC (15:00 EDT),
    half-cosines between them (the usual two-part sine/cosine interpolation of daily extremes,
    e.g. Reicosky et al. 1989, Agric. For. Meteorol. 46, 193-209);
  - dew point: constant at the value that puts the relative humidity at about 93 % at the minimum
    and about 50 % at the maximum, the highest/lowest daily humidities those reports give for
    fair September days (93 % / 51 %, CLIROC 2013-09-20);
  - wind: 1.5 m/s at night, 4 m/s by day (the same reports' daily average winds on fair
    September days: 5.4-8.2 mph, 2.4-3.7 m/s);
  - sky: clear (cloud fraction 0.1, base 1500 m): the scenes the thesis planned (§3: cloud-free
    nights). The thesis reports partly cloudy skies at some acquisitions (§3, §9); edit the
    cloud columns for those. The
    overcast-starlight scenario's night gets an overcast variant (cloud fraction 1, base 600 m,
    an assumption) whose diurnal range is cut to 5 K around the same mean and whose dew point
    is 1 K below the minimum (assumptions: a cloud deck damps the daily swing and the air near
    saturation).
Run: python3 make_climatology.py (writes the three files beside it).
"""
import datetime
import math

NIGHTS = [
    # file, first UTC day, days, Tmax C, Tmin C, dew point C, cloud fraction, base m
    ("rochester-1998-08-20.csv", (1998, 8, 18), 2.25, 25.6, 14.4, 13.4, 0.1, 1500),
    ("rochester-1998-08-20-overcast.csv", (1998, 8, 18), 2.25, 22.5, 17.5, 16.5, 1.0, 600),
    ("rochester-1998-09-02.csv", (1998, 8, 31), 2.25, 24.2, 13.3, 12.2, 0.1, 1500),
    ("rochester-1998-09-06.csv", (1998, 9, 4), 2.25, 23.3, 12.4, 11.4, 0.1, 1500),
]
T_MIN_H, T_MAX_H = 10.5, 19.0


def air(h, tmax, tmin):
    h = h % 24.0
    if T_MIN_H <= h <= T_MAX_H:
        f = (h - T_MIN_H) / (T_MAX_H - T_MIN_H)
    else:
        span = 24.0 - (T_MAX_H - T_MIN_H)
        f = 1.0 - ((h - T_MAX_H) % 24.0) / span
    return tmin + (tmax - tmin) * 0.5 * (1.0 - math.cos(math.pi * f))


def main():
    for name, (y, m, d), days, tmax, tmin, dew, cloud, base in NIGHTS:
        rows = []
        for k in range(int(days * 24) + 1):
            when = datetime.datetime(y, m, d) + datetime.timedelta(hours=k)
            h = when.hour
            t = air(h, tmax, tmin)
            wind = 4.0 if 13 <= h <= 22 else 1.5
            rows.append(f"{when:%Y-%m-%dT%H}:00Z,{t:.1f},{dew:.1f},{wind:.1f},{cloud},{base}")
        with open(name, "w") as f:
            f.write("# source: climatology, not a record: a typical day of the date (fair weather; the -overcast file a cloud deck) at "
                    "Rochester NY (KROC) built from NWS Buffalo climate normals (CLIROC daily reports, "
                    "1971-2000/1981-2010 normals) by config/thermal/weather/make_climatology.py, which "
                    "states every assumption\n")
            sky = "clear sky" if cloud < 0.5 else "overcast (assumed)"
            f.write(f"# values used: max {tmax} C, min {tmin} C, dew point {dew} C; wind 1.5 m/s night, "
                    f"4 m/s day; {sky} (cloud fraction {cloud}, base {base} m)\n")
            f.write("utc,air_temperature_C,dew_point_C,wind_speed_m_s,cloud_fraction,cloud_base_m\n")
            f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
