#!/usr/bin/env python3
"""Draws the plots of `nvstim sweep` (docs/sweep.md, "Results").

Reads DIR/results.json that nvstim wrote and draws, for every metric it names and every grid
axis that varies, DIR/plots/METRIC-vs-AXIS.png with Matplotlib (Debian python3-matplotlib, Agg
backend, no display needed): one point per job that succeeded, coloured by the first other
axis that varies (seeds are repeats), and the means of each colour as a line; a metric that is
the same in every job is not drawn. An axis whose values are all numbers is drawn to scale, any other in the order of
its first appearance. Earlier PNG files in DIR/plots are replaced.

Usage: sweep_plots.py DIR
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def as_number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def positions(values):
    """Where each axis value lies on x: to scale when all are numbers, else in order."""
    numeric = all(as_number(v) is not None for v in values)
    if numeric:
        return {v: as_number(v) for v in values}, True
    return {v: i for i, v in enumerate(values)}, False


def plot(rows, metric, axis, group, out):
    ok = [r for r in rows
          if r.get("status") == "ok" and isinstance(r.get(metric), (int, float))]
    if not ok:
        return False
    values = []
    for r in ok:
        if r.get(axis, "") not in values:
            values.append(r.get(axis, ""))
    where, numeric = positions(values)
    if numeric:
        values.sort(key=as_number)
    groups = []
    for r in ok:
        g = r.get(group, "") if group else ""
        if g not in groups:
            groups.append(g)
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    for i, g in enumerate(groups):
        mine = [r for r in ok if (r.get(group, "") if group else "") == g]
        colour = "C%d" % (i % 10)
        label = "%s = %s" % (group, g) if group else "jobs"
        ax.plot([where[r.get(axis, "")] for r in mine], [r[metric] for r in mine], "o",
                color=colour, alpha=0.6, label=label)
        xs, means = [], []
        for v in values:
            ys = [r[metric] for r in mine if r.get(axis, "") == v]
            if ys:
                xs.append(where[v])
                means.append(sum(ys) / len(ys))
        ax.plot(xs, means, "-", color=colour, alpha=0.8)
    if not numeric:
        ax.set_xticks(list(range(len(values))))
        ax.set_xticklabels(values, rotation=20, ha="right", fontsize=8)
    ax.set_xlabel(axis)
    ax.set_ylabel(metric)
    ax.set_title("%s against %s (lines: means)" % (metric, axis))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return True


def varies(rows, metric):
    seen = {r.get(metric) for r in rows if r.get("status") == "ok"}
    return len(seen) > 1


def main():
    if len(sys.argv) != 2:
        sys.stderr.write("usage: sweep_plots.py DIR\n")
        return 2
    folder = sys.argv[1]
    with open(os.path.join(folder, "results.json")) as f:
        table = json.load(f)
    plots = os.path.join(folder, "plots")
    os.makedirs(plots, exist_ok=True)
    for name in os.listdir(plots):
        if name.endswith(".png"):
            os.remove(os.path.join(plots, name))
    drawn = 0
    varied = table.get("varied", [])
    for metric in table.get("metrics", []):
        if not varies(table["rows"], metric):
            continue
        for axis in varied:
            # Points coloured by the first other axis that varies, seeds being repeats.
            others = [a for a in varied if a != axis and a != "seed"]
            out = os.path.join(plots, "%s-vs-%s.png" % (metric, axis))
            drawn += 1 if plot(table["rows"], metric, axis, others[0] if others else None,
                               out) else 0
    print("sweep_plots: %d plots in %s" % (drawn, plots))
    return 0


if __name__ == "__main__":
    sys.exit(main())
