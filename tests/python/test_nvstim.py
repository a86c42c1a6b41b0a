"""The Python module `nvstim` (docs/python.md) against the command line it shares its code with,
run on the same inputs: nothing here is computed by the module alone.

  frames    nvstim.Run's counts equal the y4m payload of `nvstim run ... --output y4m:F`
            (an 8-bit camera: the same bytes; 12 bits: the y4m's 16-bit samples shifted down),
            its meta dicts the lines of `--output meta:F.jsonl`
  no copy   a frame's array views the frame's own buffer: its base is the capsule that owns
            it, it does not own its data, and the data stay valid after the Run is gone
  camera    nvstim.camera on a numpy radiance equals `nvstim sensor` on the same image
            written as PFM (8 and 12 bits, pe/s/m2/sr and W/m2/sr)
  diagnose  nvstim.diagnose equals `nvstim diagnose DATASET --json OUT` on a dataset made by
            `nvstim sensor` here
  errors    a bad scenario, preset key or dataset raises nvstim.SetupError with the line the
            command line prints after "nvstim: " (exit status 2)

Environment (tests/python/CMakeLists.txt): PYTHONPATH the module's build folder, NVSTIM the
command line, NVS_SOURCE_DIR the source tree, NVS_CONFIG_DIR its config/.
"""
import gc
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import nvstim

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "pylib"))
from netpbm import read_pgm  # noqa: E402

NVSTIM = os.environ["NVSTIM"]
SOURCE = os.environ["NVS_SOURCE_DIR"]
# A rendered scene, shrunk: the RIT roof under the Moon, 96 x 64, 3 frames.
SCENARIO = os.path.join(SOURCE, "scenarios", "thesis-nolight")
SMALL = {"width": "96", "height": "64"}
PRESET = "pulnix-ag5745ef3"


def cli(*args, check=True):
    """Runs the command line; (status, stdout, stderr)."""
    r = subprocess.run([NVSTIM, *args], capture_output=True, text=True, timeout=120)
    if check and r.returncode != 0:
        raise AssertionError(f"nvstim {' '.join(args)}: status {r.returncode}\n{r.stderr}")
    return r.returncode, r.stdout, r.stderr


def sets_args(sets):
    out = []
    for k, v in sets.items():
        out += ["--set", f"{k}={v}"]
    return out


def read_y4m(path):
    """(header tags, [frame payload bytes]) of a YUV4MPEG2 file (mjpegtools yuv4mpeg(5))."""
    data = open(path, "rb").read()
    end = data.index(b"\n")
    tags = data[:end].split(b" ")
    assert tags[0] == b"YUV4MPEG2"
    header = {t[:1].decode(): t[1:].decode() for t in tags[1:]}
    w, h = int(header["W"]), int(header["H"])
    size = w * h * (2 if header["C"] == "mono16" else 1)
    frames, pos = [], end + 1
    while pos < len(data):
        line_end = data.index(b"\n", pos)
        assert data[pos:line_end].startswith(b"FRAME")
        pos = line_end + 1
        frames.append(data[pos:pos + size])
        pos += size
    return header, frames


def write_pfm(path, image):
    """A grey PFM: little-endian (negative scale), rows bottom to top."""
    image = np.asarray(image, dtype="<f4")
    h, w = image.shape
    with open(path, "wb") as f:
        f.write(f"Pf\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(image[::-1]).tobytes())


def python_frames(scenario, frames, sets, **kw):
    with nvstim.Run(scenario, clock="sim", frames=frames, set=sets, **kw) as run:
        fmt = (run.width, run.height, run.bits, run.frame_rate_hz, run.field_order, run.frames)
        got = [(f.counts, f.meta, f.index, f.t_sample_s) for f in run]
        status = run.close()
    return fmt, got, status


# ---- frames and metadata ------------------------------------------------------------------------

@pytest.mark.parametrize("bits", [8, 12])
def test_frames_and_meta_equal_the_command_lines_y4m_and_meta(tmp_path, bits):
    sets = dict(SMALL, **({"video.adc_bits": str(bits)} if bits != 8 else {}))
    y4m, meta = tmp_path / "run.y4m", tmp_path / "run.jsonl"
    cli("run", SCENARIO, "--clock", "sim", "--frames", "3", *sets_args(sets),
        "--output", f"y4m:{y4m}", "--output", f"meta:{meta}")
    header, payloads = read_y4m(y4m)
    records = [json.loads(line) for line in open(meta)]

    (w, h, b, rate, order, n), got, status = python_frames(SCENARIO, 3, sets)
    assert status == 0
    assert (w, h, b, n) == (96, 64, bits, 3)
    assert (int(header["W"]), int(header["H"])) == (w, h)
    num, den = (int(x) for x in header["F"].split(":"))
    assert rate == pytest.approx(num / den, rel=1e-9)
    assert header["I"] == {"progressive": "p", "top": "t", "bottom": "b"}[order]
    assert len(got) == len(payloads) == len(records) == 3
    for k, (counts, m, index, t_sample_s) in enumerate(got):
        assert counts.shape == (h, w)
        if bits <= 8:
            # Cmono: one byte per pixel, the counts themselves at 8 bits.
            assert header["C"] == "mono"
            assert counts.dtype == np.uint8
            assert counts.tobytes() == payloads[k]
        else:
            # Cmono16: little-endian, the counts scaled to 16 bits (drivers/sinks/sinks.h).
            assert header["C"] == "mono16"
            assert counts.dtype == np.uint16
            y4m16 = np.frombuffer(payloads[k], dtype="<u2").reshape(h, w)
            assert np.array_equal(y4m16 & ((1 << (16 - bits)) - 1), np.zeros_like(y4m16))
            assert np.array_equal(counts, y4m16 >> (16 - bits))
            assert counts.max() < (1 << bits)
        assert m == records[k]
        assert index == m["frame"] == k
        assert t_sample_s == pytest.approx(m["t_sample_s"], abs=1e-9)  # printed with %.9f
    # Not all one value: a rendered scene.
    assert len(np.unique(got[-1][0])) > 10


def test_the_format_is_the_scenarios():
    with nvstim.Run(SCENARIO, frames=1) as run:
        assert (run.width, run.height, run.bits) == (768, 494, 8)
        assert run.frame_rate_hz == pytest.approx(30000 / 1001)
        assert run.name == "thesis-nolight"
        assert run.exit_status is None
    # Closed before its frame was taken: stopped (8), or ended by itself had the frame reached
    # the ring first (0); never failed.
    assert run.exit_status in (0, 8)


# ---- no copy ------------------------------------------------------------------------------------

def test_counts_view_the_frames_buffer_and_outlive_the_run():
    run = nvstim.Run(SCENARIO, frames=2, set=SMALL)
    frames = list(run)
    a, b = frames[0].counts, frames[1].counts
    for c in (a, b):
        assert c.base is not None
        assert type(c.base).__name__ == "PyCapsule"
        assert not c.flags.owndata
        assert c.flags.c_contiguous
    # Two frames, two buffers.
    assert a.__array_interface__["data"][0] != b.__array_interface__["data"][0]
    before = a.__array_interface__["data"][0]
    kept = a.copy()
    run.close()
    del run, frames
    gc.collect()
    # The Run is gone and the ring reused its slots; the array's buffer is its own.
    assert a.__array_interface__["data"][0] == before
    assert np.array_equal(a, kept)
    with nvstim.Run(SCENARIO, frames=2, set=SMALL) as again:
        for f in again:
            f.counts[:] = 0
    assert np.array_equal(a, kept)


# ---- camera ------------------------------------------------------------------------------------

def radiance_image(w, h):
    """A ramp, a bright disc and a dark bar [pe s^-1 m^-2 sr^-1], around half the 8-bit range of
    the preset at its own gain (tests/diagnose_open/open_world.py: 4.9e13 is the ADC's top)."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    img = 2.0e12 + 2.0e13 * x / (w - 1)
    img[(x - w * 0.3) ** 2 + (y - h * 0.5) ** 2 < (h * 0.2) ** 2] = 4.0e13
    img[:, int(w * 0.7):int(w * 0.75)] = 0.0
    return img.astype(np.float32)


@pytest.mark.parametrize("bits,unit,spectrum", [(8, "pe/s/m2/sr", None),
                                                (12, "W/m2/sr", "moon")])
def test_camera_equals_nvstim_sensor(tmp_path, bits, unit, spectrum):
    w, h, frames, seed = 80, 48, 3, 7
    img = radiance_image(w, h)
    if unit == "W/m2/sr":
        # Band radiance giving about the same photoelectron rate (the moon's factor).
        img = img * np.float32(2.0e-19)
    sets = {"width": w, "height": h}
    if bits != 8:
        sets["video.adc_bits"] = bits
    write_pfm(tmp_path / "in.pfm", img)
    args = ["sensor", "--in", str(tmp_path / "in.pfm"), "--camera", PRESET, *sets_args(sets),
            "--frames", str(frames), "--seed", str(seed), "--unit", unit,
            "--out", str(tmp_path / "out{frame:06d}.pgm")]
    if spectrum:
        args += ["--spectrum", spectrum]
    cli(*args)
    got = nvstim.camera(img, PRESET, set=sets, frames=frames, seed=seed, unit=unit,
                        spectrum=spectrum)
    assert got.shape == (frames, h, w)
    assert got.dtype == (np.uint8 if bits <= 8 else np.uint16)
    assert not got.flags.owndata and got.base is not None
    for k in range(frames):
        pgm, maxval = read_pgm(tmp_path / f"out{k:06d}.pgm")
        assert maxval == (1 << bits) - 1
        assert np.array_equal(got[k], pgm), f"frame {k}"
    # Signal, not a flat or clipped frame.
    assert 5 < got[-1].mean() < 0.9 * ((1 << bits) - 1)
    # One image per frame gives the same as one held.
    per_frame = nvstim.camera(np.stack([img] * frames), PRESET, set=sets, seed=seed, unit=unit,
                              spectrum=spectrum)
    assert np.array_equal(per_frame, got)


def test_camera_refuses_what_the_sensor_refuses(tmp_path):
    img = radiance_image(80, 48)
    with pytest.raises(nvstim.SetupError, match="camera 'pulnix-ag5745ef3' expects 768x494"):
        nvstim.camera(img, PRESET)
    bad = img.copy()
    bad[3, 5] = np.nan
    with pytest.raises(nvstim.SetupError, match=r"pixel \(5, 3\).*finite and >= 0"):
        nvstim.camera(bad, PRESET, set={"width": 80, "height": 48})
    # A bad preset key: the command line's message.
    write_pfm(tmp_path / "in.pfm", img)
    status, _, err = cli("sensor", "--in", str(tmp_path / "in.pfm"), "--camera", PRESET,
                         "--set", "width=80", "--set", "height=48", "--set", "mcp.nosie=1",
                         "--out", str(tmp_path / "o.pgm"), check=False)
    assert status == 2
    with pytest.raises(nvstim.SetupError) as e:
        nvstim.camera(img, PRESET, set={"width": 80, "height": 48, "mcp.nosie": 1})
    assert err == f"nvstim: {e.value}\n"


# ---- diagnose ------------------------------------------------------------------------------------

def make_dataset(root):
    """A measured dataset (docs/contracts.md, "Measured dataset"): 12 frames of the preset at
    96 x 64 made by `nvstim sensor` from 3 radiance images, each held for 4 frames. The dataset
    names the preset without its halo (the camera that made the frames has it), so that diagnose
    has something to look for."""
    ds = root / "dataset"
    (ds / "radiance").mkdir(parents=True)
    (ds / "frames").mkdir()
    w, h = 96, 64
    base = radiance_image(w, h)
    for k, scale in enumerate([0.4, 1.0, 1.6]):
        write_pfm(ds / "radiance" / f"{k:06d}.pfm", base * np.float32(scale))
    seen = root / "seen"
    seen.mkdir()
    for n in range(12):
        write_pfm(seen / f"{n:06d}.pfm", base * np.float32([0.4, 1.0, 1.6][n // 4]))
    cli("sensor", "--in", str(seen / "{frame:06d}.pfm"), "--camera", PRESET,
        "--set", f"width={w}", "--set", f"height={h}", "--seed", "4242",
        "--out", str(ds / "frames" / "{frame:06d}.pgm"))
    (ds / "dataset.toml").write_text(
        f'[camera]\npreset = "{PRESET}"\n[camera.settings]\nwidth = {w}\nheight = {h}\n'
        '"halo.enabled" = false\n'
        '[stimulus]\nradiance = "radiance/{frame:06d}.pfm"\nunit = "pe/s/m2/sr"\n'
        "index = [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2]\n"
        '[output]\nframes = "frames/{frame:06d}.pgm"\n')
    return ds


def test_diagnose_equals_the_command_lines_json(tmp_path):
    ds = make_dataset(tmp_path)
    out = tmp_path / "findings.json"
    _, stdout, _ = cli("diagnose", str(ds), "--json", str(out), "--seed", "3")
    lines = []
    got = nvstim.diagnose(str(ds), seed=3, progress=lines.append)
    assert got == json.loads(out.read_text()) == json.loads(stdout)
    assert "baseline" in got and "findings" in got
    assert lines and all(isinstance(line, str) for line in lines)


def test_diagnose_refuses_a_bad_dataset_as_the_command_line(tmp_path):
    for path in [tmp_path / "missing", tmp_path]:  # no folder; a folder without dataset.toml
        status, _, err = cli("diagnose", str(path), check=False)
        assert status == 2
        with pytest.raises(nvstim.SetupError) as e:
            nvstim.diagnose(str(path))
        assert err.splitlines()[-1] == f"nvstim: {e.value}"


# ---- errors ----------------------------------------------------------------------------------------

def test_a_bad_scenario_raises_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[scenario]\nname = "bad"\nframe_rat_hz = 30\n')
    cases = [
        (str(bad), {}),                                     # an unknown key, file:line
        (str(tmp_path / "nowhere"), {}),                    # no such scenario
        (SCENARIO, {"mcp.nosie": "1"}),                     # an unknown preset key
        (SCENARIO, {"width": "-3"}),                        # a bad value
    ]
    for scenario, sets in cases:
        status, _, err = cli("run", scenario, "--clock", "sim", "--frames", "1",
                             *sets_args(sets), "--output", f"y4m:{tmp_path / 'x.y4m'}",
                             check=False)
        assert status == 2, err
        with pytest.raises(nvstim.SetupError) as e:
            nvstim.Run(scenario, frames=1, set=sets)
        assert isinstance(e.value, ValueError)
        assert err == f"nvstim: {e.value}\n", (scenario, sets)


def test_data_folders_follow_the_environment_and_the_arguments():
    assert nvstim.data_dirs()["config"] == os.environ["NVS_CONFIG_DIR"]
    assert nvstim.data_dirs(config_dir="/elsewhere")["config"] == "/elsewhere"
    assert nvstim.data_dirs(cache_dir="/c")["cache"] == "/c"
    # A preset looked up in a config folder without it: the folder given is the one used.
    with pytest.raises(nvstim.SetupError, match="/nonexistent-config"):
        nvstim.camera(radiance_image(8, 8), PRESET, config_dir="/nonexistent-config")


def test_channel_of_a_scenario_with_one_camera_is_refused():
    with pytest.raises(nvstim.SetupError, match="channel 'left': the scenario has one camera"):
        nvstim.Run(SCENARIO, frames=1, channel="left")
