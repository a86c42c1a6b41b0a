#!/usr/bin/env python3
"""Measured datasets for `nvstim diagnose` built from the thesis's tables (docs/validation.md,
"diagnose"). Reads only tests/data/thesis/*.csv (provenance in its README); writes one dataset
folder per table into OUT (docs/contracts.md, "Measured dataset").

The thesis publishes statistics of its frames (means, standard deviations, modulations), not
the frames. Each dataset's frames are therefore a realisation of those statistics, made here
with a fixed seed, and each says which statistic it realises and what it assumes:

  t18-5_calibration   Table 18-5: 20 uniform frames at 5.5 V, f/11, through ND filters. Each
                      row's mean and standard deviation as white Gaussian noise (the standard
                      deviation taken as temporal), 3 frames per row (frame scan, so a stimulus
                      held for 3 frames gives temporal pairs). Stimulus: the row's reduced
                      radiance (480-940 nm band), tungsten sphere taken as a 2856 K blackbody.
  s4-5_averaging      Section 4.5: two frames of mean 129.8 DC and standard deviation 15.7 and
                      15.45 DC whose average has 12.20 DC, not 11.01: split into a fixed pattern
                      and temporal noise (sigma_f^2 = var_avg - var_t/2, var_t = 2(var_1 - var_avg)),
                      8 frames with that split, per pixel, white. The stimulus is not given:
                      uniform, at the radiance the thesis's gain/bias model (Table 18-6, 6 V,
                      40e6 DC per W m-2 sr-1 at f/5.6, bias 36.4 DC) maps to 129.8 DC.
  t18-6_gain_6p0V,    Table 18-6: the image gain (DC per W m-2 sr-1 at f/11) and bias at each
  t18-6_gain_6p5V     measured tube gain setting other than 5.5 V (Table 18-5's own; 5.0 V is
                      marked estimated in the source and left out): uniform frames at Table
                      18-5's radiance ladder, mean bias + gain x L, the levels under 240 DC, 3
                      frames each (frame scan). Noise: Table 18-5's variance against signal
                      above Table 18-6's 5.5 V bias (a least-squares line through its rows:
                      4.14 DC^2 + 0.733 DC per DC) with the part that grows with signal scaled
                      by the gain over 5.5 V's, white.
  t18-2_mtf           Table 18-2: bar targets at eight image frequencies; the output modulation
                      as a sinusoid of the row's image frequency (cycles/mm at the photocathode,
                      the thesis's contrast transfer taken as the MTF), mean 100 DC, 2 DC of
                      white noise; stimulus a sinusoid with the row's input modulation.
  t9-3_truth_panels   Tables 9-3..9-7: the four truth panels (white, light gray, asphalt, grass)
                      as regions with the truth images' mean and standard deviation; stimulus
                      the radiance the SIG predicted for each panel, recovered from Table 9-3's
                      stage 1 (sig = 40e6 L + 36), spectrum moon; the panels are [[roi]]s.

Usage: make_thesis_datasets.py THESIS_CSV_DIR OUT_DIR
"""
import csv
import math
import os
import random
import struct
import sys


def write_pfm(path, w, h, value_of):
    rows = []
    for y in reversed(range(h)):  # PFM stores the bottom row first
        rows.append(struct.pack("<%df" % w, *[value_of(x, y) for x in range(w)]))
    with open(path, "wb") as f:
        f.write(b"Pf\n%d %d\n-1.0\n" % (w, h))
        f.write(b"".join(rows))


def write_pgm(path, w, h, values):
    with open(path, "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (w, h))
        f.write(bytes(max(0, min(255, int(round(v)))) for v in values))


def write_toml(d, preset, settings, unit, spectrum, index, count, rois=(), comment="",
               band="480-940"):
    with open(os.path.join(d, "dataset.toml"), "w") as f:
        f.write("# " + comment.replace("\n", "\n# ") + "\n")
        f.write('[camera]\npreset = "%s"\n[camera.settings]\n' % preset)
        for k, v in settings:
            f.write('"%s" = %s\n' % (k, v))
        f.write('\n[stimulus]\nradiance = "radiance/{frame:06d}.pfm"\nunit = "%s"\n' % unit)
        f.write('spectrum = "%s"\n' % spectrum)
        if band:
            f.write('band = "%s"\n' % band)
        f.write('index = [%s]\n' % ", ".join(str(i) for i in index))
        f.write('\n[output]\nframes = "frames/{frame:06d}.pgm"\nfirst_frame = 0\ncount = %d\n' % count)
        for r in rois:
            f.write('\n[[roi]]\nname = "%s"\nx = %d\ny = %d\nw = %d\nh = %d\n' % r)


def folders(out, name):
    d = os.path.join(out, name)
    os.makedirs(os.path.join(d, "radiance"), exist_ok=True)
    os.makedirs(os.path.join(d, "frames"), exist_ok=True)
    return d


def rows(thesis, name):
    with open(os.path.join(thesis, name)) as f:
        return list(csv.DictReader(f))


W, H = 96, 64


def calibration(thesis, out, rng):
    d = folders(out, "t18-5_calibration")
    index, k = [], 0
    for i, r in enumerate(rows(thesis, "table18-5_radiometric_calibration_gain5p5V.csv")):
        L = float(r["reduced_radiance_W_m-2_sr-1"])
        write_pfm(os.path.join(d, "radiance", "%06d.pfm" % i), W, H, lambda x, y: L)
        for _ in range(3):
            m, s = float(r["mean_DC"]), float(r["stddev_DC"])
            write_pgm(os.path.join(d, "frames", "%06d.pgm" % k), W, H,
                      [rng.gauss(m, s) for _ in range(W * H)])
            index.append(i)
            k += 1
    write_toml(d, "pulnix-ag5745ef3",
               [("width", W), ("height", H), ("gain_V", 5.5), ("f_number", 11.0),
                ('video.scan', '"frame"')],
               "W/m2/sr", "blackbody:2856", index, k,
               comment="Thesis Table 18-5 (make_thesis_datasets.py): rows' mean/stddev as frames")


def averaging(thesis, out, rng):
    d = folders(out, "s4-5_averaging")
    st = {r["image"]: r for r in rows(thesis, "sec4-5_noise_averaging_stats.csv")}
    mean = float(st["mean_of_a_b_stats"]["mean_DC"])
    var1 = float(st["mean_of_a_b_stats"]["stddev_DC"]) ** 2
    var_avg = float(st["two_frame_average_image"]["stddev_DC"]) ** 2
    var_t = 2.0 * (var1 - var_avg)
    var_f = var_avg - var_t / 2.0
    L = (mean - 36.374) / 40e6
    write_pfm(os.path.join(d, "radiance", "000000.pfm"), W, H, lambda x, y: L)
    pattern = [rng.gauss(0.0, math.sqrt(var_f)) for _ in range(W * H)]
    n = 8
    for k in range(n):
        write_pgm(os.path.join(d, "frames", "%06d.pgm" % k), W, H,
                  [mean + p + rng.gauss(0.0, math.sqrt(var_t)) for p in pattern])
    write_toml(d, "pulnix-ag5745ef3",
               [("width", W), ("height", H), ("gain_V", 6.0), ('video.scan', '"frame"')],
               "W/m2/sr", "moon", [0] * n, n,
               comment="Thesis sec. 4.5 (make_thesis_datasets.py): fixed pattern %.2f DC, "
                       "temporal %.2f DC" % (math.sqrt(var_f), math.sqrt(var_t)))


def mtf(thesis, out, rng):
    d = folders(out, "t18-2_mtf")
    pitch_mm = 11e-3 * 1.636  # a pixel at the photocathode (preset pitch x taper)
    index, k = [], 0
    L0 = (100.0 - 36.374) / 40e6
    for i, r in enumerate(rows(thesis, "table18-2_electronic_mtf.csv")):
        f = float(r["image_frequency_cyc_per_mm"]) * pitch_mm  # cycles per pixel
        m_in, m_out = float(r["modulation_in_rel"]), float(r["modulation_out_rel"])
        write_pfm(os.path.join(d, "radiance", "%06d.pfm" % i), W, H,
                  lambda x, y: L0 * (1.0 + m_in * math.cos(2 * math.pi * f * x)))
        for _ in range(4):
            write_pgm(os.path.join(d, "frames", "%06d.pgm" % k), W, H,
                      [36.374 + 63.626 * (1.0 + m_out * math.cos(2 * math.pi * f * (p % W)))
                       + rng.gauss(0.0, 2.0) for p in range(W * H)])
            index.append(i)
            k += 1
    write_toml(d, "pulnix-ag5745ef3",
               [("width", W), ("height", H), ("gain_V", 6.0), ('video.scan', '"frame"'),
                ("optics.cos4", "false")],
               "W/m2/sr", "blackbody:2856", index, k,
               comment="Thesis Table 18-2 (make_thesis_datasets.py): bar targets as sinusoids")


def truth_panels(thesis, out, rng):
    d = folders(out, "t9-3_truth_panels")
    t = [r for r in rows(thesis, "table9-3_to_9-7_roi_truth_vs_sig.csv")
         if r["table"] == "9-3" and r["region"] != "TOTAL"]
    pw = W // 2
    ph = H // 2
    panels = []
    for i, r in enumerate(t):
        x0, y0 = (i % 2) * pw, (i // 2) * ph
        L = (float(r["sig_mean_DC"]) - 36.0) / 40e6
        panels.append((r["region"], x0, y0, float(r["truth_mean_DC"]), float(r["truth_stddev_DC"]), L))

    def panel(x, y):
        return panels[(y // ph) * 2 + (x // pw)]

    write_pfm(os.path.join(d, "radiance", "000000.pfm"), W, H, lambda x, y: panel(x, y)[5])
    n = 8
    for k in range(n):
        vals = []
        for y in range(H):
            for x in range(W):
                p = panel(x, y)
                vals.append(rng.gauss(p[3], p[4]))
        write_pgm(os.path.join(d, "frames", "%06d.pgm" % k), W, H, vals)
    rois = [(p[0], p[1] + 4, p[2] + 4, pw - 8, ph - 8) for p in panels]
    write_toml(d, "pulnix-ag5745ef3",
               [("width", W), ("height", H), ("gain_V", 6.0), ('video.scan', '"frame"'),
                ("optics.cos4", "false")],
               "W/m2/sr", "moon", [0] * n, n, rois,
               comment="Thesis Tables 9-3..9-7 (make_thesis_datasets.py): truth panels",
               band="")


def gain_series(thesis, out, rng):
    t185 = rows(thesis, "table18-5_radiometric_calibration_gain5p5V.csv")
    ladder = sorted({float(r["reduced_radiance_W_m-2_sr-1"]) for r in t185})
    table = rows(thesis, "table18-6_camera_gain_vs_image_gain.csv")
    row55 = next(r for r in table if float(r["camera_gain_V"]) == 5.5)
    g55 = float(row55["image_gain_f11_DC_per_W_m-2_sr-1"])
    # Table 18-5's temporal variance against signal above bias: var = a + b * signal.
    xs = [float(r["mean_DC"]) - float(row55["image_bias_DC"]) for r in t185]
    ys = [float(r["stddev_DC"]) ** 2 for r in t185]
    n, sx, sy = len(xs), sum(xs), sum(ys)
    sxx, sxy = sum(x * x for x in xs), sum(x * y for x, y in zip(xs, ys))
    b = (n * sxy - sx * sy) / (n * sxx - sx * sx)
    a = (sy - b * sx) / n
    for r in table:
        volts = float(r["camera_gain_V"])
        if r["estimated"] == "yes" or volts == 5.5:
            continue
        gain, bias = float(r["image_gain_f11_DC_per_W_m-2_sr-1"]), float(r["image_bias_DC"])
        d = folders(out, "t18-6_gain_%sV" % ("%.1f" % volts).replace(".", "p"))
        index, k = [], 0
        levels = [L for L in ladder if bias + gain * L < 240.0]
        for i, L in enumerate(levels):
            write_pfm(os.path.join(d, "radiance", "%06d.pfm" % i), W, H, lambda x, y: L)
            m = bias + gain * L
            s = math.sqrt(a + b * (gain / g55) * (m - bias))
            for _ in range(3):
                write_pgm(os.path.join(d, "frames", "%06d.pgm" % k), W, H,
                          [rng.gauss(m, s) for _ in range(W * H)])
                index.append(i)
                k += 1
        write_toml(d, "pulnix-ag5745ef3",
                   [("width", W), ("height", H), ("gain_V", volts), ("f_number", 11.0),
                    ('video.scan', '"frame"')],
                   "W/m2/sr", "blackbody:2856", index, k,
                   comment="Thesis Table 18-6 at %.1f V (make_thesis_datasets.py): gain %.3g "
                           "DC per W m-2 sr-1, bias %.5g DC, on Table 18-5's radiance ladder"
                           % (volts, gain, bias))


def main():
    if len(sys.argv) != 3:
        sys.stderr.write("usage: make_thesis_datasets.py THESIS_CSV_DIR OUT_DIR\n")
        return 2
    thesis, out = sys.argv[1], sys.argv[2]
    rng = random.Random(1999)
    calibration(thesis, out, rng)
    averaging(thesis, out, rng)
    gain_series(thesis, out, rng)
    mtf(thesis, out, rng)
    truth_panels(thesis, out, rng)
    return 0


if __name__ == "__main__":
    sys.exit(main())
