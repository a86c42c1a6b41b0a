#!/usr/bin/env python3
"""Writes the seeds of the `dataset` fuzz target (tests/fuzz/fuzz_targets.cpp, `dataset`):
one valid 8x8 dataset of 8 frames and the hostile cases of issue 27, each as one input whose
parts (dataset.toml, then frame and radiance files) are separated by a line "%%".

Usage: make_corpus.py [DIR]   (default: the corpus folder beside this script)
"""
import os
import struct
import sys
import zlib

SEP = b"\n%%\n"
W = H = 8

TOML = """[camera]
preset = "pulnix-ag5745ef3"
[camera.settings]
width = 8
height = 8
{settings}
[stimulus]
radiance = "radiance/000000.pfm"
unit = "pe/s/m2/sr"
[output]
frames = "frames/{{frame:06d}}.{ext}"
{count}
{extra}"""


def toml(settings="", ext="pgm", count="count = 8", extra=""):
    return TOML.format(settings=settings, ext=ext, count=count, extra=extra).encode()


def pgm(k, maxv=255, value=None):
    wide = maxv > 255
    px = b""
    for y in range(H):
        for x in range(W):
            v = value if value is not None else (20 + 3 * x + 5 * y + 7 * k) % (maxv + 1)
            px += struct.pack(">H", v) if wide else bytes([v])
    return b"P5\n%d %d\n%d\n" % (W, H, maxv) + px


def pfm():
    return b"Pf\n%d %d\n-1.0\n" % (W, H) + struct.pack("<%df" % (W * H), *([2.0e9] * (W * H)))


def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png16(k, interlace):
    ihdr = struct.pack(">IIBBBBB", W, H, 16, 0, 0, 0, 1 if interlace else 0)
    rows = []
    if not interlace:
        for y in range(H):
            rows.append(b"\0" + b"".join(struct.pack(">H", 1000 * y + 37 * x + k) for x in range(W)))
    else:
        # Adam7 passes of an 8x8 image: (x0, y0, dx, dy)
        for x0, y0, dx, dy in [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4),
                               (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2)]:
            for y in range(y0, H, dy):
                xs = range(x0, W, dx)
                if not list(xs):
                    continue
                rows.append(b"\0" + b"".join(struct.pack(">H", 1000 * y + 37 * x + k) for x in xs))
    idat = zlib.compress(b"".join(rows))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def forged_png(side):
    ihdr = struct.pack(">IIBBBBB", side, side, 16, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) +
            chunk(b"IDAT", b"\x78\x9c\x03\x00\x00\x00\x00\x01") + chunk(b"IEND", b""))


def dataset(t, frames, radiance=True):
    parts = [t] + frames + ([pfm()] if radiance else [])
    return SEP.join(parts)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "corpus")
    os.makedirs(out, exist_ok=True)
    frames = [pgm(k) for k in range(8)]
    seeds = {
        "valid": dataset(toml(), frames),
        "valid_png16": dataset(toml(ext="png"), [png16(k, False) for k in range(8)]),
        "adam7_png16": dataset(toml(ext="png"), [png16(k, True) for k in range(8)]),
        "roi": dataset(toml(extra='[[roi]]\nname = "a"\nx = 1\ny = 1\nw = 4\nh = 4\n'), frames),
        "settings_quote": dataset(toml(settings='"name" = "a \\"quoted\\" \\\\ name"'), frames),
        "preset_dev_zero": dataset(toml().replace(b'"pulnix-ag5745ef3"', b'"/dev/zero"'), frames),
        "count_huge": dataset(toml(count="count = 1000000000000"), frames),
        "count_negative": dataset(toml(count="count = -5"), frames),
        "name_24_digits": dataset(
            toml(count="").replace(b'frames = "frames/{frame:06d}.pgm"',
                                   b'frames = ["frames/123456789012345678901234.pgm"]'), frames),
        "roi_overflow": dataset(
            toml(extra='[[roi]]\nname = "w"\nx = 2147483647\ny = 0\nw = 10\nh = 4\n'), frames),
        "png_16384": dataset(toml(ext="png"), [forged_png(16384)] * 8),
        "png_30000": dataset(toml(ext="png"), [forged_png(30000)] * 8),
        "mixed_depth": dataset(toml(), frames[:4] + [pgm(4, 65535)] + frames[5:]),
        "maxval_1000": dataset(toml(), [pgm(k, 1000) for k in range(8)]),
        "six_frames": dataset(toml(count="count = 6"), frames[:6]),
        "six_frames_no_count": dataset(toml(count=""), frames[:6]),
        "all_dark": dataset(toml(), [pgm(k, 255, 0) for k in range(8)]),
        "all_clipped": dataset(toml(), [pgm(k, 255, 255) for k in range(8)]),
        "truncated_frame": dataset(toml(), frames[:3] + [frames[3][:20]] + frames[4:]),
        "empty": b"",
    }
    for name, data in seeds.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
