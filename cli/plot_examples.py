#!/usr/bin/python3
"""Combines several `pardel solve` output folders of one planar model into one figure: every
path over the model's drift field (evaluated from its .lag as in plot.py), each labelled with its
physical cost — the figure of the seed's six local Zermelo solutions.

Usage: plot_examples.py OUT.png DIR [DIR ...]
"""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import plot  # noqa: E402  (cli/plot.py)

plt = plot.plt
np = plot.np


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    target, dirs = argv[1], argv[2:]
    runs = []
    for d in dirs:
        with open(os.path.join(d, "summary.json"), encoding="utf-8") as f:
            summary = json.load(f)
        runs.append((d, summary, plot.read_table(os.path.join(d, "trajectory.csv"))))
    first = runs[0][1]
    coords, defaults, lets = plot.read_lag(first["model_source"])
    values = dict(defaults)
    values.update({k: repr(float(v)) for k, v in first.get("params", {}).items()})
    field = plot.LagExpressions(coords, values, lets).field()
    xs = np.concatenate([r[2][coords[0]] for r in runs])
    ys = np.concatenate([r[2][coords[1]] for r in runs])
    limits = plot.box(xs, ys, 0.08)
    fig, ax = plt.subplots(figsize=(9, 8))
    if field is not None:
        gx, gy = np.meshgrid(np.linspace(limits[0], limits[1], 150), np.linspace(limits[2], limits[3], 150))
        u, v = field[0](gx, gy, 0.0)
        strm = ax.streamplot(gx, gy, u, v, color=np.hypot(u, v), cmap="Blues", density=1.6, linewidth=0.7)
        fig.colorbar(strm.lines, ax=ax, shrink=0.7, label="|W|")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (d, summary, traj) in enumerate(runs):
        x, y = traj[coords[0]], traj[coords[1]]
        cost = summary["cost"]
        label = "%s: %s %.4f" % (os.path.basename(os.path.normpath(d)), cost["name"].replace("_", " "), cost["value"])
        ax.plot(x, y, ".-", ms=3, lw=1.5, color=colors[i % len(colors)], label=label, zorder=3)
        mid = len(x) // 2
        ax.annotate("%.3f" % cost["value"], (x[mid], y[mid]), textcoords="offset points", xytext=(5, 5),
                    fontsize=9, color=colors[i % len(colors)], weight="bold")
    ax.plot(xs[0], ys[0], "ko", ms=6, zorder=4)
    ax.plot(runs[0][2][coords[0]][-1], runs[0][2][coords[1]][-1], "ks", ms=6, zorder=4)
    ax.set_aspect("equal")
    ax.set_xlim(limits[0], limits[1])
    ax.set_ylim(limits[2], limits[3])
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title("%s (%s, N = %d): %d runs" % (first["model"], first["discretization"], first["N"], len(runs)),
                 fontsize=10)
    plot.save(fig, target)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
