#!/usr/bin/python3
"""Plots of one `pardel solve` output folder: trajectory.png and convergence.png.

Usage: plot.py OUT_DIR

Reads OUT_DIR/summary.json, trajectory.csv and convergence.csv. Where the model's .lag
(summary.json "model_source") defines lets named W1 and W2, they are the drift (wind) field:
they are evaluated from the .lag text with SymPy/NumPy and drawn under the path; a field that
depends on t is drawn at t = 0, T/3, 2T/3 and T (T the final node time), with the ship's position
at each instant and, along the path, the wind the ship meets when it passes. The spacecraft model
is drawn with the Earth, the Moon's orbit and the Moon at both ends, and beside it in the frame
that rotates with the Moon. Files are written atomically (temporary file, then rename).

Whatever the solve's status, each plot is drawn or skipped with a line on stderr
("plot.py: trajectory.png skipped: REASON"), and the exit status is 0: trajectory.png is skipped
(and an older one removed) when trajectory.csv has no rows or a value that is not finite; the wind
field is left out, with a note, when the path reaches beyond FIELD_LIMIT (a diverged solve), where
matplotlib's arrows never finish drawing, or when W1 or W2 cannot be read or evaluated here (the note
names the let); an error this script did not foresee skips only the plot it met it in, with its
reason (a trajectory is then drawn once more without the wind field), never with a traceback.
"""
import csv
import json
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import sympy  # noqa: E402

FUNCTIONS = {
    "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "exp": sympy.exp, "log": sympy.log,
    "sqrt": sympy.sqrt, "sinh": sympy.sinh, "cosh": sympy.cosh, "tanh": sympy.tanh,
    "asin": sympy.asin, "acos": sympy.acos, "atan": sympy.atan, "atan2": sympy.atan2,
    "pow": sympy.Pow,
}
# A number as pardel-gen reads it (digits with a point, an exponent: 5e-1, 1E5, .5, 2.) or a name
# with its primes: a number is matched first, so that the exponent of 5e-1 is no name "e".
TOKEN = re.compile(r"(?P<number>(?:[0-9][0-9.]*|\.[0-9][0-9.]*)(?:[eE][+-]?[0-9]+)?)"
                   r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*'*)")
# The wind field is drawn only while the path stays within this distance of the origin (in the
# model's units): at 10^12 matplotlib 3.6 does not finish drawing the arrows of a streamplot.
FIELD_LIMIT = 1e6


def skip(png, reason):
    print("plot.py: %s skipped: %s" % (png, reason), file=sys.stderr)


def unforeseen(path, error):
    """An error this script did not foresee while drawing the plot at path: the plot is skipped with
    it (and an older solve's picture removed), the other plot still drawn."""
    skip(os.path.basename(path), "an error while drawing it: %s: %s" % (type(error).__name__, error))
    plt.close("all")
    try:
        os.remove(path)
    except OSError:
        pass


def number_text(value, spec="%.3g"):
    """summary.json writes a number that is not finite as null."""
    return spec % value if isinstance(value, (int, float)) else "not finite"


def read_lag(path):
    """The coords, param defaults and let texts of a .lag file (lets kept in order)."""
    coords, params, lets = [], {}, {}
    # pardel-gen reads bytes: a comment in Latin-1 (or any bytes that are not UTF-8) is no error.
    with open(path, encoding="utf-8", errors="replace") as f:
        for raw in f:
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            word = line.split(None, 1)[0]
            rest = line[len(word):].strip()
            if word == "coords":
                coords = rest.split()
            elif word == "param" and "=" in rest:
                name, value = rest.split("=", 1)
                params[name.strip()] = value.strip()
            elif word == "let" and "=" in rest:
                name, value = rest.split("=", 1)
                lets[name.strip()] = value.strip()
    return coords, params, lets


class FieldUnreadable(Exception):
    """A let of the wind field that this script cannot turn into an expression."""


class LagExpressions:
    """Evaluates let definitions of a .lag symbolically, params replaced by their values."""

    def __init__(self, coords, param_values, lets):
        self.coords = coords
        self.symbols = {c: sympy.Symbol("c_" + c) for c in coords}
        self.t = sympy.Symbol("t_time")
        self.params = param_values
        self.lets = lets
        self.cache = {}

    def let(self, name):
        if name not in self.cache:
            try:
                self.cache[name] = self.parse(self.lets[name])
            except FieldUnreadable:
                raise
            except Exception as error:  # SymPy's SympifyError, SyntaxError, TypeError, ...: text it cannot read
                raise FieldUnreadable("let %s = %s cannot be read (%s: %s)"
                                      % (name, self.lets[name], type(error).__name__, error)) from None
        return self.cache[name]

    def parse(self, text):
        local = {}
        renamed = {}

        def rename(match):
            word = match.group("name")
            if word is None:
                return match.group("number")
            key = "v_%d" % len(renamed) if word not in renamed else renamed[word]
            renamed.setdefault(word, key)
            return renamed[word]

        body = TOKEN.sub(rename, text).replace("^", "**")
        for word, key in renamed.items():
            if word in FUNCTIONS:
                local[key] = FUNCTIONS[word]
            elif word == "pi":
                local[key] = sympy.pi
            elif word == "t":
                local[key] = self.t
            elif word in self.symbols:
                local[key] = self.symbols[word]
            elif word in self.params:
                local[key] = sympy.Float(self.params[word], 17)
            elif word in self.lets:
                local[key] = self.let(word)
            else:  # a derivative (x') or anything else: not part of a drift field
                local[key] = sympy.Symbol("unused_" + key)
        return sympy.sympify(body, locals=local, rational=True)

    def field(self):
        """(f(x, y, t) -> (W1, W2), depends_on_t) or None when W1/W2 are not both defined."""
        if "W1" not in self.lets or "W2" not in self.lets or len(self.coords) < 2:
            return None
        w1, w2 = self.let("W1"), self.let("W2")
        x, y = self.symbols[self.coords[0]], self.symbols[self.coords[1]]
        free = (w1.free_symbols | w2.free_symbols) - {x, y, self.t}
        if free:
            return None
        try:
            f1 = sympy.lambdify((x, y, self.t), w1, "numpy")
            f2 = sympy.lambdify((x, y, self.t), w2, "numpy")
        except Exception as error:
            raise FieldUnreadable("W1, W2 cannot be evaluated (%s: %s)" % (type(error).__name__, error)) from None

        def evaluate(xs, ys, t):
            u = np.broadcast_to(np.asarray(f1(xs, ys, t), dtype=float), np.shape(xs))
            v = np.broadcast_to(np.asarray(f2(xs, ys, t), dtype=float), np.shape(xs))
            return u, v

        return evaluate, self.t in (w1.free_symbols | w2.free_symbols)


def read_table(path):
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    data = np.array([[float(v) for v in row] for row in rows[1:] if row], dtype=float)
    if data.size == 0:
        data = np.zeros((0, len(header)))
    return {name: data[:, i] for i, name in enumerate(header)}


def save(fig, path):
    """Writes the figure to path through a temporary file; where that fails (a full disk, no write
    permission), the plot is skipped with the reason, and neither the temporary file nor an older
    solve's picture at path is left (it would be taken for this one's)."""
    tmp = "%s.tmp.%d" % (path, os.getpid())
    try:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
        os.replace(tmp, path)
    except OSError as error:
        skip(os.path.basename(path), "it could not be written (%s)" % (error.strerror or error))
        for leftover in (tmp, path):
            try:
                os.remove(leftover)
            except OSError:
                pass
    finally:
        plt.close(fig)


def cost_text(summary):
    cost = summary.get("cost", {})
    name = cost.get("name", "cost").replace("_", " ")
    value = cost.get("value")
    # summary.json writes a non-finite cost (a non_finite solve) as null
    return "%s = %s" % (name, "%.6g" % value if isinstance(value, (int, float)) else "not finite")


def box(xs, ys, margin=0.12):
    x0, x1, y0, y1 = np.min(xs), np.max(xs), np.min(ys), np.max(ys)
    span = max(x1 - x0, y1 - y0, 1e-9)
    return x0 - margin * span, x1 + margin * span, y0 - margin * span, y1 + margin * span


def arrow_scale(field, limits, t0, t1, density):
    """A quiver scale (speed units per data unit) shared by every panel: the fastest wind on the
    grid over [t0, t1] gets an arrow 0.8 grid spacings long."""
    x0, x1, y0, y1 = limits
    gx, gy = np.meshgrid(np.linspace(x0, x1, density), np.linspace(y0, y1, density))
    fastest = max(np.max(np.hypot(*field(gx, gy, t))) for t in np.linspace(t0, t1, 7))
    spacing = (x1 - x0) / (density - 1)
    return max(fastest, 1e-12) / (0.8 * spacing)


def draw_field(ax, field, limits, t, density, scale):
    x0, x1, y0, y1 = limits
    gx, gy = np.meshgrid(np.linspace(x0, x1, density), np.linspace(y0, y1, density))
    u, v = field(gx, gy, t)
    speed = np.hypot(u, v)
    ax.quiver(gx, gy, u, v, speed, cmap="Blues", alpha=0.8, angles="xy", scale_units="xy", scale=scale,
              width=0.003)


def draw_path(ax, xs, ys, markers=True):
    ax.plot(xs, ys, "-", color="tab:red", lw=1.4, zorder=3)
    if markers:
        ax.plot(xs, ys, ".", color="tab:red", ms=3, zorder=3)
    ax.plot(xs[0], ys[0], "o", color="k", ms=5, zorder=4)
    ax.plot(xs[-1], ys[-1], "s", color="k", ms=5, zorder=4)


def plot_trajectory(summary, traj, coords, lag, out_path):
    title = "%s (%s, N = %d): %s, %s" % (summary["model"], summary["discretization"], summary["N"],
                                          summary["status"], cost_text(summary))
    t = traj["t"]
    if len(coords) < 2:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        ax.plot(t, traj[coords[0]], ".-", color="tab:red")
        ax.set_xlabel("t")
        ax.set_ylabel(coords[0])
        ax.set_title(title, fontsize=9)
        save(fig, out_path)
        return
    xs, ys = traj[coords[0]], traj[coords[1]]
    try:
        field = lag.field() if lag else None
    except FieldUnreadable as error:
        print("plot.py: trajectory.png: the wind field is not drawn: %s" % error, file=sys.stderr)
        field = None
    reach = max(np.max(np.abs(xs)), np.max(np.abs(ys)))
    if field is not None and reach > FIELD_LIMIT:
        print("plot.py: trajectory.png: the wind field is not drawn: the path reaches %.3g, beyond %.0e"
              % (reach, FIELD_LIMIT), file=sys.stderr)
        field = None
    if summary["model"].startswith("spacecraft") and lag is not None:
        plot_spacecraft(summary, traj, coords, lag, title, out_path)
        return
    if field is not None and field[1]:
        evaluate = field[0]
        T = t[-1]
        limits = box(xs, ys, 0.15)
        fig, axes = plt.subplots(2, 2, figsize=(11, 10))
        # The wind the ship meets: at 60 equal time steps, at the ship's position at that time.
        ts = np.linspace(t[0], T, 61)
        px, py = np.interp(ts, t, xs), np.interp(ts, t, ys)
        wu, wv = evaluate(px, py, ts)
        scale = arrow_scale(evaluate, limits, t[0], T, 18)
        for ax, when, label in zip(axes.flat, [t[0], t[0] + (T - t[0]) / 3, t[0] + 2 * (T - t[0]) / 3, T],
                                   ["0", "T/3", "2T/3", "T"]):
            draw_field(ax, evaluate, limits, when, 18, scale)
            draw_path(ax, xs, ys)
            ax.quiver(px, py, wu, wv, color="k", angles="xy", scale_units="xy", scale=scale, width=0.003,
                      zorder=5)
            ax.plot(np.interp(when, t, xs), np.interp(when, t, ys), "o", color="k", ms=10, zorder=6)
            ax.set_title("t = %s = %.4g" % (label, when), fontsize=10)
            ax.set_aspect("equal")
            ax.set_xlim(limits[0], limits[1])
            ax.set_ylim(limits[2], limits[3])
        fig.suptitle(title, fontsize=10)
        save(fig, out_path)
        return
    fig, ax = plt.subplots(figsize=(7.5, 7))
    limits = box(xs, ys, 0.25)
    if field is not None:
        x0, x1, y0, y1 = limits
        gx, gy = np.meshgrid(np.linspace(x0, x1, 120), np.linspace(y0, y1, 120))
        u, v = field[0](gx, gy, 0.0)
        speed = np.hypot(u, v)
        strm = ax.streamplot(gx, gy, u, v, color=speed, cmap="Blues", density=1.4, linewidth=0.8)
        fig.colorbar(strm.lines, ax=ax, shrink=0.7, label="|W|")
    draw_path(ax, xs, ys)
    for knot in summary.get("knots", []):
        ax.plot(knot["q"][0], knot["q"][1], "D", color="tab:green", ms=8, zorder=5)
        ax.annotate("t = %g" % knot["t"], (knot["q"][0], knot["q"][1]), textcoords="offset points",
                    xytext=(6, 6), fontsize=8, color="tab:green")
    ax.set_aspect("equal")
    ax.set_xlim(limits[0], limits[1])
    ax.set_ylim(limits[2], limits[3])
    ax.set_xlabel(coords[0])
    ax.set_ylabel(coords[1])
    ax.set_title(title, fontsize=9)
    save(fig, out_path)


def plot_spacecraft(summary, traj, coords, lag, title, out_path):
    p = {k: float(v) for k, v in lag.params.items()}
    r_m, w_m, th0 = p.get("r_M", 0.00257), p.get("w_M", 12.37), p.get("th_M0", 0.0)
    t, xs, ys = traj["t"], traj[coords[0]], traj[coords[1]]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 6.2))
    phi = np.linspace(0, 2 * math.pi, 400)
    for ax in (a1, a2):
        ax.plot(r_m * np.cos(phi), r_m * np.sin(phi), ":", color="0.6", lw=0.8)
        ax.plot(0, 0, "o", color="tab:blue", ms=8)
        ax.set_aspect("equal")
        ax.set_xlabel("%s [AU]" % coords[0])
        ax.set_ylabel("%s [AU]" % coords[1])
    draw_path(a1, xs, ys)
    for when, style in ((t[0], "o"), (t[-1], "s")):
        angle = w_m * when + th0
        a1.plot(r_m * math.cos(angle), r_m * math.sin(angle), style, color="0.4", ms=7)
    a1.set_title("Sun-Earth rotating frame (Moon at start: o, at end: s)", fontsize=9)
    # Frame rotating with the Moon, the Moon fixed at the top.
    angle = w_m * t + th0
    rot = math.pi / 2 - angle
    mx = xs * np.cos(rot) - ys * np.sin(rot)
    my = xs * np.sin(rot) + ys * np.cos(rot)
    draw_path(a2, mx, my)
    a2.plot(0, r_m, "o", color="0.4", ms=7)
    a2.set_title("Earth-Moon rotating frame (Moon fixed at the top)", fontsize=9)
    fig.suptitle(title, fontsize=10)
    save(fig, out_path)


def plot_convergence(summary, conv, out_path):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    it, n, res = conv.get("iteration", []), conv.get("N", []), conv.get("residual", [])
    if len(it):
        for level in sorted(set(n.tolist()), key=lambda v: np.min(it[n == v])):
            mask = n == level
            ax.semilogy(it[mask] if len(it) > 1 else it, np.maximum(res[mask], 1e-300), ".-", ms=3,
                        label="N = %d" % level)
        if len(set(n.tolist())) > 1:
            ax.legend(fontsize=8)
    tol = summary.get("tol")
    if tol:
        ax.axhline(tol, color="0.5", ls="--", lw=0.8)
    ax.set_xlabel("iteration")
    ax.set_ylabel("DEL residual (inf-norm)")
    ax.set_title("%s, %s: %s after %d iterations, %s s" % (summary["model"], summary["method"],
                                                           summary["status"], summary["iterations"],
                                                           number_text(summary["wall_seconds"])), fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    save(fig, out_path)


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    out = argv[1]
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    traj = read_table(os.path.join(out, "trajectory.csv"))
    conv = read_table(os.path.join(out, "convergence.csv"))
    source = summary.get("model_source") or ""
    lag = None
    coords = [c for c in list(traj.keys())[2:] if "'" not in c]
    if source and os.path.exists(source):
        lag_coords, defaults, lets = read_lag(source)
        values = dict(defaults)
        values.update({k: repr(float(v)) for k, v in summary.get("params", {}).items()})
        lag = LagExpressions(lag_coords, values, lets)
        coords = lag_coords
    trajectory_png = os.path.join(out, "trajectory.png")
    bad = [(name, int(np.flatnonzero(~np.isfinite(traj[name]))[0])) for name in ["t"] + coords
           if name in traj and not np.all(np.isfinite(traj[name]))]
    if len(traj.get("t", [])) == 0 or bad:
        skip("trajectory.png", "trajectory.csv has no rows" if not bad else
             "trajectory.csv holds a value that is not finite (%s at row %d)" % (bad[0][0], bad[0][1]))
        if os.path.exists(trajectory_png):
            os.remove(trajectory_png)  # an older solve's picture would be taken for this one's
    else:
        try:
            plot_trajectory(summary, traj, coords, lag, trajectory_png)
        except Exception as error:  # reported; the path is drawn once more without the model's extras
            if lag is None:
                unforeseen(trajectory_png, error)
            else:
                print("plot.py: trajectory.png: drawn without the wind field and the model's extras: %s: %s"
                      % (type(error).__name__, error), file=sys.stderr)
                try:
                    plot_trajectory(summary, traj, coords, None, trajectory_png)
                except Exception as again:
                    unforeseen(trajectory_png, again)
    convergence_png = os.path.join(out, "convergence.png")
    try:
        plot_convergence(summary, conv, convergence_png)
    except Exception as error:
        unforeseen(convergence_png, error)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
