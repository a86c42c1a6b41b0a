#!/usr/bin/python3
"""Open-world measured datasets for `nvstim diagnose`: a camera that has one effect the
diagnosed model lacks, made with shapes of its own (docs/contracts.md, "Measured dataset").

    open_world.py --effect NAME --seed S --out DIR [--size 768x494] [--frames 40]
                  [--nvstim PATH] [--set KEY=VALUE ...]
    open_world.py --list
    open_world.py --calibrate [--size WxH] [--nvstim PATH] [--set KEY=VALUE ...]

DIR receives dataset.toml, radiance/NNNNNN.pfm (the clean stimulus, the light the user
believes they showed), frames/NNNNNN.pgm (8-bit, what the camera made of the light it saw)
and truth.json ({"effect", "family", "character", "catalog_name", "parameters", ...}).
Everything follows from (effect, seed, size, frames). numpy only.

Camera
------
Preset `pulnix-ag5745ef3` with its own settings; only `width` and `height` are set (in the
dataset's [camera.settings] and as `--set width=.. --set height=..` of `nvstim sensor`), with
two exceptions: the preset has a halo and an MCP saturation of its own, which diagnose counts
as part of the model and does not try again, so for the effects `halo` and `mcp_saturation`
the preset's own stage is switched off (`halo.enabled = false`, `mcp_saturation.enabled =
false`, in the dataset and in the sensor) and the injected one takes its place. `--set
KEY=VALUE` changes the camera for every effect (dataset and sensor) and re-measures the
calibration below at 256 x 160 with it.

Each frame is one call of the model (a field in field scan): the frames come from one run of
`nvstim sensor --camera pulnix-ag5745ef3 --set width=W --set height=H --set video.adc_bits=16
--in seen/{frame:06d}.pfm --unit pe/s/m2/sr --frames N --seed S' --out raw/{frame:06d}.pgm`
on the light the camera saw (the clean stimulus with the effect, where the effect acts on the
light). S' is a number drawn from the dataset's seed (never the small seeds diagnose uses for
its own noisy run).

What the sensor's outputs hold (tested on a ramp, 256 x 160, same seed): its EXR output is not
the signal before quantisation. It holds the ADC's counts as floats: the same integers as the
PGM (read noise, video noise and quantisation in, clipped at 2^adc_bits - 1), except in the
first frame of field scan, where the rows not yet read hold the video offset (26.8) in the EXR
and 0 in the PGM. There is no float signal before quantisation to be had. `video.adc_bits=16`
keeps the same DC scale (DC per electron and offset unchanged) and only moves the top from 255
to 65535: its PGM equals the 8-bit PGM in every pixel below 255 (tested, 4 frames). So the
frames are made at 16 bits (integer DC, unclipped), the effects that act after detection are
applied to those integers (signal S = DC - offset_dc, offset_dc = 26.8 DC from the preset),
and the result is rounded and clipped to 0..255 here; with no post-detection effect this is
the 8-bit output bit for bit. Post-detection effects therefore see a signal already quantised
to 1 DC (a second rounding adds about 1/12 DC^2). Rows that are 0 throughout in the raw frame
(the unread field of the first frame) stay 0.

Units and calibration
---------------------
Radiance is photoelectron radiance, pe s^-1 m^-2 sr^-1 (`unit = "pe/s/m2/sr"`). Levels are
set in DC-equivalents: L = level_DC / K, K the signal above offset per unit radiance of the
preset at its own settings, measured once with `--calibrate` (a step ramp of 12 uniform
bands, 256 x 160, 12 frames held, bands' centres, frames 2..11):
    K = 4.67e-12 DC per pe s^-1 m^-2 sr^-1 (the signal of the bands from 12 to 216 DC within
        2 % of K L; the preset's cos^4 lowers the corners of a 768 x 494 frame by about 10 %,
        of a 256 x 160 frame by 1 %), so the ADC's top, 255 - 26.8 = 228.2 DC above offset, is
        4.9e13 pe s^-1 m^-2 sr^-1;
    dark signal 0.8 DC above offset at zero light (the preset's EBI);
    temporal variance 9.5 DC^2 + 3.9 DC^2 per DC of signal (per pixel, 10-200 DC, frames two
        apart: in field scan consecutive frames share a field): at the preset's 6 V the
        frames are dominated by shot noise, sigma 20 DC at 100 DC.

Stimulus (drawn from the seed; the same for every effect at one seed)
--------------------------------------------------------------------
Per frame, rendered by area sampling (4 x 4 samples a pixel) in pixel coordinates:
  - background 1 DC;
  - a ladder of 8-12 uniform panels across the top quarter, levels geometric from 0.5-1.5 DC
    (near black) to 1.3-1.8 x the ADC's top (so the brightest frames clip there);
  - a slanted edge (4-6 degrees from vertical, either way), 0.08 x top on its left, 0.55 x top
    on its right;
  - a bright spot, a disk of radius 1.5-2.5 px at 20 x the ADC's top;
  - a vertical bar at 0.45 x top, switched on or off (at random, at least once each) with
    the blocks below, independently of their brightness;
  - the whole scene scaled by a brightness held in blocks of 4-5 frames, uniform 0.25-1.0,
    one block in each half of the frames at 1.0.
So every block holds one stimulus: in field scan, frames k and k + 2 share no field and see
the same stimulus where calls k - 1 .. k + 2 do (the pairs of the noise statistics).
Distinct stimuli are stored once (`[stimulus] index`).

Effects (strengths uniform in the ranges given; the pixel pitch at the photocathode is
11 x 13 um times the taper's 1.636, 18.0 x 21.3 um, and kernels are round there, so a radius
"in px" is horizontal pixels)
------------------------------------------------------------------------------------------
Catalog effects, each with a shape other than diagnose's own:
  phosphor_persistence  L'_k = (1 - w) L_k + w sum_j h_j L_{k-j}, h_j ~ j^-n (j = 1..24 frames,
      normalised), w 0.15-0.4, n 1.5-2.5: a hyperbolic (power-law) afterglow, as phosphors
      with bimolecular recombination decay, in place of an exponential; light before frame 0
      is frame 0's. On the light seen.
  halo  L' = (1 - f) L + f ring (*) L, the ring of radius R 6-15 px with a Gaussian radial
      profile of sigma 0.15-0.3 R, f 0.05-0.15: electrons backscattered from the MCP's input
      land spread about a most likely range rather than on a thin ring. Before detection.
  fixed_pattern_noise  L' = L (1 + p n(x, y)), n white noise low-passed by a Gaussian of sigma
      5-20 px and scaled to zero mean and unit rms, p 0.03-0.08: a photocathode and screen whose
      sensitivity varies in blotches (uneven activation, fibre bundles' multifibres), not pixel
      by pixel. On the light.
  mcp_saturation  L' = L / (1 + L / L_half), L_half such that the brightest panel at full
      brightness is compressed by 20-60 %: a channel's output approaching its limit as a
      hyperbola, not an exponential. Before detection, per pixel.
  veiling_glare  L' = (1 - g) L + g G_sigma (*) L, G a Gaussian of sigma 40-100 px, g 0.03-0.08:
      scatter in the lens with a Gaussian, not an exponential, wing.
  vertical_smear  S' = S + s mean_column(S), s 0.01-0.03, on the signal above offset after
      detection (the assembled frame's column mean; an interline CCD's vertical registers
      collect light from the whole column while they shift).
  bright_source_protection  L' = L (1 - D / (1 + exp(-(I - I_mid) / I_w))), I the frame's mean
      light, I_mid = 0.55 I_max, I_w = 0.15 I_max, D so that the brightest frame loses 10-40 %:
      a power supply's gate duty cycle that falls as a logistic of the cathode current (a
      protection that engages around a threshold), not as a power law. On the light (fewer
      photoelectrons, as gating does).
  ebi_background  L' = L + B (1 + 0.2 u), B 3-10 DC equivalent, u the position along a
      random direction scaled to -0.5..0.5 over the frame: a dark emission with a gentle
      gradient across the tube. Added to the light, so it has the shot noise of light (and
      the optics' cos^4 of the preset, 1 % at 256 x 160).
  excess_noise  S' = S g, g ~ Gamma(shape S / ((r - 1) k), mean 1) where S > 0 (S unchanged
      elsewhere), k = 3.9 DC^2/DC the camera's shot variance per DC, r 1.3-1.8: per pixel and
      frame a multiplicative gain noise after detection. Var(S g) = E[S^2 var(g)] + var(S) =
      (r - 1) k E[S] + var(S), so the shot part of the variance rises by r exactly where S > 0;
      the approximation is that S (with its read noise) stands for the charge: where S is at or
      below 0 nothing is added, which leaves pixels within a few DC of the offset short of r.
      The added noise is white per pixel, the camera's shot noise is correlated by the MTF,
      so the neighbour covariance rises less than the variance. (Measured on a 256 x 160
      dataset against the null one of the same seed, frame pairs two apart, 35-200 DC: the
      variance rose by 0.63-0.68 k S for r - 1 = 0.64.)
Effects outside the catalog (family "outside"), with the character diagnose should call them:
  vignetting (spatial)  L' = L (1 + (r / r0)^2)^-2 (cos^4 of the angle arctan(r / r0)), r from
      the centre in um at the photocathode, r0 so that the corners lose 15-35 %. On the light.
  gain_compression (level)  S' = sign(S) M (|S| / M)^p, M = 114 DC (mid-scale above offset),
      p 0.85-0.93: a video amplifier's power-law transfer, after detection, on the noisy
      signal: its slope rises toward zero signal (1.4 at 2 DC), so the read noise of dark
      pixels is amplified, as a video gamma amplifies it.
  flicker (temporal)  L' = L (1 + u_k), u_k uniform in +-a per frame, a 0.05-0.12: a lamp on a
      mains or PWM supply beating with the field rate. On the light.
  column_offsets (spatial)  S' = S + c_x, c_x ~ N(0, sigma^2) per column, fixed, zero mean,
      sigma 2-4 DC: column amplifiers' offsets of a read-out. After detection.
  frame_jitter (geometric)  the scene rendered displaced by (dx_k, dy_k) ~ N(0, sigma^2) per
      axis, sigma 0.6-1.2 px: a camera on a vibrating mount. Before detection.
  lens_ghost (spatial)  L' = L + q G_b (*) L(rotated 180 deg about the frame's centre),
      q 0.02-0.05, G_b a Gaussian of sigma 1.5-3 px: a double reflection between lens surfaces
      images the scene point-mirrored and slightly out of focus.
  row_noise (temporal)  S' = S + r_{k,y}, r ~ N(0, sigma^2) per row and frame, sigma 1-3 DC:
      a read-out's line-clamp noise. After detection.
  light_loss  L' = t L, t 0.5-0.8 (family "null"): less light reached the photocathode than
      the dataset's radiance says (a lens's transmission, a radiance calibration off by 1/t).
      Not an effect of the camera: the baseline's gain absorbs it, and no cause may be named;
      a noise effect that reads the gain as the electronics' may be reported as a candidate.
  null  nothing (family "null").
Convolutions extend the frame by its mirror image at each edge (the scene continues past the
frame), exactly as an infinite symmetric extension (the kernel is summed over its periods).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zlib

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "pylib"))
import netpbm  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PRESET = "pulnix-ag5745ef3"

# Calibration of the preset at its own settings (module docstring; `--calibrate` re-measures).
K_DC = 4.67e-12          # [DC per pe s^-1 m^-2 sr^-1] signal above offset per unit radiance
SHOT_DC2_PER_DC = 3.9    # [DC^2 per DC] temporal variance per DC of signal (shot noise)


def toml_value(v):
    """A --set value as TOML: a number or boolean as given, anything else a string."""
    if v in ("true", "false"):
        return v
    try:
        float(v)
        return v
    except ValueError:
        return json.dumps(v)


def read_preset(settings=()):
    with open(os.path.join(REPO, "config", "cameras", PRESET + ".toml"), "rb") as f:
        p = tomllib.load(f)
    for key, v in settings:
        *tables, last = key.split(".")
        t = p
        for name in tables:
            t = t.setdefault(name, {})
        t[last] = tomllib.loads("v = " + toml_value(v))["v"]
    taper = p["photocathode"]["taper_magnification"]
    return {
        "offset_dc": float(p["video"]["offset_dc"]),
        "adc_top": float(2 ** int(p["video"]["adc_bits"]) - 1),
        "noise_factor": float(p["mcp"]["noise_factor"]),
        "pitch_um": (float(p["ccd"]["pitch_x_um"]) * taper, float(p["ccd"]["pitch_y_um"]) * taper),
    }


# ---------------------------------------------------------------------------------- images

def write_pfm(path, a):
    a = np.asarray(a, dtype="<f4")
    with open(path, "wb") as f:
        f.write(b"Pf\n%d %d\n-1.0\n" % (a.shape[1], a.shape[0]))
        f.write(a[::-1].tobytes())  # PFM stores the bottom row first


def write_pgm(path, a):
    a = np.asarray(a, dtype=np.uint8)
    with open(path, "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (a.shape[1], a.shape[0]))
        f.write(a.tobytes())


def read_pgm(path):
    return netpbm.read_pgm(path)[0].astype(float)


# ---------------------------------------------------------------------------- convolution

class Spreader:
    """Convolution with a kernel round at the photocathode, the frame extended by its mirror
    image at each edge (period 2H x 2W), the kernel summed over its periods."""

    def __init__(self, h, w, pitch_um):
        self.h, self.w, self.pitch = h, w, pitch_um
        self.cache = {}

    def kernel_ft(self, key, radial):
        if key not in self.cache:
            h2, w2 = 2 * self.h, 2 * self.w
            dy = (np.arange(h2) + self.h) % h2 - self.h
            dx = (np.arange(w2) + self.w) % w2 - self.w
            k = np.zeros((h2, w2))
            for m in (-2, -1, 0, 1, 2):
                for n in (-2, -1, 0, 1, 2):
                    yy = ((dy + m * h2) * self.pitch[1])[:, None]
                    xx = ((dx + n * w2) * self.pitch[0])[None, :]
                    k += radial(np.hypot(xx, yy))
            self.cache[key] = np.fft.rfft2(k / k.sum())
        return self.cache[key]

    def apply(self, img, key, radial):
        kf = self.kernel_ft(key, radial)
        top = np.concatenate([img, img[:, ::-1]], axis=1)
        ext = np.concatenate([top, top[::-1, :]], axis=0)
        return np.fft.irfft2(np.fft.rfft2(ext) * kf, s=ext.shape)[:self.h, :self.w]

    def gaussian(self, img, sigma_um):
        return self.apply(img, ("gauss", sigma_um),
                          lambda r: np.exp(-0.5 * (r / sigma_um) ** 2))


# ------------------------------------------------------------------------------- stimulus

SS = 4  # area samples per pixel and axis


def draw_scene(seed, w, h, frames, top_dc):
    """The stimulus's layout and time course (levels in DC above offset at brightness 1)."""
    rng = np.random.default_rng([int(seed), 0x5CE4E])
    n = int(rng.integers(8, 13))
    lo = rng.uniform(0.5, 1.5)
    hi = rng.uniform(1.3, 1.8) * top_dc
    ladder = list(lo * (hi / lo) ** (np.arange(n) / (n - 1)))
    tilt = rng.uniform(4.0, 6.0) * (1 if rng.random() < 0.5 else -1)
    spot_r = rng.uniform(1.5, 2.5)
    spot_xy = (rng.uniform(0.62, 0.70) * w, rng.uniform(0.56, 0.68) * h)
    # brightness held in blocks of 4-5 frames
    blocks, k = [], 0
    while k < frames:
        ln = int(rng.integers(4, 6))
        blocks.append((k, min(frames, k + ln)))
        k += ln
    bright = list(rng.uniform(0.25, 1.0, len(blocks)))
    mid = 2 + (frames - 2) // 2   # diagnose: frames 2.. split in halves
    first = [i for i, b in enumerate(blocks) if b[0] < mid]
    second = [i for i, b in enumerate(blocks) if b[1] > mid] or first
    bright[first[int(rng.integers(len(first)))]] = 1.0
    bright[second[int(rng.integers(len(second)))]] = 1.0
    brightness = [0.0] * frames
    for (a, b), v in zip(blocks, bright):
        for j in range(a, b):
            brightness[j] = float(v)
    # the bar is switched with the blocks, on or off independently of their brightness, so
    # that each block holds one stimulus (frame pairs of one stimulus for the noise statistics)
    states = list(rng.random(len(blocks)) < 0.5)
    if all(states) or not any(states):
        states[int(rng.integers(len(blocks)))] = not states[0]
    bar = [False] * frames
    for (a, b), on in zip(blocks, states):
        for j in range(a, b):
            bar[j] = bool(on)
    return {
        "background_dc": 1.0, "ladder_dc": [float(v) for v in ladder],
        "edge_dc": [0.08 * top_dc, 0.55 * top_dc], "edge_tilt_deg": float(tilt),
        "spot_dc": 20.0 * top_dc, "spot_radius_px": float(spot_r),
        "spot_xy_px": [float(spot_xy[0]), float(spot_xy[1])],
        "bar_dc": 0.45 * top_dc, "brightness": brightness, "bar_on": bar,
        "blocks": blocks,
    }


def render(scene, w, h, part, dx=0.0, dy=0.0):
    """One part of the scene ("base" or "bar") at brightness 1, in DC above offset, area-sampled,
    the scene displaced by (dx, dy) px."""
    off = (np.arange(SS) + 0.5) / SS - 0.5
    xs = (np.arange(w)[:, None] + off[None, :]).ravel() - dx
    ys = (np.arange(h)[:, None] + off[None, :]).ravel() - dy
    X, Y = xs[None, :], ys[:, None]
    img = np.zeros((h * SS, w * SS))

    def box(x0, x1, y0, y1):
        return ((X >= x0) & (X < x1)) & ((Y >= y0) & (Y < y1))

    if part == "bar":
        img[box(0.80 * w, 0.86 * w, 0.38 * h, 0.94 * h)] = scene["bar_dc"]
    else:
        img[:] = scene["background_dc"]
        lad = scene["ladder_dc"]
        edges = np.linspace(0.04 * w, 0.96 * w, len(lad) + 1)
        for i, v in enumerate(lad):
            img[box(edges[i], edges[i + 1], 0.07 * h, 0.30 * h)] = v
        x0, x1, y0, y1 = 0.06 * w, 0.46 * w, 0.40 * h, 0.92 * h
        xc, yc = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        t = np.tan(np.radians(scene["edge_tilt_deg"]))
        inside = box(x0, x1, y0, y1)
        right = (X - xc) > (Y - yc) * t
        img[inside] = scene["edge_dc"][0]
        img[inside & right] = scene["edge_dc"][1]
        sx, sy = scene["spot_xy_px"]
        img[np.hypot(X - sx, Y - sy) <= scene["spot_radius_px"]] = scene["spot_dc"]
    return img.reshape(h, SS, w, SS).mean(axis=(1, 3))


# -------------------------------------------------------------------------------- effects

CATALOG = ["phosphor_persistence", "halo", "fixed_pattern_noise", "mcp_saturation",
           "veiling_glare", "vertical_smear", "bright_source_protection", "ebi_background",
           "excess_noise"]

# name: (family, character)
EFFECTS = {
    "phosphor_persistence": ("catalog", "temporal"),
    "halo": ("catalog", "spatial"),
    "fixed_pattern_noise": ("catalog", "spatial"),
    "mcp_saturation": ("catalog", "level"),
    "veiling_glare": ("catalog", "spatial"),
    "vertical_smear": ("catalog", "spatial"),
    "bright_source_protection": ("catalog", "temporal"),
    "ebi_background": ("catalog", "noise"),
    "excess_noise": ("catalog", "noise"),
    "vignetting": ("outside", "spatial"),
    "gain_compression": ("outside", "level"),
    "flicker": ("outside", "temporal"),
    "column_offsets": ("outside", "spatial"),
    "frame_jitter": ("outside", "geometric"),
    "lens_ghost": ("outside", "spatial"),
    "row_noise": ("outside", "temporal"),
    "light_loss": ("null", "none"),
    "null": ("null", "none"),
}


def draw_parameters(effect, rng, ctx):
    """The effect's parameters (JSON-able), drawn uniformly in its range."""
    u = rng.uniform
    pitch_x = ctx["pitch_um"][0]
    if effect == "phosphor_persistence":
        return {"weight": u(0.15, 0.4), "power": u(1.5, 2.5), "frames": 24}
    if effect == "halo":
        r = u(6.0, 15.0)
        return {"fraction": u(0.05, 0.15), "radius_px": r, "radius_um": r * pitch_x,
                "ring_sigma_rel": u(0.15, 0.3)}
    if effect == "fixed_pattern_noise":
        s = u(5.0, 20.0)
        return {"prnu_rel": u(0.03, 0.08), "blotch_sigma_px": s, "blotch_sigma_um": s * pitch_x}
    if effect == "mcp_saturation":
        c = u(0.2, 0.6)
        top_panel = ctx["scene"]["ladder_dc"][-1]
        lh = top_panel * (1.0 - c) / c
        return {"compression_at_top_panel": c, "l_half_dc": lh, "l_half": lh / ctx["k_dc"]}
    if effect == "veiling_glare":
        s = u(40.0, 100.0)
        return {"fraction": u(0.03, 0.08), "sigma_px": s, "sigma_um": s * pitch_x}
    if effect == "vertical_smear":
        return {"smear_rel": u(0.01, 0.03)}
    if effect == "bright_source_protection":
        return {"drop_at_brightest": u(0.10, 0.40), "mid_rel": 0.55, "width_rel": 0.15}
    if effect == "ebi_background":
        b = u(3.0, 10.0)
        return {"level_dc": b, "level": b / ctx["k_dc"], "gradient": 0.2,
                "direction_deg": u(0.0, 360.0)}
    if effect == "excess_noise":
        return {"variance_factor": u(1.3, 1.8), "shot_dc2_per_dc": ctx["shot_dc2_per_dc"],
                "model_noise_factor": ctx["noise_factor"]}
    if effect == "vignetting":
        return {"corner_loss": u(0.15, 0.35)}
    if effect == "gain_compression":
        return {"exponent": u(0.85, 0.93), "mid_dc": 0.5 * ctx["top_dc"]}
    if effect == "flicker":
        a = u(0.05, 0.12)
        return {"amplitude": a,
                "gains": [float(1.0 + v) for v in rng.uniform(-a, a, ctx["frames"])]}
    if effect == "column_offsets":
        return {"sigma_dc": u(2.0, 4.0)}
    if effect == "frame_jitter":
        s = u(0.6, 1.2)
        d = rng.normal(0.0, s, (ctx["frames"], 2))
        return {"sigma_px": s, "shifts_px": [[float(a), float(b)] for a, b in d]}
    if effect == "lens_ghost":
        s = u(1.5, 3.0)
        return {"fraction": u(0.02, 0.05), "blur_sigma_px": s, "blur_sigma_um": s * pitch_x}
    if effect == "row_noise":
        return {"sigma_dc": u(1.0, 3.0)}
    if effect == "light_loss":
        return {"transmission": u(0.5, 0.8)}
    return {}


def light_seen(effect, p, clean, ctx, rng):
    """The light the camera saw, frame by frame (list of arrays, pe s^-1 m^-2 sr^-1)."""
    h, w = clean[0].shape
    sp = ctx["spreader"]
    if effect == "phosphor_persistence":
        n = p["frames"]
        hj = np.arange(1, n + 1, dtype=float) ** -p["power"]
        hj /= hj.sum()
        out = []
        for k in range(len(clean)):
            lag = sum(hj[j - 1] * clean[max(0, k - j)] for j in range(1, n + 1))
            out.append((1.0 - p["weight"]) * clean[k] + p["weight"] * lag)
        return out
    if effect == "halo":
        r0, s0 = p["radius_um"], p["ring_sigma_rel"] * p["radius_um"]
        def ring(r):
            return np.exp(-0.5 * ((r - r0) / s0) ** 2)
        return [(1.0 - p["fraction"]) * L + p["fraction"] * sp.apply(L, ("ring", r0, s0), ring)
                for L in clean]
    if effect == "fixed_pattern_noise":
        white = rng.normal(0.0, 1.0, (h, w))
        n = np.fft.irfft2(np.fft.rfft2(white) * gauss_ft(h, w, p["blotch_sigma_px"],
                                                         ctx["pitch_um"]), s=(h, w))
        n = (n - n.mean()) / n.std()
        g = 1.0 + p["prnu_rel"] * n
        return [L * g for L in clean]
    if effect == "mcp_saturation":
        return [L / (1.0 + L / p["l_half"]) for L in clean]
    if effect == "veiling_glare":
        return [(1.0 - p["fraction"]) * L + p["fraction"] * sp.gaussian(L, p["sigma_um"])
                for L in clean]
    if effect == "bright_source_protection":
        mean = np.array([L.mean() for L in clean])
        imax = mean.max()
        def logistic(i):
            return 1.0 / (1.0 + np.exp(-(i - p["mid_rel"] * imax) / (p["width_rel"] * imax)))
        d = p["drop_at_brightest"] / logistic(imax)
        gains = 1.0 - d * logistic(mean)
        p["frame_gains"] = [float(v) for v in gains]
        return [L * g for L, g in zip(clean, gains)]
    if effect == "ebi_background":
        a = np.radians(p["direction_deg"])
        yy, xx = np.mgrid[0:h, 0:w].astype(float)
        proj = np.cos(a) * xx * ctx["pitch_um"][0] + np.sin(a) * yy * ctx["pitch_um"][1]
        u = (proj - proj.min()) / (proj.max() - proj.min()) - 0.5
        bg = p["level"] * (1.0 + p["gradient"] * u)
        return [L + bg for L in clean]
    if effect == "vignetting":
        yy, xx = np.mgrid[0:h, 0:w].astype(float)
        r = np.hypot((xx - (w - 1) / 2) * ctx["pitch_um"][0],
                     (yy - (h - 1) / 2) * ctx["pitch_um"][1])
        rc = r.max()
        r0 = rc / np.sqrt((1.0 - p["corner_loss"]) ** -0.5 - 1.0)
        p["r0_um"] = float(r0)
        v = (1.0 + (r / r0) ** 2) ** -2
        return [L * v for L in clean]
    if effect == "flicker":
        return [L * g for L, g in zip(clean, p["gains"])]
    if effect == "light_loss":
        return [L * p["transmission"] for L in clean]
    if effect == "lens_ghost":
        return [L + p["fraction"] * sp.gaussian(L[::-1, ::-1], p["blur_sigma_um"]) for L in clean]
    return list(clean)


def gauss_ft(h, w, sigma_px, pitch_um):
    """Fourier transform of a periodic Gaussian of sigma_px horizontal pixels, round in um."""
    s = sigma_px * pitch_um[0]
    fy = np.fft.fftfreq(h)[:, None] / pitch_um[1]
    fx = np.fft.rfftfreq(w)[None, :] / pitch_um[0]
    return np.exp(-2.0 * np.pi ** 2 * s ** 2 * (fx ** 2 + fy ** 2))


def after_detection(effect, p, signal, ctx, rng):
    """The signal above offset [DC] after the effects that act after detection."""
    h, w = signal[0].shape
    if effect == "vertical_smear":
        return [S + p["smear_rel"] * S.mean(axis=0, keepdims=True) for S in signal]
    if effect == "excess_noise":
        c = (p["variance_factor"] - 1.0) * p["shot_dc2_per_dc"]
        out = []
        for S in signal:
            pos = S > 0
            T = S.copy()
            T[pos] = c * rng.gamma(S[pos] / c)
            out.append(T)
        return out
    if effect == "gain_compression":
        m, e = p["mid_dc"], p["exponent"]
        return [np.sign(S) * m * (np.abs(S) / m) ** e for S in signal]
    if effect == "column_offsets":
        c = rng.normal(0.0, p["sigma_dc"], w)
        c -= c.mean()
        return [S + c[None, :] for S in signal]
    if effect == "row_noise":
        return [S + rng.normal(0.0, p["sigma_dc"], (h, 1)) for S in signal]
    return signal


# ---------------------------------------------------------------------------------- sensor

def sensor_seed(seed):
    return int(np.random.default_rng([int(seed), 0x5E5]).integers(1 << 20, 1 << 48))


def run_sensor(nvstim, settings, seen_dir, raw_dir, w, h, frames, seed):
    cmd = sensor_cmd(nvstim, w, h, settings, os.path.join(seen_dir, "{frame:06d}.pfm"),
                     os.path.join(raw_dir, "{frame:06d}.pgm"), frames, seed)
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise SystemExit("open_world.py: nvstim sensor failed (%d): %s"
                         % (r.returncode, r.stderr.strip()))
    return [read_pgm(os.path.join(raw_dir, "%06d.pgm" % k)) for k in range(frames)]


# -------------------------------------------------------------------------------- dataset

# The chain's own stage of the same physics, switched off in the camera (dataset and sensor)
# when the effect is injected, so that the model diagnose starts from lacks it.
OWN_STAGE_OFF = {"halo": [("halo.enabled", "false")],
                 "mcp_saturation": [("mcp_saturation.enabled", "false")]}


def make(effect, seed, out, w, h, frames, nvstim, user_settings=()):
    if user_settings:
        cal = calibrate(nvstim, 256, 160, user_settings)
    else:
        cal = {"k_dc": K_DC, "shot_dc2_per_dc": SHOT_DC2_PER_DC}
    settings = list(user_settings) + OWN_STAGE_OFF.get(effect, [])
    pre = read_preset(settings)
    kdc = cal["k_dc"]
    top = pre["adc_top"] - pre["offset_dc"]
    scene = draw_scene(seed, w, h, frames, top)
    family, character = EFFECTS[effect]
    ctx = dict(pre, top_dc=top, frames=frames, scene=scene, k_dc=kdc,
               shot_dc2_per_dc=cal["shot_dc2_per_dc"],
               spreader=Spreader(h, w, pre["pitch_um"]))
    rng = np.random.default_rng([int(seed), zlib.crc32(effect.encode())])
    p = draw_parameters(effect, rng, ctx)

    base, bar = render(scene, w, h, "base") / kdc, render(scene, w, h, "bar") / kdc
    keys, index = [], []
    for k in range(frames):
        key = (scene["brightness"][k], scene["bar_on"][k])
        if key not in keys:
            keys.append(key)
        index.append(keys.index(key))
    distinct = [b * (base + (bar if on else 0.0)) for b, on in keys]
    clean = [distinct[i] for i in index]
    if effect == "frame_jitter":
        seen = []
        for k, (dx, dy) in enumerate(p["shifts_px"]):
            b, on = scene["brightness"][k], scene["bar_on"][k]
            img = render(scene, w, h, "base", dx, dy)
            if on:
                img = img + render(scene, w, h, "bar", dx, dy)
            seen.append(b * img / kdc)
    else:
        seen = light_seen(effect, p, clean, ctx, rng)

    os.makedirs(os.path.join(out, "radiance"), exist_ok=True)
    os.makedirs(os.path.join(out, "frames"), exist_ok=True)
    for i, img in enumerate(distinct):
        write_pfm(os.path.join(out, "radiance", "%06d.pfm" % i), img)
    tmp = tempfile.mkdtemp(prefix="open_world_")
    try:
        os.makedirs(os.path.join(tmp, "seen"))
        os.makedirs(os.path.join(tmp, "raw"))
        for k, img in enumerate(seen):
            write_pfm(os.path.join(tmp, "seen", "%06d.pfm" % k), np.maximum(img, 0.0))
        raw = run_sensor(nvstim, settings, os.path.join(tmp, "seen"), os.path.join(tmp, "raw"),
                         w, h, frames, sensor_seed(seed))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    signal = [r - pre["offset_dc"] for r in raw]
    signal = after_detection(effect, p, signal, ctx, rng)
    clipped = 0
    for k, (r, S) in enumerate(zip(raw, signal)):
        dc = np.clip(np.round(pre["offset_dc"] + S), 0, pre["adc_top"])
        dc[(r == 0).all(axis=1)] = 0
        clipped = max(clipped, int((dc >= pre["adc_top"]).sum()))
        write_pgm(os.path.join(out, "frames", "%06d.pgm" % k), dc)

    with open(os.path.join(out, "dataset.toml"), "w") as f:
        f.write("# open_world.py: effect %s, seed %d, %dx%d, %d frames (truth.json)\n"
                % (effect, seed, w, h, frames))
        f.write('[camera]\npreset = "%s"\n[camera.settings]\nwidth = %d\nheight = %d\n'
                % (PRESET, w, h))
        for k, v in settings:
            f.write('"%s" = %s\n' % (k, toml_value(v)))
        f.write('\n[stimulus]\nradiance = "radiance/{frame:06d}.pfm"\nunit = "pe/s/m2/sr"\n')
        f.write("index = [%s]\n" % ", ".join(str(i) for i in index))
        f.write('\n[output]\nframes = "frames/{frame:06d}.pgm"\nfirst_frame = 0\ncount = %d\n'
                % frames)
    truth = {
        "effect": effect, "family": family, "character": character,
        "catalog_name": effect if family == "catalog" else None,
        "parameters": p, "seed": seed, "size": [w, h], "frames": frames,
        "sensor_seed": sensor_seed(seed), "settings": dict(settings), "calibration": cal,
        "max_clipped_px": clipped,
        "stimulus": {k: v for k, v in scene.items() if k != "blocks"},
    }
    with open(os.path.join(out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)
        f.write("\n")
    return truth


# ---------------------------------------------------------------------------- calibration

def sensor_cmd(nvstim, w, h, settings, src, dst, frames, seed):
    cmd = [nvstim, "sensor", "--camera", PRESET, "--set", "width=%d" % w,
           "--set", "height=%d" % h]
    for k, v in settings:
        cmd += ["--set", "%s=%s" % (k, v)]
    return cmd + ["--set", "video.adc_bits=16", "--in", src, "--unit", "pe/s/m2/sr",
                  "--frames", str(frames), "--seed", str(seed), "--out", dst]


def calibrate(nvstim, w, h, settings=(), verbose=False):
    """Step ramp through the camera: K, the dark level and the temporal variance line
    (bands' centres, frames 2..11, differences of frames two apart)."""
    pre = read_preset(settings)
    k_guess = K_DC
    for _ in range(4):
        levels = np.geomspace(2.0, 220.0, 12) / k_guess
        band = w // 12
        img = np.zeros((h, w))
        for i, v in enumerate(levels):
            img[:, i * band:(i + 1) * band] = v
        img[:, 12 * band:] = levels[-1]
        tmp = tempfile.mkdtemp(prefix="open_world_cal_")
        try:
            os.makedirs(os.path.join(tmp, "raw"))
            raws = []
            for name, im in (("ramp", img), ("dark", np.zeros((h, w)))):
                write_pfm(os.path.join(tmp, name + ".pfm"), im)
                cmd = sensor_cmd(nvstim, w, h, settings, os.path.join(tmp, name + ".pfm"),
                                 os.path.join(tmp, "raw", "{frame:06d}.pgm"), 12, 987654321)
                r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                   text=True)
                if r.returncode != 0:
                    raise SystemExit("open_world.py: nvstim sensor failed (%d): %s"
                                     % (r.returncode, r.stderr.strip()))
                raws.append(np.array([read_pgm(os.path.join(tmp, "raw", "%06d.pgm" % k))
                                      for k in range(2, 12)]) - pre["offset_dc"])
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        S, dark = raws
        y0, y1 = h // 4, 3 * h // 4
        means, varis = [], []
        for i in range(12):
            c = S[:, y0:y1, i * band + band // 4:(i + 1) * band - band // 4]
            means.append(c.mean())
            d = c[2:] - c[:-2]          # frames two apart share no field
            varis.append(0.5 * d.var())
        means, varis = np.array(means), np.array(varis)
        dark_s = dark[:, y0:y1, w // 4:3 * w // 4].mean()
        sel = (means > 10) & (means < 200)
        if sel.sum() < 3:
            ok = means < 200
            k_guess = (means[ok][-1] - dark_s) / levels[ok][-1] if ok.any() else k_guess / 10
            continue
        k = np.sum((means[sel] - dark_s) * levels[sel]) / np.sum(levels[sel] ** 2)
        A = np.vstack([np.ones(sel.sum()), means[sel]]).T
        (a, b), *_ = np.linalg.lstsq(A, varis[sel], rcond=None)
        if abs(k / k_guess - 1.0) < 0.2:
            break
        k_guess = k
    if verbose:
        print("level [pe/s/m2/sr]   signal [DC]   signal/(K L)   variance [DC^2]")
        for L, m, v in zip(levels, means, varis):
            print("%12.4g  %10.2f  %10.3f  %10.2f" % (L, m, (m - dark_s) / (k * L), v))
        print("K = %.4g DC per pe/s/m2/sr; dark %.3f DC above offset; variance %.2f DC^2 + "
              "%.3f DC^2 per DC" % (k, dark_s, a, b))
    return {"k_dc": float(k), "dark_dc": float(dark_s), "var0_dc2": float(a),
            "shot_dc2_per_dc": float(b)}


# ----------------------------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--effect")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out")
    ap.add_argument("--size", default="768x494")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--nvstim",
                    default=os.path.join(REPO, "build", "release", "rt", "cli", "nvstim"))
    ap.add_argument("--list", action="store_true", help="print every effect, family, character")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a preset key (dataset and sensor); recalibrates K")
    ap.add_argument("--calibrate", action="store_true", help="measure K and the noise line")
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.lower().split("x"))
    settings = []
    for kv in a.set:
        if "=" not in kv or kv.split("=", 1)[0] in ("width", "height"):
            ap.error("--set KEY=VALUE (not width or height: --size)")
        settings.append(tuple(kv.split("=", 1)))
    if a.list:
        for name, (fam, ch) in EFFECTS.items():
            print("%-26s %-8s %s" % (name, fam, ch))
        return 0
    if a.calibrate:
        calibrate(a.nvstim, w, h, settings, verbose=True)
        return 0
    if a.effect not in EFFECTS or not a.out:
        ap.error("--effect NAME (one of --list) and --out DIR are needed")
    if a.frames < 8:
        ap.error("--frames must be at least 8")
    t = make(a.effect, a.seed, a.out, w, h, a.frames, a.nvstim, settings)
    print(json.dumps({"effect": t["effect"], "family": t["family"], "out": a.out,
                      "max_clipped_px": t["max_clipped_px"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
