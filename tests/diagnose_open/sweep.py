#!/usr/bin/python3
"""Sweep `nvstim diagnose` over open-world datasets (open_world.py) and tabulate what it names.

    sweep.py --effects a,b,...|all --seeds N --size WxH --frames F --out TABLE.md
             [--json OUT.json] [--jobs J] [--nvstim PATH] [--keep DIR] [--first-seed S]
             [--set KEY=VALUE ...]

For each effect and seed (seeds first-seed .. first-seed + N - 1) it writes the dataset with
open_world.py into a temporary folder (or DIR/EFFECT-sSEED with --keep), runs
`NVSTIM diagnose DATASET --json DATASET.diagnose.json`, reads the findings (docs/diagnose.md
§5: {"baseline", "findings": [{"effect", "parameters", "z", "status", "character", ...}]},
best first) and scores them against the dataset's truth.json. Temporary folders are removed.
Progress (done/total, elapsed, time left) goes to stderr.

Scores, per effect (a finding's "status" absent counts as named; "candidate" is not named;
a missing "z" counts as 0):
  catalog effects (truth family "catalog")
    named        a finding whose effect is the injected one's catalog name, not a candidate;
    top          the first finding is it (and not a candidate);
    parameter    where the injected parameter means what diagnose's does: the named
                 finding's value within 20 % of the truth:
                   halo                 fraction   (share of the light moved to the ring)
                   veiling_glare        fraction   (share of the light moved to the wing)
                   vertical_smear       smear_rel  (column mean's share added)
                   fixed_pattern_noise  prnu_blotch_rel (the blotchy member's rms), else
                                        prnu_rel, against the injected pattern's rms
                   excess_noise         noise_factor / the preset's [mcp] noise_factor against
                                        the injected variance factor of the shot noise (both
                                        ratios of the shot part of the temporal variance)
                   phosphor_persistence weight (share of the light that comes late) where
                                        the finding is the hyperbolic member's (it has
                                        "power"; the exponential member's weight also
                                        holds light of the same frame)
                 nothing is compared for mcp_saturation (hyperbola against the exponential charge
                 limit), bright_source_protection (logistic against a power law) and
                 ebi_background (DC-equivalent light against lm/cm^2 of EBI);
  effects outside the catalog (family "outside")
    catalog z>=5   a catalog effect named (not a candidate) with z >= 5: a false cause;
    unexplained ok a finding with effect "unexplained" whose "character" is the truth's
                   (spatial, level, temporal, geometric);
  null (family "null")
    clean        no catalog effect named (not a candidate), at any z; findings "unexplained"
                 are counted separately.
"""
import argparse
import concurrent.futures
import datetime
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.dont_write_bytecode = True  # nothing written into the source tree
import open_world  # noqa: E402

CATALOG = open_world.CATALOG
# effect: (diagnose's parameter, truth's parameter, truth's divisor key or None)
# The parameter a finding must have for the comparison to mean the same (its member).
COMPARED_MEMBER = {"phosphor_persistence": "power"}
COMPARED = {
    "phosphor_persistence": ("weight", "weight", None),
    "halo": ("fraction", "fraction", None),
    "veiling_glare": ("fraction", "fraction", None),
    "vertical_smear": ("smear_rel", "smear_rel", None),
    "fixed_pattern_noise": (("prnu_blotch_rel", "prnu_rel"), "prnu_rel", None),
    "excess_noise": ("noise_factor", "variance_factor", "model_noise_factor"),
}


def status(f):
    return f.get("status") or "named"


def z_of(f):
    try:
        return float(f.get("z", 0.0))
    except (TypeError, ValueError):
        return 0.0


def param(f, name):
    """A finding's parameter: "parameters" as an object or a list of {name, value}."""
    p = f.get("parameters")
    if isinstance(p, dict):
        v = p.get(name)
        if isinstance(v, dict):
            v = v.get("value")
        return v if isinstance(v, (int, float)) else None
    if isinstance(p, list):
        for e in p:
            if isinstance(e, dict) and e.get("name") == name and \
                    isinstance(e.get("value"), (int, float)):
                return e["value"]
    return None


def score(truth, findings):
    """The dataset's scores (module docstring)."""
    fam, cat = truth["family"], truth.get("catalog_name")
    named_catalog = [f for f in findings if f.get("effect") in CATALOG and status(f) != "candidate"]
    unexplained = [f for f in findings if f.get("effect") == "unexplained"]
    s = {"named_catalog": [f["effect"] for f in named_catalog],
         "unexplained_characters": [f.get("character") for f in unexplained]}
    if fam == "catalog":
        mine = [f for f in named_catalog if f["effect"] == cat]
        s["named"] = bool(mine)
        s["top"] = bool(findings) and findings[0].get("effect") == cat and \
            status(findings[0]) != "candidate"
        s["candidate"] = any(f.get("effect") == cat and status(f) == "candidate" for f in findings)
        member = COMPARED_MEMBER.get(cat)
        if cat in COMPARED and mine and (member is None or param(mine[0], member) is not None):
            dk, tk, div = COMPARED[cat]
            # The first of diagnose's names the finding has (a member's own parameter first).
            v = None
            for k in (dk if isinstance(dk, tuple) else (dk,)):
                v = param(mine[0], k)
                if v is not None:
                    break
            t = truth["parameters"].get(tk)
            if v is not None and t:
                if div:
                    v = v / truth["parameters"][div]
                s["param_ratio"] = v / t
                s["param_ok"] = abs(v / t - 1.0) <= 0.2
    elif fam == "outside":
        s["catalog_z5"] = [f["effect"] for f in named_catalog if z_of(f) >= 5.0]
        s["unexplained_ok"] = any(f.get("character") == truth["character"] for f in unexplained)
    else:
        s["clean"] = not named_catalog
    return s


def run_one(job, a, root):
    effect, seed = job
    d = os.path.join(root, "%s-s%03d" % (effect, seed))
    t0 = time.time()
    rec = {"effect": effect, "seed": seed}
    try:
        if os.path.exists(d):
            if not os.path.exists(os.path.join(d, "truth.json")):
                raise RuntimeError("%s exists and is not an open_world.py dataset" % d)
            shutil.rmtree(d)
        cmd = [sys.executable, os.path.join(HERE, "open_world.py"), "--effect", effect,
               "--seed", str(seed), "--out", d, "--size", a.size, "--frames", str(a.frames),
               "--nvstim", a.nvstim]
        for kv in a.set:
            cmd += ["--set", kv]
        r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            raise RuntimeError("open_world.py: " + r.stderr.strip()[-400:])
        with open(os.path.join(d, "truth.json")) as f:
            truth = json.load(f)
        out = d + ".diagnose.json"  # diagnose writes nothing inside its input folder
        r = subprocess.run([a.nvstim, "diagnose", d, "--json", out], stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            raise RuntimeError("diagnose exit %d: %s" % (r.returncode, r.stderr.strip()[-400:]))
        with open(out) as f:
            diag = json.load(f)
        findings = diag.get("findings") or []
        p = dict(truth["parameters"])
        for k in ("gains", "shifts_px", "frame_gains"):
            p.pop(k, None)  # per-frame lists stay in truth.json
        rec.update({"family": truth["family"], "character": truth["character"],
                    "catalog_name": truth.get("catalog_name"), "truth_parameters": p,
                    "camera_settings": truth.get("settings"),
                    "findings": [{k: f[k] for k in ("effect", "status", "structure", "character",
                                                     "z", "score", "parameters", "cause") if k in f}
                                 for f in findings],
                    "baseline": diag.get("baseline"), "scores": score(truth, findings)})
    except Exception as e:  # a failed dataset is reported, the sweep goes on
        rec["error"] = str(e)
    finally:
        if not a.keep:
            shutil.rmtree(d, ignore_errors=True)
            if os.path.exists(d + ".diagnose.json"):
                os.remove(d + ".diagnose.json")
    rec["seconds"] = round(time.time() - t0, 1)
    return rec


def fmt_findings(rec):
    if "error" in rec:
        return "error: " + rec["error"].replace("|", "/").replace("\n", " ")[:120]
    parts = []
    for f in rec["findings"]:
        tag = f.get("effect") or "?"
        extra = [x for x in (f.get("character") if tag == "unexplained" else None,
                             f.get("status") if f.get("status") not in (None, "named") else None)
                 if x]
        if extra:
            tag += "[" + ",".join(extra) + "]"
        parts.append("%s z %.1f" % (tag, z_of(f)))
    return ", ".join(parts) or "none"


def frac(n, d):
    return "%d/%d" % (n, d)


def counts(names):
    c = {}
    for n in names:
        c[n] = c.get(n, 0) + 1
    return ", ".join("%s %d" % kv for kv in sorted(c.items(), key=lambda kv: -kv[1])) or "-"


def table(a, recs, elapsed):
    by = {}
    for r in recs:
        by.setdefault(r["effect"], []).append(r)
    L = ["# diagnose in an open world", "",
         "`%s`" % " ".join(["tests/diagnose_open/sweep.py"] + sys.argv[1:]), "",
         "%s; %s; %s, %d frames, seeds %d..%d; %.0f s." % (
             datetime.datetime.now().strftime("%Y-%m-%d %H:%M"), a.nvstim, a.size, a.frames,
             a.first_seed, a.first_seed + a.seeds - 1, elapsed)]
    if a.set:
        L.append("Camera settings: %s." % ", ".join("`%s`" % s for s in a.set))
    L += ["", "Scores as defined in tests/diagnose_open/sweep.py's docstring; `failed` counts "
          "datasets where generation or diagnose failed (not scored).", ""]
    cats = [e for e in by if open_world.EFFECTS[e][0] == "catalog"]
    outs = [e for e in by if open_world.EFFECTS[e][0] == "outside"]
    nulls = [e for e in by if open_world.EFFECTS[e][0] == "null"]
    if cats:
        L += ["## Catalog effects (other shapes)", "",
              "| effect | seeds | failed | named | top finding is it | as candidate | compared | "
              "within 20 % | ratio median (range) | other catalog effects named |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for e in cats:
            rs = [r for r in by[e] if "error" not in r]
            sc = [r["scores"] for r in rs]
            ratios = [s["param_ratio"] for s in sc if "param_ratio" in s]
            comp = COMPARED[e][0] if e in COMPARED else "-"
            if isinstance(comp, tuple):
                comp = " or ".join(comp)
            if e == "excess_noise":
                comp = "noise_factor / F_model"
            L.append("| %s | %d | %d | %s | %s | %s | %s | %s | %s | %s |" % (
                e, len(by[e]), len(by[e]) - len(rs), frac(sum(s["named"] for s in sc), len(rs)),
                frac(sum(s["top"] for s in sc), len(rs)),
                frac(sum(s["candidate"] for s in sc), len(rs)), comp,
                frac(sum(s.get("param_ok", False) for s in sc), sum(s["named"] for s in sc))
                if e in COMPARED else "-",
                "%.2f (%.2f-%.2f)" % (statistics.median(ratios), min(ratios), max(ratios))
                if ratios else "-",
                counts([n for s in sc for n in s["named_catalog"] if n != e])))
        L.append("")
    if outs:
        L += ["## Effects outside the catalog", "",
              "| effect | character | seeds | failed | catalog named z >= 5 | which | "
              "unexplained, right character | unexplained characters seen |",
              "|---|---|---|---|---|---|---|---|"]
        for e in outs:
            rs = [r for r in by[e] if "error" not in r]
            sc = [r["scores"] for r in rs]
            L.append("| %s | %s | %d | %d | %s | %s | %s | %s |" % (
                e, open_world.EFFECTS[e][1], len(by[e]), len(by[e]) - len(rs),
                frac(sum(bool(s["catalog_z5"]) for s in sc), len(rs)),
                counts([n for s in sc for n in s["catalog_z5"]]),
                frac(sum(s["unexplained_ok"] for s in sc), len(rs)),
                counts([c or "?" for s in sc for c in s["unexplained_characters"]])))
        L.append("")
    if nulls:
        L += ["## Null", "", "| effect | seeds | failed | clean | catalog effects named | "
              "unexplained findings |", "|---|---|---|---|---|---|"]
        for e in nulls:
            rs = [r for r in by[e] if "error" not in r]
            sc = [r["scores"] for r in rs]
            L.append("| %s | %d | %d | %s | %s | %s |" % (
                e, len(by[e]), len(by[e]) - len(rs), frac(sum(s["clean"] for s in sc), len(rs)),
                counts([n for s in sc for n in s["named_catalog"]]),
                counts([c or "?" for s in sc for c in s["unexplained_characters"]])))
        L.append("")
    L += ["## Every dataset", "", "| effect | seed | findings (best first) | truth | s |",
          "|---|---|---|---|---|"]
    for r in recs:
        tp = r.get("truth_parameters") or {}
        tp = ", ".join("%s %.3g" % (k, v) for k, v in tp.items()
                       if isinstance(v, (int, float)) and not isinstance(v, bool))
        L.append("| %s | %d | %s | %s | %.0f |" % (r["effect"], r["seed"], fmt_findings(r), tp,
                                                   r["seconds"]))
    return "\n".join(L) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--effects", required=True, help="comma-separated names, or all")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--size", default="768x494")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--out", required=True, help="Markdown table")
    ap.add_argument("--json")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--nvstim",
                    default=os.path.join(REPO, "build", "release", "rt", "cli", "nvstim"))
    ap.add_argument("--keep", help="keep the datasets (and their .diagnose.json) in this folder")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="camera setting passed to open_world.py (repeatable)")
    a = ap.parse_args()
    effects = list(open_world.EFFECTS) if a.effects == "all" else a.effects.split(",")
    bad = [e for e in effects if e not in open_world.EFFECTS]
    if bad:
        ap.error("unknown effect(s) %s (open_world.py --list)" % ", ".join(bad))
    a.nvstim = os.path.abspath(a.nvstim)
    if not os.access(a.nvstim, os.X_OK):
        ap.error("no nvstim at %s" % a.nvstim)
    jobs = [(e, a.first_seed + i) for e in effects for i in range(a.seeds)]
    root = os.path.abspath(a.keep) if a.keep else tempfile.mkdtemp(prefix="diagnose_open_")
    os.makedirs(root, exist_ok=True)
    t0, done, lock, recs = time.time(), [0], threading.Lock(), {}
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
            futs = {ex.submit(run_one, j, a, root): j for j in jobs}
            for fu in concurrent.futures.as_completed(futs):
                rec = fu.result()
                with lock:
                    recs[futs[fu]] = rec
                    done[0] += 1
                    el = time.time() - t0
                    left = el / done[0] * (len(jobs) - done[0])
                    sys.stderr.write("sweep: [%d/%d] %s seed %d: %s (%.0f s; elapsed %.0f s, "
                                     "about %.0f s left)\n" % (done[0], len(jobs), rec["effect"],
                                                               rec["seed"], fmt_findings(rec),
                                                               rec["seconds"], el, left))
    finally:
        if not a.keep:
            shutil.rmtree(root, ignore_errors=True)
    ordered = [recs[j] for j in jobs if j in recs]
    with open(a.out, "w") as f:
        f.write(table(a, ordered, time.time() - t0))
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"command": sys.argv, "nvstim": a.nvstim, "size": a.size,
                       "frames": a.frames, "settings": a.set, "datasets": ordered}, f, indent=1)
            f.write("\n")
    return 1 if any("error" in r for r in ordered) else 0


if __name__ == "__main__":
    sys.exit(main())
