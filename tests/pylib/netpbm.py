"""The test scripts' one reader of binary PGM (P5) files, netpbm pgm(5): header fields separated
by whitespace, comments from '#' to the end of a line, exactly one whitespace byte before the
samples, 16-bit big-endian samples above maxval 255."""
import numpy as np


def read_pgm(path):
    """(samples as an h x w array, uint8 or uint16, maxval)."""
    with open(path, "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos)
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    pos += 1
    if fields[0] != b"P5":
        raise ValueError(f"{path}: not a binary PGM (P5)")
    w, h, maxval = int(fields[1]), int(fields[2]), int(fields[3])
    dtype = np.dtype("u1") if maxval < 256 else np.dtype(">u2")
    a = np.frombuffer(data, dtype=dtype, count=w * h, offset=pos).reshape(h, w)
    return a.astype(np.uint16 if maxval > 255 else np.uint8), maxval
