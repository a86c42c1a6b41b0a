#!/usr/bin/env python3
"""Checks of `nvstim sweep` (docs/sweep.md) against expectations written here by hand, the
frames measured here independently, and `nvstim run` itself.

Usage: check_sweep.py NVSTIM SOURCE_DIR WORK_DIR CASE
  expansion  the manifest of tests/sweep/expansion.toml (--dry-run): count and order as listed
             here; a command spec's placeholders
  local      tests/sweep/grid24.toml with --jobs 2: 24 rows in the grid's order, every job ok,
             the metrics equal to this script's own measurement of the frames of the same
             `nvstim run` made by hand (the scenario's own seed), different seeds different
             frames; leaves WORK_DIR/local for the case slurm
  failure    tests/sweep/failing.toml: the jobs of the missing preset failed with `nvstim
             run`'s status 2 and its message, the others ok, the sweep's status 1
  resume     a finished sweep run again runs nothing; one job's result removed, only that job
             runs again (the others' files untouched); failed jobs run again
  refuse     a non-empty folder that is not a sweep, and a sweep of another grid, are refused
             with status 2 and left byte for byte as they were
Each case removes and rewrites its own folder under WORK_DIR.
"""
import hashlib
import json
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "pylib"))
from netpbm import read_pgm  # noqa: E402

NVSTIM, SOURCE, WORK, CASE = sys.argv[1:5]
TESTS = os.path.join(SOURCE, "tests", "sweep")


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def sweep(*args, check=None):
    p = subprocess.run([NVSTIM, "sweep"] + list(args), capture_output=True, text=True)
    if check is not None and p.returncode != check:
        fail("nvstim sweep %s: status %d, expected %d\nstdout: %s\nstderr: %s" %
             (" ".join(args), p.returncode, check, p.stdout[-2000:], p.stderr[-3000:]))
    return p


def fresh(name):
    d = os.path.join(WORK, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(WORK, exist_ok=True)
    return d


def read_table(d):
    with open(os.path.join(d, "results.json")) as f:
        return json.load(f)


def measure(frames_dir):
    """The metrics of docs/sweep.md, computed here from the PGM files."""
    samples, top, fnv = [], None, 0xcbf29ce484222325
    for name in sorted(os.listdir(frames_dir)):
        a, maxval = read_pgm(os.path.join(frames_dir, name))
        s = [int(v) for v in a.ravel()]
        top = maxval
        for v in s:
            for byte in (v & 0xff, v >> 8):
                fnv = ((fnv ^ byte) * 0x100000001b3) & 0xffffffffffffffff
        samples += s
    n = len(samples)
    mean = sum(samples) / n
    std = (sum((v - mean) ** 2 for v in samples) / n) ** 0.5
    ordered = sorted(samples)
    # the smallest count with at least 99 % of the pixels at or under it
    p99 = next(v for i, v in enumerate(ordered) if (i + 1) * 100 >= 99 * n)
    return {"mean_counts": mean, "std_counts": std, "p99_counts": p99, "adc_top": top,
            "adc_top_fraction": samples.count(top) / n, "frames_fnv": "%016x" % fnv}


def case_expansion():
    out = fresh("expansion")
    p = sweep(os.path.join(TESTS, "expansion.toml"), "--out", out, "--dry-run", check=0)
    jobs = [json.loads(line) for line in p.stdout.splitlines()]
    got = [(j["index"], j["scenario"], j["preset"], j["set"]["width"],
            j["set"]["video.offset_dc"], j["seed"]) for j in jobs]
    # Written out by hand: scenario, preset, width, video.offset_dc, seed; the last fastest.
    expected = []
    for scenario in ["thesis-full-moon", "thesis-new-moon"]:
        for preset in ["pulnix-ag5745ef3", "gen2-s25-p20"]:
            for width in ["64", "32"]:
                for offset in ["20", "26.8"]:
                    for seed in [7, 3]:
                        expected.append((scenario, preset, width, offset, seed))
    expected = [(i,) + e for i, e in enumerate(expected)]
    if len(got) != 32 or got != expected:
        fail("manifest order: got %s, expected %s" % (got[:6], expected[:6]))
    j = jobs[5]  # thesis-full-moon, pulnix, width 32, offset 20, seed 3
    argv = j["argv"]
    want = ["--camera", "pulnix-ag5745ef3", "--set", "width=32", "--set", "video.offset_dc=20"]
    if argv[0] != "run" or argv[2:6] != ["--clock", "sim", "--frames", "1"] or argv[6:12] != want:
        fail("job 5's nvstim run arguments: %s" % argv)
    if not argv[1].endswith("jobs/000005/scenario.toml"):
        fail("a seeded job runs its copy of the scenario: %s" % argv[1])
    if os.path.exists(out):
        fail("--dry-run wrote " + out)
    # A command spec: placeholders, --var over [vars], {{ }} literal.
    spec = os.path.join(WORK, "command.toml")
    with open(spec, "w") as f:
        f.write('name = "cmd"\nkind = "command"\nseeds = 2\n[set]\neffect = ["a", "b+c"]\n'
                '[vars]\nn = 20\n[command]\nargv = ["echo", "{effect}", "{seed}", "{n}", '
                '"{{x}}", "{job_dir}"]\n')
    p = sweep(spec, "--out", os.path.join(WORK, "cmd"), "--var", "n=3", "--dry-run", check=0)
    argvs = [json.loads(line)["argv"] for line in p.stdout.splitlines()]
    if [a[:5] for a in argvs] != [["echo", e, s, "3", "{x}"] for e in ["a", "b+c"]
                                  for s in ["1", "2"]]:
        fail("command placeholders: %s" % argvs)
    if not argvs[3][5].endswith("cmd/jobs/000003"):
        fail("{job_dir}: " + argvs[3][5])
    # An unknown placeholder is a setup error naming it.
    with open(spec, "w") as f:
        f.write('name = "cmd"\nkind = "command"\n[command]\nargv = ["echo", "{nope}"]\n')
    p = sweep(spec, "--out", os.path.join(WORK, "cmd"), "--dry-run", check=2)
    if "{nope}" not in p.stderr:
        fail("unknown placeholder message: " + p.stderr)
    print("expansion: 32 jobs in the expected order; command placeholders expanded")


def case_local():
    out = fresh("local")
    p = sweep(os.path.join(TESTS, "grid24.toml"), "--out", out, "--jobs", "2", check=0)
    if "24/24 done" not in p.stderr or "jobs/s" not in p.stderr:
        fail("no progress line: " + p.stderr[-500:])
    table = read_table(out)
    rows = table["rows"]
    order = [(r["scenario"], r["preset"], r["seed"]) for r in rows]
    expected = [(s, pr, str(seed))
                for s in ["thesis-full-moon", "thesis-new-moon", "../../scenarios/streetlamp-on"]
                for pr in ["pulnix-ag5745ef3", "gen2-s25-p20"] for seed in [1, 2, 3, 4]]
    if order != expected:
        fail("row order: %s" % order[:5])
    bad = [r for r in rows if r["status"] != "ok"]
    if bad:
        fail("jobs failed: %s" % bad[:2])
    with open(os.path.join(out, "results.csv")) as f:
        lines = f.read().splitlines()
    if len(lines) != 25 or not lines[0].startswith("index,scenario,preset,seed,width,height,status"):
        fail("results.csv: %d lines, header %s" % (len(lines), lines[0]))
    # The same run by hand: thesis-full-moon's own seed is 4 (row 3), and this script measures it.
    hand = os.path.join(WORK, "local-hand")
    shutil.rmtree(hand, ignore_errors=True)
    subprocess.run([NVSTIM, "run", os.path.join(SOURCE, "scenarios", "thesis-full-moon"),
                    "--clock", "sim", "--frames", "3", "--camera", "pulnix-ag5745ef3",
                    "--set", "width=64", "--set", "height=48", "--render-threads", "1",
                    "--output", "pgm:" + hand], check=True, capture_output=True)
    mine = measure(hand)
    row = rows[3]
    for k, v in mine.items():
        same = v == row[k] if isinstance(v, str) else abs(v - row[k]) <= 1e-9 * max(1, abs(v))
        if not same:
            fail("%s: the sweep's %s, measured here %s" % (k, row[k], v))
    if row["frames"] != 3 or row["frames_emitted"] != 3:
        fail("frames: %s" % row)
    digests = {r["frames_fnv"] for r in rows}
    if len(digests) != 24:
        fail("%d different frame digests in 24 jobs (seeds must differ)" % len(digests))
    plots = os.listdir(os.path.join(out, "plots"))
    if os.path.exists("/usr/bin/python3") and "mean_counts-vs-scenario.png" not in plots:
        print("note: no plots drawn (python3-matplotlib missing?)")
    print("local: 24 jobs ok in the grid's order; row 3 equals nvstim run measured here "
          "(mean %.4f, p99 %d, fnv %s); %d plots" % (mine["mean_counts"], mine["p99_counts"],
                                                     mine["frames_fnv"], len(plots)))


def case_failure():
    out = fresh("failure")
    p = sweep(os.path.join(TESTS, "failing.toml"), "--out", out, "--jobs", "2", check=1)
    rows = read_table(out)["rows"]
    status = [(r["preset"], r["status"], r.get("exit_status")) for r in rows]
    want = [("pulnix-ag5745ef3", "ok", 0)] * 2 + [("no-such-preset", "failed", 2)] * 2
    if status != want:
        fail("statuses %s, expected %s" % (status, want))
    if "no-such-preset" not in rows[2]["error"]:
        fail("the failed job's error does not carry nvstim run's message: " + rows[2]["error"])
    if "2 ok, 2 failed" not in p.stderr:
        fail("summary line: " + p.stderr[-300:])
    print("failure: 2 jobs failed with status 2 (%s), 2 ok, sweep status 1" % rows[2]["error"][:60])


def snapshot(folder):
    """Every file under folder with its bytes' hash and mtime."""
    out = {}
    for root, _, files in os.walk(folder):
        for name in files:
            path = os.path.join(root, name)
            with open(path, "rb") as f:
                out[os.path.relpath(path, folder)] = (hashlib.sha256(f.read()).hexdigest(),
                                                      os.stat(path).st_mtime_ns)
    return out


def case_resume():
    out = fresh("resume")
    spec = os.path.join(TESTS, "failing.toml")
    sweep(spec, "--out", out, "--jobs", "2", check=1)
    jobs = os.path.join(out, "jobs")
    before = snapshot(jobs)
    # Run again: the two ok jobs are kept, the two failed ones run again.
    p = sweep(spec, "--out", out, "--jobs", "2", check=1)
    if "resuming" not in p.stderr or "2 of 4 jobs done, 2 to run" not in p.stderr:
        fail("resume line: " + p.stderr[-400:])
    after = snapshot(jobs)
    for job in ["000000", "000001"]:
        mine = {k: v for k, v in before.items() if k.startswith(job)}
        if {k: after.get(k) for k in mine} != mine:
            fail("job %s (done) was touched by the resume" % job)
    if after["000002/result.json"] == before["000002/result.json"]:
        fail("job 2 (failed) did not run again")
    # One ok job's result removed: only it runs again.
    os.remove(os.path.join(jobs, "000001", "result.json"))
    before = snapshot(jobs)
    p = sweep(spec, "--out", out, "--jobs", "2", check=1)
    if "1 of 4 jobs done, 3 to run" not in p.stderr:
        fail("resume line: " + p.stderr[-400:])
    after = snapshot(jobs)
    if {k: v for k, v in after.items() if k.startswith("000000")} != \
            {k: v for k, v in before.items() if k.startswith("000000")}:
        fail("job 0 (done) was touched")
    if "000001/result.json" not in after:
        fail("job 1 did not run again")
    print("resume: done jobs untouched, the removed and failed ones run again")


def case_refuse():
    # A folder that is not a sweep.
    d = fresh("refuse")
    os.makedirs(os.path.join(d, "sub"))
    with open(os.path.join(d, "keep.txt"), "w") as f:
        f.write("user data\n")
    with open(os.path.join(d, "sub", "more.txt"), "w") as f:
        f.write("more\n")
    before = snapshot(d)
    p = sweep(os.path.join(TESTS, "failing.toml"), "--out", d, check=2)
    if "not a sweep folder" not in p.stderr:
        fail("message: " + p.stderr)
    if snapshot(d) != before:
        fail("the refused folder changed")
    # A sweep of another grid.
    other = fresh("refuse-other")
    sweep(os.path.join(TESTS, "failing.toml"), "--out", other, "--jobs", "2", check=1)
    before = snapshot(other)
    p = sweep(os.path.join(TESTS, "grid24.toml"), "--out", other, check=2)
    if "another grid" not in p.stderr:
        fail("message: " + p.stderr)
    if snapshot(other) != before:
        fail("the other sweep's folder changed")
    # A file as --out.
    before = snapshot(d)
    sweep(os.path.join(TESTS, "failing.toml"), "--out", os.path.join(d, "keep.txt"), check=2)
    if snapshot(d) != before:
        fail("a file given as --out changed")
    print("refuse: an unrelated folder, another grid's sweep and a file refused, untouched")


{"expansion": case_expansion, "local": case_local, "failure": case_failure,
 "resume": case_resume, "refuse": case_refuse}[CASE]()
