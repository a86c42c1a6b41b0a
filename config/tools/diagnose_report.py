#!/usr/bin/env python3
"""Draws the report of `nvstim diagnose --report DIR` (docs/diagnose.md, "Report").

Reads DIR/report.json and the residual maps DIR/*.pfm that nvstim wrote, draws every curve and
map as PNG with Matplotlib (Debian python3-matplotlib, Agg backend, no display needed) and
writes DIR/report.md: the baseline, the findings with their causes and fitted parameters, the
held-out gain, every effect that was tried and why it was or was not taken, and the plots.

Usage: diagnose_report.py DIR
"""
import json
import os
import struct
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_pfm(path):
    """A greyscale PFM as a list of rows, top row first (PFM stores the bottom row first)."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"Pf":
            raise ValueError(path + ": not a greyscale PFM")
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        fmt = "<" if scale < 0 else ">"
        data = struct.unpack(fmt + "%df" % (w * h), f.read(4 * w * h))
    rows = [list(data[y * w:(y + 1) * w]) for y in range(h)]
    rows.reverse()
    return rows


def plot_curve(curve, out):
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    # Photon transfer is one point per tile: every series as markers; the others as lines.
    styles = ["o", "x", "+", "."] if curve["name"] == "photon_transfer" else ["o", "-", "--", ":"]
    for i, s in enumerate(curve["series"]):
        st = styles[i % len(styles)]
        if st in ("o", "x", "+", "."):
            ax.plot(s["x"], s["y"], st, ms=4, label=s["name"])
        else:
            ax.plot(s["x"], s["y"], st, lw=1.5, label=s["name"])
    ax.set_xlabel(curve["x_label"])
    ax.set_ylabel(curve["y_label"])
    ax.set_title(curve["name"].replace("_", " "))
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def plot_map(name, rows, out):
    # A gain map (an unexplained smooth gain) is centred on 1, a residual map on 0.
    gain = name == "unexplained_smooth_gain"
    centre = 1.0 if gain else 0.0
    flat = sorted(v - centre for r in rows for v in r)
    lim = max(abs(flat[int(0.01 * (len(flat) - 1))]), abs(flat[int(0.99 * (len(flat) - 1))]), 1e-6)
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100)
    im = ax.imshow(rows, cmap="RdBu_r", vmin=centre - lim, vmax=centre + lim,
                   interpolation="nearest")
    fig.colorbar(im, ax=ax, label="gain relative to the model" if gain else "measured - model [DC]")
    ax.set_title(name.replace("_", " "))
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def fmt(v):
    return "%.4g" % v if isinstance(v, float) else str(v)


def compare_section(c, d, png, title_a="A", title_b="B"):
    """Markdown and a bar plot of one comparison (nvstim diagnose --compare)."""
    a, b = c["a"], c["b"]
    md = ["| | %s: `%s` | %s: `%s` |" % (title_a, a["preset"], title_b, b["preset"]),
          "|---|---|---|",
          "| held-out RMS [DC] | %s | %s |" % (fmt(a["heldout_rms_dc"]), fmt(b["heldout_rms_dc"])),
          "| log-likelihood per pixel [nats] | %s | %s |" % (
              fmt(a["log_likelihood_per_pixel"]), fmt(b["log_likelihood_per_pixel"])),
          "| gain, offset [DC], extra blur [px] | %s, %s, %s | %s, %s, %s |" % (
              fmt(a["gain_rel"]), fmt(a["offset_dc"]), fmt(a["mtf_extra_blur_px"]),
              fmt(b["gain_rel"]), fmt(b["offset_dc"]), fmt(b["mtf_extra_blur_px"])),
          "",
          "Paired test over tiles of %s's squared error against %s's: z = %.1f (> 0: %s predicts "
          "the held-out frames better); %d held-out pixels." % (
              title_b, title_a, c["z"], title_b, int(c["heldout_pixels"])),
          "", "| region | pixels | RMS %s [DC] | RMS %s [DC] | gain |" % (title_a, title_b),
          "|---|---|---|---|---|"]
    for r in c["regions"]:
        md.append("| %s | %d | %s | %s | %+.1f %% |" % (
            r["name"], int(r["pixels"]), fmt(r["rms_a_dc"]), fmt(r["rms_b_dc"]), r["gain_pct"]))
    regs = [r for r in c["regions"] if r["pixels"] > 0]
    fig, ax = plt.subplots(figsize=(8.0, 4.8), dpi=100)
    xs = range(len(regs))
    ax.bar([x - 0.2 for x in xs], [r["rms_a_dc"] for r in regs], 0.4, label="%s: %s" % (title_a, a["preset"]))
    ax.bar([x + 0.2 for x in xs], [r["rms_b_dc"] for r in regs], 0.4, label="%s: %s" % (title_b, b["preset"]))
    ax.set_xticks(list(xs))
    ax.set_xticklabels([r["name"] for r in regs], rotation=45, ha="right")
    ax.set_ylabel("held-out RMS [DC]")
    ax.set_title("held-out RMS per region")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(d, png))
    plt.close(fig)
    md += ["", "![%s](%s)" % (png, png), ""]
    return md


def main():
    if len(sys.argv) != 2:
        sys.stderr.write("usage: diagnose_report.py DIR\n")
        return 2
    d = sys.argv[1]
    with open(os.path.join(d, "report.json")) as f:
        rep = json.load(f)
    if "compare" in rep:
        md = ["# nvstim diagnose --compare: %s" % rep["dataset"], "",
              "Both presets fitted on the calibration half (extra MTF blur, gain, offset), scored "
              "on the held-out half on the same pixels.", ""]
        md += compare_section(rep["compare"], d, "compare_regions.png")
        with open(os.path.join(d, "report.md"), "w") as f:
            f.write("\n".join(md) + "\n")
        return 0
    res = rep["result"]
    md = ["# nvstim diagnose: %s" % rep["dataset"], "",
          "Camera model `%s`, frames %d x %d." % (rep["camera"], rep["width"], rep["height"]), ""]
    md += ["## Findings", ""]
    if not res["findings"]:
        md += ["No finding: no effect of the catalog improved the held-out frames significantly.", ""]
    else:
        md += ["Status: `named`, a cause of the catalog; `unexplained`, structure no effect of the "
               "catalog holds (its shape and character); `candidate`, a catalog effect that the "
               "unexplained structure explains better.", "",
               "| effect | status | cause | parameters | held-out RMS before | after | unit | confidence |",
               "|---|---|---|---|---|---|---|---|"]
        for f in res["findings"]:
            params = ", ".join("%s = %s" % (k, fmt(v)) for k, v in f["parameters"].items())
            name = f["effect"]
            if name == "unexplained":
                name = "unexplained: %s (%s)" % (f["structure"], f["character"])
            md.append("| `%s` | %s | %s | %s | %s | %s | %s | %.4f |" % (
                name, f.get("status", "named"), f["cause"], params, fmt(f["heldout_rms_before"]),
                fmt(f["heldout_rms_after"]), f["unit"], f["confidence"]))
        md.append("")
    if "gain_of_written_preset" in rep:
        md += ["## The gain of the written preset", "",
               "The dataset's preset (before) against the preset `--write-preset` wrote (after), "
               "each fitted on the calibration half and scored on the held-out half.", ""]
        md += compare_section(rep["gain_of_written_preset"]["compare"], d, "gain_regions.png",
                              "before", "after")
    md += ["## Baseline (calibration half)", "", "| quantity | value |", "|---|---|"]
    for k, v in sorted(res["baseline"].items()):
        md.append("| %s | %s |" % (k, fmt(v)))
    md += ["", "## Every effect tried", "",
           "| effect | tried | held-out z | score | RMS before | after | fitted / why not |",
           "|---|---|---|---|---|---|---|"]
    for t in rep["trials"]:
        md.append("| `%s` | %s | %.2f | %.1f | %s | %s | %s |" % (
            t["effect"], "yes" if t["tried"] else "no", t["z"], t["score"], fmt(t["before"]),
            fmt(t["after"]), t["why"]))
    md += ["", "## Plots", ""]
    for c in rep["curves"]:
        png = c["name"] + ".png"
        plot_curve(c, os.path.join(d, png))
        md += ["### %s" % c["name"].replace("_", " "), "", "![%s](%s)" % (c["name"], png), ""]
    for m in rep["maps"]:
        png = m + ".png"
        plot_map(m, read_pfm(os.path.join(d, m + ".pfm")), os.path.join(d, png))
        md += ["### %s" % m.replace("_", " "), "", "![%s](%s)" % (m, png), ""]
    with open(os.path.join(d, "report.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
