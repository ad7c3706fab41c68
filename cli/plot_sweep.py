#!/usr/bin/python3
"""The picture of one `pardel sweep` output folder: sweep.png, every distinct solution's path.

Usage: plot_sweep.py OUT_DIR

Reads OUT_DIR/sweep.json and the solution_<id>.csv files it lists. The best solution (lowest
cost) is drawn thick and red, the others thin, each labelled with its cost in the legend. Where
the model's .lag defines the wind W1, W2 (as plot.py reads it), the wind at t = 0 of the best
solution's configuration is drawn under the paths. Models with one coordinate are drawn against t.
The file is written atomically (temporary file, then rename).
"""
import json
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import plot  # noqa: E402  (read_lag, LagExpressions, read_table, save, box)
from plot import np, plt  # noqa: E402


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    out = argv[1]
    with open(os.path.join(out, "sweep.json"), encoding="utf-8") as f:
        sweep = json.load(f)
    solutions = sweep.get("solutions", [])
    if not solutions:
        print("plot_sweep.py: no solutions to draw", file=sys.stderr)
        return 1
    best = sweep["best"]
    cost_name = sweep["cost"]["name"].replace("_", " ")
    paths = [(s, plot.read_table(os.path.join(out, s["trajectory"]))) for s in solutions]
    coords = [c for c in list(paths[0][1].keys())[2:] if "'" not in c]
    lag = None
    source = sweep.get("model_source") or ""
    if source and os.path.exists(source):
        lag_coords, defaults, lets = plot.read_lag(source)
        values = dict(defaults)
        params = sweep["configurations"][best["configuration"]].get("params", {})
        values.update({k: repr(float(v)) for k, v in params.items()})
        lag = plot.LagExpressions(lag_coords, values, lets)
        coords = lag_coords
    several = len(sweep.get("configurations", [])) > 1

    def label(s):
        text = "#%d %s = %.6g (%d variant%s, %s)" % (s["id"], cost_name, s["cost"], s["variants"],
                                                     "" if s["variants"] == 1 else "s", s["certificate"])
        return ("config %d: " % s["configuration"] + text) if several else text

    fig, ax = plt.subplots(figsize=(9, 7.5))
    tab10 = plt.get_cmap("tab10")
    palette = [tab10(i) for i in range(10) if i != 3]  # red (3) is the best's alone

    def colors(i):
        return palette[i % len(palette)]

    others = [p for p in paths if p[0]["id"] != best["id"]]
    chosen = [p for p in paths if p[0]["id"] == best["id"]]
    if len(coords) < 2:
        for i, (s, traj) in enumerate(others):
            ax.plot(traj["t"], traj[coords[0]], "-", lw=1.0, color=colors(i), label=label(s))
        for s, traj in chosen:
            ax.plot(traj["t"], traj[coords[0]], "-", lw=3.0, color="tab:red", label=label(s) + ", best", zorder=5)
        ax.set_xlabel("t")
        ax.set_ylabel(coords[0])
    else:
        xs = np.concatenate([traj[coords[0]] for _, traj in paths])
        ys = np.concatenate([traj[coords[1]] for _, traj in paths])
        limits = plot.box(xs, ys, 0.1)
        field = lag.field() if lag else None
        if field is not None:
            x0, x1, y0, y1 = limits
            gx, gy = np.meshgrid(np.linspace(x0, x1, 120), np.linspace(y0, y1, 120))
            u, v = field[0](gx, gy, 0.0)
            ax.streamplot(gx, gy, u, v, color=np.hypot(u, v), cmap="Blues", density=1.2, linewidth=0.6)
        for i, (s, traj) in enumerate(others):
            ax.plot(traj[coords[0]], traj[coords[1]], "-", lw=1.2, color=colors(i), label=label(s), zorder=3)
        for s, traj in chosen:
            ax.plot(traj[coords[0]], traj[coords[1]], "-", lw=3.2, color="tab:red", label=label(s) + ", best",
                    zorder=5)
        first = paths[0][1]
        ax.plot(first[coords[0]][0], first[coords[1]][0], "o", color="k", ms=6, zorder=6)
        ax.plot(first[coords[0]][-1], first[coords[1]][-1], "s", color="k", ms=6, zorder=6)
        ax.set_aspect("equal")
        ax.set_xlim(limits[0], limits[1])
        ax.set_ylim(limits[2], limits[3])
        ax.set_xlabel(coords[0])
        ax.set_ylabel(coords[1])
    failed = sum(sweep.get("failures", {}).values())
    ax.set_title("%s: %d variants, %d converged%s, %d distinct solutions" % (
        os.path.basename(sweep["sweep"]), sweep["variants"], sweep["converged"],
        (", %d failed" % failed) if failed else "", len(solutions)), fontsize=10)
    handles, labels = ax.get_legend_handles_labels()
    by_id = sorted(zip(handles, labels), key=lambda hl: int(re.search(r"#(\d+)", hl[1]).group(1)))
    ax.legend([h for h, _ in by_id], [lab for _, lab in by_id], fontsize=8, loc="upper left",
              bbox_to_anchor=(1.02, 1.0))
    plot.save(fig, os.path.join(out, "sweep.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
