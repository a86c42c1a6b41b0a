#!/usr/bin/python3
"""Reference fusion consumer for an nvstim rig: how an algorithm under test connects to it.

Two channels of one rig come in, each as a video and its metadata:

  video     a YUV4MPEG2 file (.y4m: the luma plane is used, any chroma layout, 8 or 16 bits), or
            a V4L2 device /dev/videoN (mono 8-bit GREY, as nvstim's v4l2 output sends it);
  metadata  the JSON-lines file of nvstim's `meta:` output for that channel, one record per
            emitted frame (keys: docs/contracts.md).

Frames and records are matched by order. For a file, the i-th y4m frame is the i-th record. For a
device, the i-th frame captured is taken to be the i-th record: start this consumer before nvstim
sends its first frame; it captures both channels at once until the streams stop (or --frames N
each), and only then reads the metadata files, complete by then. V4L2 queues a few buffers, so a
slow consumer loses nothing, but a frame lost between nvstim and the consumer shifts every later
match by one, and a count that differs from the records' is reported as bad input.

What it does, channel A into channel B:
  1. Pairs frames in time: for every frame of A, the frame of B whose exposure mid-time
     (t_sample_s) is nearest; a pair is matched when |dt| <= half the longer frame period.
     Gaps in a channel's sequence numbers are frames dropped on the way.
  2. Recovers each channel's time offset from its stamps: t_sample_s = offset + k * period with the
     nominal period fixed (least squares: the offset is the mean of t - k * period); the skew of B
     relative to A is offset_B - offset_A. The free least-squares slope is reported, not used.
  3. Registers A to B with the published ground-plane homography H_AB (Hartley & Zisserman,
     Multiple View Geometry, 2nd ed., 2004, §13.1: exact for points on the plane z = ground_z_m)
     and fuses them with a Laplacian pyramid (Burt & Adelson 1983).
  4. With --fiducials, measures the registration at known scene points: each is found by image
     measurement in both channels (the projection only places the search window) and A's
     centroid, mapped through H_AB, is compared with B's.

Pixel convention: nvstim's pixel coordinates have (0, 0) at the image's top-left corner and pixel
centres at +0.5 (docs/contracts.md); OpenCV's have pixel centres at integers. H_AB is published in
nvstim's convention and converted here where OpenCV uses it.

Interlaced channels: a frame's stamp is its second (later) field's, as the metadata gives it;
the first field was exposed 1/59.94 s earlier (its own stamp is in "fields").

Usage:
  nvstim_fusion_reference.py --a VIDEO META --b VIDEO META [--rate-a HZ] [--rate-b HZ]
      [--fiducials FILE] [--fused-dir DIR] [--fused-max N] [--json FILE] [--frames N]
  e.g. --a lwir.y4m lwir.jsonl --b ii.y4m ii.jsonl --rate-a 30 --rate-b 30000/1001
Give the nominal rates where they are known: a period taken from the stamps themselves (no y4m
header, no --rate) is off by its noise, and the offsets by that error times the mean frame number.
Exit status: 0 done, 2 bad input (one line on stderr saying what).
"""
import argparse
import json
import math
import os
import re
import sys
import threading

import cv2
import numpy as np

SEARCH_RADIUS_PX = 20  # half-size of the window the projection places around a fiducial
PYRAMID_LEVELS = 5     # at 768 x 494 the coarsest band is 48 x 31 px
MIN_PART_PX = 4        # smaller specks above a fiducial's threshold are noise
MIN_PART_FRACTION = 0.05  # of the main part's pixels


class BadInput(Exception):
    """Input the consumer cannot work with; main() prints it as one line and exits 2."""


# ---------------------------------------------------------------------------------------------
# Input


def parse_rate_hz(text):
    """A frame rate as '30', '29.97' or '30000/1001'."""
    try:
        if "/" in text:
            num, den = text.split("/", 1)
            rate_hz = float(num) / float(den)
        else:
            rate_hz = float(text)
    except (ValueError, ZeroDivisionError):
        raise argparse.ArgumentTypeError(f"not a frame rate: {text!r}")
    if not (rate_hz > 0 and math.isfinite(rate_hz)):
        raise argparse.ArgumentTypeError(f"not a frame rate: {text!r}")
    return rate_hz


def read_metadata(path):
    if not os.path.isfile(path):
        raise BadInput(f"metadata file not found: {path}")
    records = []
    with open(path, encoding="utf-8") as f:
        for line_no, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except json.JSONDecodeError as e:
                raise BadInput(f"{path}:{line_no}: not JSON ({e.msg})")
            for key in ("frame", "t_sample_s"):
                if key not in rec:
                    raise BadInput(f"{path}:{line_no}: record has no {key!r}")
            records.append(rec)
    if not records:
        raise BadInput(f"{path}: no records")
    return records


# Samples per frame after the luma plane for each YUV4MPEG2 chroma layout (the 'C' tag: mono,
# 420jpeg/420paldv/420mpeg2/420, 422, 444, 444alpha, 411, with a bit depth as in 420p10 or
# mono16), and the bytes per sample (more than 8 bits: 2, little-endian; mjpegtools' yuv4mpeg(5)
# and FFmpeg's yuv4mpegenc).
def _chroma_layout(tag, w, h):
    deep = re.fullmatch(r"(mono|\d{3})p?(\d+)", tag)  # mono16, 420p10, ...
    base = deep.group(1) if deep else tag[:4] if tag.startswith("mono") else tag[:3]
    depth_bits = int(deep.group(2)) if deep else 8
    cw2, ch2 = (w + 1) // 2, (h + 1) // 2
    if base == "mono":
        chroma = 0
    elif base == "420":
        chroma = 2 * cw2 * ch2
    elif base == "422":
        chroma = 2 * cw2 * h
    elif base == "411":
        chroma = 2 * ((w + 3) // 4) * h
    elif base == "444":
        chroma = 2 * w * h + (w * h if tag.startswith("444alpha") else 0)
    else:
        raise BadInput(f"y4m chroma layout C{tag} is not supported")
    return chroma, (2 if depth_bits > 8 else 1)


def read_y4m(path):
    """The luma planes of a YUV4MPEG2 file, and its header (width, height, rate, interlacing)."""
    if not os.path.isfile(path):
        raise BadInput(f"video file not found: {path}")
    with open(path, "rb") as f:
        data = f.read()
    nl = data.find(b"\n")
    if not data.startswith(b"YUV4MPEG2 ") or nl < 0:
        raise BadInput(f"{path}: not a YUV4MPEG2 file")
    header = {"width": None, "height": None, "rate_hz": None, "interlace": "?", "chroma": "420jpeg"}
    for tok in data[:nl].decode("ascii", "replace").split()[1:]:
        tag, val = tok[0], tok[1:]
        if tag == "W":
            header["width"] = int(val)
        elif tag == "H":
            header["height"] = int(val)
        elif tag == "F":
            num, den = val.split(":")
            if int(den) > 0 and int(num) > 0:
                header["rate_hz"] = int(num) / int(den)
        elif tag == "I":
            header["interlace"] = val
        elif tag == "C":
            header["chroma"] = val
    w, h = header["width"], header["height"]
    if not w or not h:
        raise BadInput(f"{path}: y4m header without W or H")
    chroma_samples, sample_bytes = _chroma_layout(header["chroma"], w, h)
    frame_bytes = (w * h + chroma_samples) * sample_bytes
    frames, pos = [], nl + 1
    while pos < len(data):
        end = data.find(b"\n", pos)
        if end < 0 or not data.startswith(b"FRAME", pos):
            raise BadInput(f"{path}: frame {len(frames)} has no FRAME marker")
        pos = end + 1
        if pos + frame_bytes > len(data):
            raise BadInput(f"{path}: frame {len(frames)} is truncated")
        dtype = "<u2" if sample_bytes == 2 else np.uint8
        frames.append(np.frombuffer(data, dtype, w * h, pos).reshape(h, w))
        pos += frame_bytes
    return frames, header


def capture_v4l2(path, count=None):
    """Mono frames from a V4L2 device in arrival order: `count` of them, or (None) until the
    stream stops (a read fails: OpenCV's V4L2 backend gives up after its select() timeout)."""
    cap = cv2.VideoCapture(path, cv2.CAP_V4L2)
    if not cap.isOpened():
        raise BadInput(f"{path}: cannot open as a V4L2 capture device")
    # Raw GREY buffers rather than OpenCV's conversion to BGR; where the backend refuses, the
    # converted frame is taken back to one channel below.
    cap.set(cv2.CAP_PROP_CONVERT_RGB, 0)
    width = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
    height = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    frames = []
    try:
        while count is None or len(frames) < count:
            ok, img = cap.read()
            if not ok or img is None:
                if count is not None:
                    raise BadInput(f"{path}: capture stopped after {len(frames)} of {count} "
                                   f"frames")
                break
            if img.ndim == 3 and img.shape[2] == 3:
                img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            elif img.ndim == 3:
                img = img[:, :, 0]
            if img.shape != (height, width):
                if img.size >= width * height and width * height > 0:
                    # An unconverted buffer comes as one row (its size may be padded).
                    img = img.reshape(-1)[:width * height].reshape(height, width)
                else:
                    raise BadInput(f"{path}: frame of {img.shape} from a {width} x {height} "
                                   f"device")
            frames.append(np.ascontiguousarray(img))
    finally:
        cap.release()
    if not frames:
        raise BadInput(f"{path}: no frame captured")
    return frames


def capture_devices(devices, count):
    """Both devices at once (each in its own thread; cv2 releases the GIL in read()), so that
    neither misses frames while the other is read. {label: path} -> {label: frames}."""
    results, errors = {}, {}

    def grab(label, path):
        try:
            results[label] = capture_v4l2(path, count)
        except BadInput as e:
            errors[label] = e
    threads = [threading.Thread(target=grab, args=item) for item in devices.items()]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise next(iter(errors.values()))
    return results


def is_device(video):
    return video.startswith("/dev/")


class Channel:
    """One channel: its frames, their records, and what the stamps say about its clock."""

    def __init__(self, label, video, meta, rate_hz, captured=None):
        self.video = video
        self.header = {}
        if captured is not None:
            self.frames = captured  # from a device, before the metadata was complete
        else:
            self.frames, self.header = read_y4m(video)
        self.records = read_metadata(meta)
        self.name = self.records[0].get("channel", label)
        if len(self.frames) != len(self.records):
            raise BadInput(f"channel {self.name}: {len(self.frames)} frames in {video} but "
                           f"{len(self.records)} records in {meta}")
        cam = self.records[0].get("camera")
        if cam and self.frames[0].shape != (cam["height"], cam["width"]):
            raise BadInput(f"channel {self.name}: frames of {self.frames[0].shape[1]} x "
                           f"{self.frames[0].shape[0]} in {video}, camera of {cam['width']} x "
                           f"{cam['height']} in {meta}")
        self.seq = np.array([r["frame"] for r in self.records], dtype=np.int64)
        self.t_s = np.array([r["t_sample_s"] for r in self.records], dtype=np.float64)
        if np.any(np.diff(self.seq) <= 0):
            raise BadInput(f"{meta}: sequence numbers do not increase")
        self.period_s, self.period_source = self._period(rate_hz)

    def _period(self, rate_hz):
        if rate_hz:
            return 1.0 / rate_hz, "command line"
        if self.header.get("rate_hz"):
            return 1.0 / self.header["rate_hz"], "y4m header"
        if len(self.seq) < 2:
            raise BadInput(f"channel {self.name}: one frame, no rate given: no period")
        # Stamp differences over sequence differences, each between frames half the record apart:
        # the stamps' noise divided by many periods rather than one.
        m = max(1, len(self.seq) // 2)
        per_s = (self.t_s[m:] - self.t_s[:-m]) / (self.seq[m:] - self.seq[:-m])
        return float(np.median(per_s)), "median of stamp differences"


# ---------------------------------------------------------------------------------------------
# Time


def sequence_gaps(seq):
    """Missing sequence numbers between consecutive records: frames dropped on the way."""
    gaps = []
    for k0, k1 in zip(seq[:-1], seq[1:]):
        if k1 - k0 > 1:
            gaps.append({"after": int(k0), "missing": int(k1 - k0 - 1)})
    return gaps


def fit_offset(ch):
    """The channel's time offset with its period fixed, and the free fit for the report.

    t_k = offset + k * period + e_k; least squares over the offset alone gives
    offset = mean(t_k - k * period) (ordinary least squares with a known slope).
    """
    resid_s = ch.t_s - ch.seq * ch.period_s
    offset_s = float(np.mean(resid_s))
    rms_s = float(np.sqrt(np.mean((resid_s - offset_s) ** 2)))
    slope_s = intercept_s = None
    if len(ch.seq) >= 2:
        slope_s, intercept_s = (float(v) for v in np.polyfit(ch.seq.astype(float), ch.t_s, 1))
    return {"offset_s": offset_s, "residual_rms_s": rms_s, "period_s": ch.period_s,
            "period_source": ch.period_source, "fitted_period_s": slope_s,
            "fitted_offset_s": intercept_s, "frames": len(ch.seq),
            "first_frame": int(ch.seq[0]), "last_frame": int(ch.seq[-1])}


def pair_frames(a, b, tolerance_s):
    """For each frame of A the frame of B nearest in t_sample_s, with dt_s = t_B - t_A."""
    order = np.argsort(b.t_s, kind="stable")
    tb = b.t_s[order]
    pairs = []
    for ia, ta in enumerate(a.t_s):
        j = int(np.searchsorted(tb, ta))
        cands = [c for c in (j - 1, j) if 0 <= c < len(tb)]
        jb = min(cands, key=lambda c: abs(tb[c] - ta))
        ib = int(order[jb])
        dt_s = float(b.t_s[ib] - ta)
        pairs.append({"frame_a": int(a.seq[ia]), "frame_b": int(b.seq[ib]), "dt_s": dt_s,
                      "matched": abs(dt_s) <= tolerance_s, "index_a": ia, "index_b": ib})
    return pairs


# ---------------------------------------------------------------------------------------------
# Geometry


def intrinsics(cam):
    return np.array([[cam["fx_px"], 0.0, cam["cx_px"]], [0.0, cam["fy_px"], cam["cy_px"]],
                     [0.0, 0.0, 1.0]])


def project_px(cam, xyz_m):
    """Pixel (nvstim convention) of scene point X: x_c = R X + t, u = K x_c / z_c."""
    R = np.array(cam["R"], dtype=float).reshape(3, 3)
    xc = R @ np.asarray(xyz_m, dtype=float) + np.array(cam["t_m"], dtype=float)
    if xc[2] <= 0:
        return None
    u = intrinsics(cam) @ (xc / xc[2])
    return u[:2]


def apply_h(H, p):
    q = H @ np.array([p[0], p[1], 1.0])
    return q[:2] / q[2]


def h_for_opencv(H):
    """H in OpenCV's pixel convention (centres at integers) from nvstim's (centres at +0.5):
    u_cv = u - 0.5 on both sides, so H_cv = T(-0.5) H T(+0.5)."""
    T_in = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, 0.5], [0.0, 0.0, 1.0]])
    T_out = np.array([[1.0, 0.0, -0.5], [0.0, 1.0, -0.5], [0.0, 0.0, 1.0]])
    Hc = T_out @ H @ T_in
    return Hc / Hc[2, 2]


def homography(rec_a, name_b):
    hs = rec_a.get("rig", {}).get("ground_homography", {})
    if name_b not in hs:
        raise BadInput(f"channel {rec_a.get('channel')} frame {rec_a['frame']}: no ground "
                       f"homography to {name_b} in its metadata")
    return np.array(hs[name_b], dtype=float).reshape(3, 3)


def geometry_key(rec, name_b=None):
    """What fixes a record's registration: its camera and (for A) its homography to B."""
    key = json.dumps(rec.get("camera"), sort_keys=True)
    if name_b is not None:
        key += json.dumps(rec.get("rig", {}).get("ground_homography", {}).get(name_b))
    return key


# ---------------------------------------------------------------------------------------------
# Fusion (Burt & Adelson, "The Laplacian Pyramid as a Compact Image Code", IEEE Trans. Commun.
# 31(4), 1983; selection rule: Burt & Kolczynski, "Enhanced image capture through fusion",
# ICCV 1993, the "choose max" of the detail coefficients)


def laplacian_pyramid(img, levels):
    gauss = [img]
    for _ in range(levels - 1):
        gauss.append(cv2.pyrDown(gauss[-1]))
    lap = []
    for i in range(levels - 1):
        h, w = gauss[i].shape
        lap.append(gauss[i] - cv2.pyrUp(gauss[i + 1], dstsize=(w, h)))
    lap.append(gauss[-1])  # the base: the coarsest Gaussian level
    return lap


def fuse_laplacian(a, b, levels=PYRAMID_LEVELS):
    """Detail bands: the coefficient of larger magnitude; base: the average of the two."""
    la, lb = laplacian_pyramid(a, levels), laplacian_pyramid(b, levels)
    fused = [np.where(np.abs(x) >= np.abs(y), x, y) for x, y in zip(la[:-1], lb[:-1])]
    fused.append(0.5 * (la[-1] + lb[-1]))
    img = fused[-1]
    for band in reversed(fused[:-1]):
        h, w = band.shape
        img = cv2.pyrUp(img, dstsize=(w, h)) + band
    return img


def warp_into(frame_a, H_ab, shape_b):
    """A's frame in B's pixels, and where it is defined (outside A's footprint: False)."""
    Hc = h_for_opencv(H_ab)
    h, w = shape_b
    warped = cv2.warpPerspective(frame_a.astype(np.float32), Hc, (w, h), flags=cv2.INTER_LINEAR,
                                 borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    valid = cv2.warpPerspective(np.ones(frame_a.shape, np.uint8), Hc, (w, h),
                                flags=cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                                borderValue=0) > 0
    return warped, valid


def fuse_pair(frame_a, frame_b, H_ab):
    b = frame_b.astype(np.float32)
    warped, valid = warp_into(frame_a, H_ab, b.shape)
    # Outside A's footprint B stands in for A, so the border adds no false detail to the bands.
    a_in_b = np.where(valid, warped, b)
    fused = fuse_laplacian(a_in_b, b, min(PYRAMID_LEVELS, _max_levels(b.shape)))
    if max(float(frame_a.max()), float(frame_b.max())) > 255:  # deeper than 8 bits: stretch
        return to_u8(fused), a_in_b, valid
    return np.clip(fused + 0.5, 0, 255).astype(np.uint8), a_in_b, valid


def _max_levels(shape):
    return max(1, int(math.log2(max(1, min(shape) // 8))) + 1)


def to_u8(img):
    """A display stretch (0.5 % .. 99.5 %) for images that are not 8-bit already."""
    img = img.astype(np.float32)
    lo, hi = np.percentile(img, (0.5, 99.5))
    return np.clip((img - lo) * 255.0 / max(hi - lo, 1e-6), 0, 255).astype(np.uint8)


# ---------------------------------------------------------------------------------------------
# Fiducials
#
# A fiducial is found by image measurement alone; its projection only places the search window.
# The aluminium targets look different in the two bands: bright in the intensified channel, where
# they reflect the lamp, with the shadow one plate casts on the other; dark in the thermal channel,
# where their low emissivity shows the cold sky (the top faces darkest) or the ground, in a ground
# of uneven temperature. A blob's thresholded area or its intensity-weighted centroid moves with
# that shading by a pixel or more, differently in each band. What the bands share is the outline,
# so the measurement is:
#   1. background: the median of a region twice the search window, which the target covers only
#      a small part of;
#   2. polarity: the sign of the mean deviation from the background in a small disc at the
#      projection (the target fills it; a light or dark surround does not decide it);
#   3. parts: pixels that deviate, with that polarity, by more than half the window's peak
#      deviation (99th percentile, after a 1-px Gaussian against the noise), grouped into
#      connected components; the one with the most pixels in the search window, and any other
#      there of some size (a shadow can cut the target in two);
#   4. outline: edges at the peak of the gradient near those parts (the boundary of a blurred
#      step, whatever the contrast on either side), to sub-pixel;
#   5. the centroid of the outline's convex hull, from its first moments: the hull fills in the
#      shading and shadows inside the target (centroid estimators of target images compared:
#      Shortis, Clarke & Short, "A comparison of some techniques for the subpixel location of
#      discrete target images", Proc. SPIE 2350, 1994).
# A target that reaches the edge of the image or of the analysis region is reported instead of
# measured. On the rit-fusion fiducials the two bands agree to about 0.4-0.8 px this way (2 px by
# a thresholded blob's centroid).


def measure_fiducial(img, pred_px, radius_px=SEARCH_RADIUS_PX):
    """(centroid in nvstim pixels, None) or (None, why not)."""
    h, w = img.shape
    u, v = pred_px[0] - 0.5, pred_px[1] - 0.5  # OpenCV indices
    if not (0.0 <= pred_px[0] <= w and 0.0 <= pred_px[1] <= h):
        return None, "outside the image"
    if not (radius_px <= u <= w - 1 - radius_px and radius_px <= v <= h - 1 - radius_px):
        return None, "too close to the image edge for the search window"
    r2 = 2 * radius_px
    x0, x1 = max(0, int(round(u)) - r2), min(w, int(round(u)) + r2 + 1)
    y0, y1 = max(0, int(round(v)) - r2), min(h, int(round(v)) + r2 + 1)
    region = cv2.GaussianBlur(img[y0:y1, x0:x1].astype(np.float32), (0, 0), 1.0)
    dev = region - np.median(region)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    in_disc = (xx - u) ** 2 + (yy - v) ** 2 <= (radius_px / 3.0) ** 2
    in_window = (np.abs(xx - u) <= radius_px) & (np.abs(yy - v) <= radius_px)
    polarity = 1.0 if np.mean(dev[in_disc]) >= 0 else -1.0
    signed = polarity * dev
    peak = float(np.percentile(signed[in_window], 99))
    if not peak > 0:
        return None, "no contrast in the search window"
    mask = (signed > 0.5 * peak).astype(np.uint8)
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 1:
        return None, "nothing above the threshold"
    counts_window = np.bincount(labels[in_window], minlength=n)
    counts_window[0] = 0
    main = int(np.argmax(counts_window))
    if counts_window[main] == 0:
        return None, "nothing above the threshold in the search window"
    # The target's parts that a shadow or a facet of other contrast cuts off the main one.
    sizes = np.bincount(labels.ravel(), minlength=n)
    keep = [i for i in range(1, n) if counts_window[i] > 0
            and sizes[i] >= max(MIN_PART_PX, MIN_PART_FRACTION * sizes[main])]
    ys, xs = np.nonzero(np.isin(labels, keep))
    if (xs.min() == 0 or ys.min() == 0 or xs.max() == x1 - x0 - 1 or ys.max() == y1 - y0 - 1):
        at_image_edge = (x0 + xs.min() == 0 or y0 + ys.min() == 0 or x0 + xs.max() == w - 1
                         or y0 + ys.max() == h - 1)
        return None, ("target cut by the image edge" if at_image_edge
                      else "target not isolated in the analysis region")
    # The outline where the gradient peaks, and the centroid of its convex hull.
    pts = outline_points(region, np.isin(labels, keep))
    if len(pts) < 3:
        return None, "no outline found"
    hull = cv2.convexHull(pts)
    m = cv2.moments(hull)
    if m["m00"] <= 0:
        return None, "target too small to measure"
    centroid = np.array([m["m10"] / m["m00"] + x0 + 0.5, m["m01"] / m["m00"] + y0 + 0.5])
    return centroid, None


def outline_points(region, parts):
    """Sub-pixel edge points of the target's outline: Canny's edges (hysteresis at 30 % and 10 %
    of the strongest gradient near the target) within 2 px of its mask, each moved to the peak
    of a parabola through the gradient magnitude across the edge (Devernay, "A non-maxima
    suppression method for edge detection with sub-pixel accuracy", INRIA RR-2724, 1995)."""
    gx = cv2.Sobel(region, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(region, cv2.CV_32F, 0, 1, ksize=3)
    mag = np.hypot(gx, gy)
    near = cv2.dilate(parts.astype(np.uint8), np.ones((3, 3), np.uint8), iterations=2) > 0
    gmax = float(mag[near].max()) if near.any() else 0.0
    if not gmax > 0:
        return np.zeros((0, 2), np.float32)
    scale = 1000.0 / gmax  # Canny takes 16-bit derivatives: the strongest edge at 1000
    edges = cv2.Canny(np.round(gx * scale).astype(np.int16), np.round(gy * scale).astype(np.int16),
                      100.0, 300.0, L2gradient=True)
    ys, xs = np.nonzero((edges > 0) & near)
    h, w = mag.shape
    pts = []
    for y, x in zip(ys, xs):
        ang = math.atan2(gy[y, x], gx[y, x])
        dx, dy = int(round(math.cos(ang))), int(round(math.sin(ang)))
        off = 0.0
        if 0 <= x - dx < w and 0 <= x + dx < w and 0 <= y - dy < h and 0 <= y + dy < h:
            gm, g0, gp = mag[y - dy, x - dx], mag[y, x], mag[y + dy, x + dx]
            den = gm - 2.0 * g0 + gp
            if den < 0:
                off = min(0.5, max(-0.5, 0.5 * (gm - gp) / den))
        pts.append((x + off * dx, y + off * dy))
    return np.array(pts, np.float32).reshape(-1, 2)


def load_fiducials(path):
    if not os.path.isfile(path):
        raise BadInput(f"fiducials file not found: {path}")
    try:
        with open(path, encoding="utf-8") as f:
            fids = json.load(f)
        out = [{"name": str(d["name"]), "xyz_m": [float(x) for x in d["xyz_m"]]} for d in fids]
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as e:
        raise BadInput(f"{path}: not a list of {{name, xyz_m}} ({e})")
    if any(len(d["xyz_m"]) != 3 for d in out):
        raise BadInput(f"{path}: every xyz_m must have 3 numbers")
    return out


def fiducial_offsets(fids, img_a, rec_a, img_b, rec_b, H_ab):
    """Per fiducial: B's measured centroid minus A's mapped through H_AB (B pixels).

    Also the parallax the plane's homography leaves for the fiducial's height above the plane
    (the published geometry alone: proj_B(X) - H_AB proj_A(X)), which a perfect rig shows.
    """
    out = []
    for fd in fids:
        row = {"name": fd["name"], "xyz_m": fd["xyz_m"]}
        pa, pb = project_px(rec_a["camera"], fd["xyz_m"]), project_px(rec_b["camera"], fd["xyz_m"])
        row["predicted_a_px"] = None if pa is None else pa.tolist()
        row["predicted_b_px"] = None if pb is None else pb.tolist()
        if pa is None or pb is None:
            row["status"] = "behind a camera"
            out.append(row)
            continue
        row["parallax_px"] = (pb - apply_h(H_ab, pa)).tolist()
        ca, why_a = measure_fiducial(img_a, pa)
        cb, why_b = measure_fiducial(img_b, pb)
        if ca is None or cb is None:
            parts = ([f"{rec_a['channel']}: {why_a}"] if why_a else []) + \
                    ([f"{rec_b['channel']}: {why_b}"] if why_b else [])
            row["status"] = "skipped (" + "; ".join(parts) + ")"
            out.append(row)
            continue
        mapped = apply_h(H_ab, ca)
        d = cb - mapped
        row.update({"status": "measured", "measured_a_px": ca.tolist(),
                    "measured_b_px": cb.tolist(), "a_in_b_px": mapped.tolist(),
                    "offset_px": d.tolist(), "offset_abs_px": float(np.hypot(*d))})
        out.append(row)
    return out


def median_over_pairs(per_pair):
    """Per fiducial, the median of its offsets over the pairs it was measured in."""
    merged = []
    for i, first in enumerate(per_pair[0]):
        rows = [p[i] for p in per_pair if p[i]["status"] == "measured"]
        if not rows:
            merged.append(first)
            continue
        row = dict(rows[0])
        for key in ("measured_a_px", "measured_b_px", "a_in_b_px", "offset_px"):
            row[key] = np.median([r[key] for r in rows], axis=0).tolist()
        row["offset_abs_px"] = float(np.hypot(*row["offset_px"]))
        row["pairs_measured"] = len(rows)
        merged.append(row)
    return merged


# ---------------------------------------------------------------------------------------------
# Images for a person to look at


def strong_edges(img):
    """Canny edges of an image at thresholds that follow its own contrast (70th/90th percentile
    of its gradient magnitude), so that two bands of different contrast show alike."""
    b = cv2.GaussianBlur(img.astype(np.float32), (0, 0), 1.0)
    gx, gy = cv2.Sobel(b, cv2.CV_32F, 1, 0), cv2.Sobel(b, cv2.CV_32F, 0, 1)
    mag = np.hypot(gx, gy)
    lo, hi = np.percentile(mag, (92, 98))
    scale = 1000.0 / max(float(mag.max()), 1e-6)
    return cv2.Canny(np.round(gx * scale).astype(np.int16), np.round(gy * scale).astype(np.int16),
                     lo * scale, max(hi * scale, lo * scale + 1), L2gradient=True) > 0


def write_overlay(path, a_in_b, frame_b, fid_rows):
    """B dimmed in grey, B's edges in green, A's (warped into B) in magenta, white where they
    coincide: registered structure is white, displaced structure shows green beside magenta.
    Fiducials marked (B's centroid: green circle; A's, mapped: magenta cross)."""
    grey = (to_u8(frame_b) // 3).astype(np.uint8)
    img = cv2.merge([grey, grey, grey])
    ea, eb = strong_edges(a_in_b), strong_edges(frame_b)
    img[ea] = (255, 0, 255)
    img[eb] = (0, 255, 0)
    img[ea & eb] = (255, 255, 255)
    scale = 2  # marks drawn at 1/4 px with cv2's fixed-point shift
    for row in fid_rows or []:
        if row.get("status") != "measured":
            continue
        cb = np.array(row["measured_b_px"]) - 0.5
        ca = np.array(row["a_in_b_px"]) - 0.5
        cv2.circle(img, tuple(int(round(c * 4)) for c in cb), 6 * 4, (0, 255, 0), 1,
                   cv2.LINE_AA, scale)
        cv2.drawMarker(img, tuple(int(round(c)) for c in ca), (255, 0, 255),
                       cv2.MARKER_CROSS, 10, 1)
        cv2.putText(img, row["name"], (int(cb[0]) + 8, int(cb[1]) + 4),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 255, 255), 1, cv2.LINE_AA)
    cv2.imwrite(path, img)


def write_fiducial_crops(path, a_in_b, frame_b, fid_rows, half_px=24, zoom=6):
    """For each measured fiducial: A warped into B | B, enlarged, centroids marked."""
    tiles = []
    for row in fid_rows or []:
        if row.get("status") != "measured":
            continue
        c = np.array(row["measured_b_px"]) - 0.5
        x0, y0 = int(round(c[0])) - half_px, int(round(c[1])) - half_px
        pair = []
        for img in (a_in_b, frame_b):
            pad = np.pad(img.astype(np.float32), half_px + 1, mode="edge")
            crop = pad[y0 + half_px + 1:y0 + 3 * half_px + 1, x0 + half_px + 1:x0 + 3 * half_px + 1]
            big = cv2.resize(to_u8(crop), None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)
            big = cv2.cvtColor(big, cv2.COLOR_GRAY2BGR)
            for key, colour in (("a_in_b_px", (255, 0, 255)), ("measured_b_px", (0, 255, 0))):
                p = (np.array(row[key]) - 0.5 - [x0, y0] + 0.5) * zoom
                cv2.drawMarker(big, (int(round(p[0])), int(round(p[1]))), colour,
                               cv2.MARKER_CROSS, 3 * zoom, 1)
            pair.append(big)
        tile = np.hstack(pair)
        cv2.putText(tile, row["name"], (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 255, 255), 1)
        tiles.append(tile)
    if tiles:
        cv2.imwrite(path, np.vstack(tiles))


# ---------------------------------------------------------------------------------------------


def run(args):
    devices = {label: video for label, (video, _) in (("a", args.a), ("b", args.b))
               if is_device(video)}
    for video in devices.values():
        if not os.path.exists(video):
            raise BadInput(f"video device not found: {video}")
    captured = capture_devices(devices, args.frames) if devices else {}
    a = Channel("a", args.a[0], args.a[1], args.rate_a, captured.get("a"))
    b = Channel("b", args.b[0], args.b[1], args.rate_b, captured.get("b"))
    if a.name == b.name:
        raise BadInput(f"both inputs are channel {a.name}")

    fit_a, fit_b = fit_offset(a), fit_offset(b)
    skew_s = fit_b["offset_s"] - fit_a["offset_s"]
    tolerance_s = 0.5 * max(a.period_s, b.period_s)
    pairs = pair_frames(a, b, tolerance_s)
    matched = [p for p in pairs if p["matched"]]
    if not matched:
        raise BadInput(f"no overlap: no frame of {a.name} has a frame of {b.name} within "
                       f"{tolerance_s * 1e3:.3f} ms ({a.name} {a.t_s[0]:.6f}..{a.t_s[-1]:.6f} s, "
                       f"{b.name} {b.t_s[0]:.6f}..{b.t_s[-1]:.6f} s)")
    for p in matched:
        if "camera" not in a.records[p["index_a"]] or "camera" not in b.records[p["index_b"]]:
            raise BadInput("a matched frame has no camera geometry in its metadata: no "
                           "registration (a test pattern?)")
    gaps_a, gaps_b = sequence_gaps(a.seq), sequence_gaps(b.seq)
    # B's frames no frame of A chose: where A dropped a frame, or ran at a lower rate.
    chosen_b = {p["index_b"] for p in matched}
    unpaired_b = [int(k) for i, k in enumerate(b.seq) if i not in chosen_b]

    fids, fid_rows, fid_mode = None, None, None
    if args.fiducials:
        fids = load_fiducials(args.fiducials)
        static = (len({geometry_key(r, b.name) for r in a.records}) == 1
                  and len({geometry_key(r) for r in b.records}) == 1)
        fid_mode = args.fiducial_mode if args.fiducial_mode != "auto" else (
            "mean" if static else "pair")
        if fid_mode == "mean":
            # A rig and scene at rest: the targets are measured on each channel's mean of its
            # matched frames, the noise down by the square root of their number.
            ia = sorted({p["index_a"] for p in matched})
            ib = sorted({p["index_b"] for p in matched})
            mean_a = np.mean([a.frames[i].astype(np.float32) for i in ia], axis=0)
            mean_b = np.mean([b.frames[i].astype(np.float32) for i in ib], axis=0)
            ra, rb = a.records[ia[0]], b.records[ib[0]]
            fid_rows = fiducial_offsets(fids, mean_a, ra, mean_b, rb, homography(ra, b.name))
        else:
            per_pair = []
            for p in matched:
                ra, rb = a.records[p["index_a"]], b.records[p["index_b"]]
                per_pair.append(fiducial_offsets(fids, a.frames[p["index_a"]], ra,
                                                 b.frames[p["index_b"]], rb,
                                                 homography(ra, b.name)))
            fid_rows = median_over_pairs(per_pair)

    if args.fused_dir:
        os.makedirs(args.fused_dir, exist_ok=True)
        written = 0
        for n, p in enumerate(matched):
            if args.fused_max and written >= args.fused_max:
                break
            ra = a.records[p["index_a"]]
            fused, a_in_b, _ = fuse_pair(a.frames[p["index_a"]], b.frames[p["index_b"]],
                                         homography(ra, b.name))
            stem = f"{a.name}{p['frame_a']:05d}_{b.name}{p['frame_b']:05d}"
            cv2.imwrite(os.path.join(args.fused_dir, f"fused_{stem}.png"), fused)
            written += 1
            if n == 0:
                write_overlay(os.path.join(args.fused_dir, f"overlay_{stem}.png"), a_in_b,
                              b.frames[p["index_b"]], fid_rows)
        if fid_rows and fid_mode == "mean":
            H = homography(a.records[matched[0]["index_a"]], b.name)
            warped, valid = warp_into(mean_a, H, mean_b.shape)
            a_in_b = np.where(valid, warped, mean_b)
            write_overlay(os.path.join(args.fused_dir, "overlay_mean.png"), a_in_b, mean_b,
                          fid_rows)
            write_fiducial_crops(os.path.join(args.fused_dir, "fiducials_mean.png"), a_in_b,
                                 mean_b, fid_rows)

    measured = [r for r in (fid_rows or []) if r["status"] == "measured"]
    summary = {
        "channels": {"a": a.name, "b": b.name},
        "pairs": {
            "matched": len(matched), "total": len(pairs), "tolerance_s": tolerance_s,
            "max_abs_dt_s": max(abs(p["dt_s"]) for p in pairs),
            "max_abs_dt_matched_s": max(abs(p["dt_s"]) for p in matched),
            "unpaired_b": unpaired_b,
            "list": [{k: p[k] for k in ("frame_a", "frame_b", "dt_s", "matched")}
                     for p in pairs],
        },
        "skew_s": skew_s,
        "offsets": {a.name: fit_a, b.name: fit_b},
        "drops": {
            a.name: {"gaps": gaps_a, "missing": sum(g["missing"] for g in gaps_a),
                     "first_frame": int(a.seq[0])},
            b.name: {"gaps": gaps_b, "missing": sum(g["missing"] for g in gaps_b),
                     "first_frame": int(b.seq[0])},
        },
    }
    if fid_rows is not None:
        summary["fiducials"] = {
            "mode": fid_mode, "list": fid_rows, "measured": len(measured),
            "skipped": len(fid_rows) - len(measured),
            "median_offset_px": (np.median([r["offset_px"] for r in measured], axis=0).tolist()
                                 if measured else None),
            "median_offset_abs_px": (float(np.median([r["offset_abs_px"] for r in measured]))
                                     if measured else None),
        }
    return summary, a, b


def print_report(s, a, b):
    na, nb = a.name, b.name
    p = s["pairs"]
    print(f"channels: A = {na} ({len(a.seq)} frames, {a.video}), B = {nb} ({len(b.seq)} frames, "
          f"{b.video})")
    print(f"pairs ({na} -> nearest {nb}): {p['matched']}/{p['total']} matched "
          f"(|dt| <= {p['tolerance_s'] * 1e3:.3f} ms); max |dt| {p['max_abs_dt_s'] * 1e3:.3f} ms")
    for q in p["list"]:
        flag = "" if q["matched"] else "   NOT MATCHED"
        print(f"  {na} {q['frame_a']:5d}  {nb} {q['frame_b']:5d}  "
              f"dt {q['dt_s'] * 1e3:+8.3f} ms{flag}")
    if p["unpaired_b"]:
        print(f"  {nb} frames no {na} frame matched: {', '.join(map(str, p['unpaired_b']))}")
    for name in (na, nb):
        o = s["offsets"][name]
        fitted = ("" if o["fitted_period_s"] is None else
                  f"; free fit: period {o['fitted_period_s'] * 1e3:.6f} ms "
                  f"({1.0 / o['fitted_period_s']:.4f} Hz), "
                  f"offset {o['fitted_offset_s'] * 1e3:+.4f} ms")
        print(f"clock {name}: period {o['period_s'] * 1e3:.6f} ms ({o['period_source']}), "
              f"offset {o['offset_s'] * 1e3:+.4f} ms, "
              f"residual rms {o['residual_rms_s'] * 1e3:.4f} ms{fitted}")
    print(f"skew of {nb} relative to {na}: {s['skew_s'] * 1e3:+.4f} ms")
    for name in (na, nb):
        d = s["drops"][name]
        where = ", ".join(f"{g['missing']} after {g['after']}" for g in d["gaps"]) or "none"
        print(f"drops {name}: {d['missing']} frame(s) missing from the sequence ({where}); "
              f"first frame {d['first_frame']}")
    f = s.get("fiducials")
    if f:
        print(f"fiducials ({f['mode']} images; offset = {nb}'s centroid - {na}'s mapped by H, "
              f"{nb} px):")
        for r in f["list"]:
            if r["status"] != "measured":
                print(f"  {r['name']:>8}: {r['status']}")
                continue
            ma, ab, mb = r["measured_a_px"], r["a_in_b_px"], r["measured_b_px"]
            off, par = r["offset_px"], r["parallax_px"]
            print(f"  {r['name']:>8}: {na} ({ma[0]:7.2f}, {ma[1]:7.2f}) -> ({ab[0]:7.2f}, "
                  f"{ab[1]:7.2f}); {nb} ({mb[0]:7.2f}, {mb[1]:7.2f}); offset ({off[0]:+6.2f}, "
                  f"{off[1]:+6.2f}) |{r['offset_abs_px']:.2f}| px; parallax ({par[0]:+.2f}, "
                  f"{par[1]:+.2f}) px")
        if f["measured"]:
            m = f["median_offset_px"]
            print(f"  median offset ({m[0]:+.2f}, {m[1]:+.2f}) px, median |offset| "
                  f"{f['median_offset_abs_px']:.2f} px over {f['measured']} fiducial(s); "
                  f"{f['skipped']} skipped")
        else:
            print(f"  no fiducial measured; {f['skipped']} skipped")


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line and status 2, as for any other bad input
        print(f"nvstim_fusion_reference: {message}", file=sys.stderr)
        sys.exit(2)


def main(argv=None):
    ap = _Parser(description=__doc__.split("\n")[0])
    ap.add_argument("--a", nargs=2, metavar=("VIDEO", "META"), required=True,
                    help="channel A (warped into B): .y4m or /dev/videoN, and its JSONL metadata")
    ap.add_argument("--b", nargs=2, metavar=("VIDEO", "META"), required=True,
                    help="channel B (the reference image)")
    ap.add_argument("--rate-a", type=parse_rate_hz, metavar="HZ",
                    help="A's nominal frame rate (e.g. 30000/1001); default: the y4m header, "
                         "else the stamps")
    ap.add_argument("--rate-b", type=parse_rate_hz, metavar="HZ", help="B's, likewise")
    ap.add_argument("--fiducials", metavar="FILE",
                    help='JSON list of {"name", "xyz_m": [x, y, z]} scene points (ENU m)')
    ap.add_argument("--fiducial-mode", choices=("auto", "mean", "pair"), default="auto",
                    help="measure on each channel's mean image (rig at rest) or on every "
                         "matched pair and take the median; auto: mean when the geometry of "
                         "every record is the same")
    ap.add_argument("--fused-dir", metavar="DIR", help="write fused PNGs (and overlays) here")
    ap.add_argument("--fused-max", type=int, default=0, metavar="N",
                    help="at most N fused PNGs (0: one per matched pair)")
    ap.add_argument("--json", metavar="FILE", help="write the summary as JSON")
    ap.add_argument("--frames", type=int, metavar="N",
                    help="from a V4L2 device, capture N frames (default: until the stream stops)")
    args = ap.parse_args(argv)
    try:
        summary, a, b = run(args)
    except BadInput as e:
        print(f"nvstim_fusion_reference: {e}", file=sys.stderr)
        return 2
    print_report(summary, a, b)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(summary, f, indent=1)
            f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
