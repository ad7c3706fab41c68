"""The plotting step of `pardel solve` never ends in a Python traceback.

Runs cli/plot.py as `pardel solve` runs it (PYTHON PLOT_SCRIPT OUT_DIR) on output folders
of every status the solver writes (converged at a minimum, a saddle and a degenerate point,
stalled, max_iterations, diverged, non_finite, interrupted), every kind of cost (declared action,
declared clock summed over a fixed total time, travel time under a free final time, the action of
a model that declares none), a one-coordinate model, order-2 and order-3 models, clock models,
the time-varying wind and the spacecraft. The folders come from real solves (`pardel solve
--no-plot`); the statuses a small solve cannot reach on demand are made from them by editing what
the solver would have written (summary.json's status, null numbers where it writes NaN, the
history of an interrupted or diverging run, a trajectory that ran away). Each plot must be drawn
(a PNG file) or skipped with a message on stderr that names the file and the reason, with exit
status 0, within 120 s; the cases say which. One case runs `pardel solve` with its plots end to end.

usage: test_plots.py PARDEL PLOT_SCRIPT PYTHON SCENES_DIR
"""
import csv
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def solve(pardel, scene, out, sets=()):
    args = [pardel, "solve", scene, "--out", out, "--no-plot", "--quiet", "--threads", "1"]
    for s in sets:
        args += ["--set", s]
    r = subprocess.run(args, capture_output=True, text=True, timeout=120)
    if not os.path.exists(os.path.join(out, "summary.json")):
        raise RuntimeError("pardel solve %s wrote no summary (exit %d): %s" % (scene, r.returncode, r.stderr))
    return r


def edit_summary(out, **changes):
    path = os.path.join(out, "summary.json")
    with open(path, encoding="utf-8") as f:
        summary = json.load(f)
    for key, value in changes.items():
        if "." in key:
            outer, inner = key.split(".", 1)
            summary[outer][inner] = value
        else:
            summary[key] = value
    with open(path, "w", encoding="utf-8") as f:
        json.dump(summary, f, indent=2)


def read_rows(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.reader(f))


def write_rows(path, rows):
    text = io.StringIO()
    csv.writer(text, lineterminator="\n").writerows(rows)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.getvalue())


def edit_table(out, name, edit):
    """Applies edit(header, rows) -> rows to OUT/name."""
    path = os.path.join(out, name)
    rows = read_rows(path)
    write_rows(path, [rows[0]] + edit(rows[0], rows[1:]))


def scale_positions(factor):
    def edit(header, rows):
        return [[row[0], row[1]] + ["%.17g" % (float(v) * factor) for v in row[2:]] for row in rows]
    return edit


def set_cell(row_index, column, value):
    def edit(header, rows):
        rows[row_index][header.index(column)] = value
        return rows
    return edit


def residuals_growing(header, rows):
    # A diverging run's history: the residual grows by 10^8 per record up to 1e300, then inf.
    for i, row in enumerate(rows):
        row[header.index("residual")] = "inf" if i == len(rows) - 1 and i > 0 else "%.17g" % min(1e300, 10.0 ** (8 * i))
    return rows


def last_record_not_finite(header, rows):
    rows[-1][header.index("residual")] = "nan"
    rows[-1][header.index("action")] = "-inf"
    return rows


def no_records(header, rows):
    return []


NULL_NUMBERS = {"residual": None, "action": None, "cost.value": None, "final_time": None}


class Case:
    def __init__(self, name, scene, sets=(), summary=None, tables=(), trajectory="drawn", convergence="drawn",
                 note=None):
        self.name, self.scene, self.sets, self.note = name, scene, list(sets), note
        self.summary = summary or {}
        self.tables = list(tables)  # (file name, edit)
        self.trajectory, self.convergence = trajectory, convergence


def cases():
    small = ["solver.threads=1"]
    newton = small + ["solver.method=newton"]
    return [
        # Converged, by point kind; the costs: declared action (fuel_nav, a drift field drawn as
        # streamlines), declared clock under a free final time (zermelo), the action of a model
        # without a declaration and one coordinate (harmonic, from the fuzz seeds' scene).
        Case("converged_minimum_fuel", "fuel_nav.toml", newton + ["grid.N=40"]),
        Case("converged_saddle", "fuel_nav.toml", newton + ["grid.N=40"],
             summary={"point.kind": "saddle", "point.inertia": {"positive": 70, "negative": 2, "zero": 0}}),
        Case("converged_degenerate", "fuel_nav.toml", newton + ["grid.N=40"],
             summary={"point.kind": "degenerate", "point.lambda_min": 0.0}),
        Case("clock_travel_time_free_final_time", "zermelo_1.toml", newton + ["grid.N=40"]),
        Case("clock_summed_over_fixed_total_time", "zermelo_1.toml",
             newton + ["grid.N=40", "solver.clock=fixed_total_time"]),
        Case("time_varying_wind", "zermelo_tv.toml", newton + ["grid.N=30"]),
        Case("order_2_with_knots", "interp_fuel.toml", newton + ["grid.N=60"]),
        Case("order_3_three_coordinates", "min_jerk.toml", newton + ["grid.N=16"]),
        Case("spacecraft", "spacecraft_fixed.toml", newton + ["grid.N=40"]),
        Case("one_coordinate_action", "@harmonic", newton),
        # The other statuses.
        Case("max_iterations", "fuel_nav.toml", small + ["solver.method=jacobi", "solver.max_iterations=3",
                                                        "grid.N=40"]),
        Case("stalled", "fuel_nav.toml", newton + ["grid.N=40"],
             summary={"status": "stalled", "message": "no further progress"}),
        Case("diverged_far_away", "fuel_nav.toml", newton + ["grid.N=40"],
             summary={"status": "diverged", "message": "DEL residual grew", "residual": 1e300},
             tables=[("trajectory.csv", scale_positions(1e250)), ("convergence.csv", residuals_growing)],
             note="plot.py: trajectory.png: the wind field is not drawn: the path reaches 6e+250, beyond 1e+06"),
        Case("diverged_clock_model", "zermelo_1.toml", newton + ["grid.N=40"],
             summary={"status": "diverged", "message": "DEL residual grew", "cost.value": None},
             tables=[("trajectory.csv", scale_positions(1e200)), ("convergence.csv", residuals_growing)]),
        Case("non_finite", "fuel_nav.toml", newton + ["grid.N=40"],
             summary=dict(NULL_NUMBERS, status="non_finite", message="non-finite DEL residual at node 11"),
             tables=[("convergence.csv", last_record_not_finite)]),
        Case("non_finite_trajectory_values", "fuel_nav.toml", newton + ["grid.N=40"],
             summary=dict(NULL_NUMBERS, status="non_finite", message="non-finite DEL residual at node 3"),
             tables=[("trajectory.csv", set_cell(3, "x", "nan")), ("trajectory.csv", set_cell(4, "y", "inf"))],
             trajectory="skipped"),
        Case("non_finite_one_coordinate", "@harmonic", newton,
             summary=dict(NULL_NUMBERS, status="non_finite", message="non-finite"),
             tables=[("trajectory.csv", set_cell(2, "x", "-inf"))], trajectory="skipped"),
        Case("interrupted_before_the_first_record", "fuel_nav.toml", newton + ["grid.N=40"],
             summary={"status": "interrupted", "iterations": 0, "message": "interrupted"},
             tables=[("convergence.csv", no_records)]),
        Case("interrupted_on_a_coarse_level", "zermelo_1.toml",
             small + ["solver.method=newton", "grid.N=40", "solver.refine={start_N = 10, factor = 2}",
                      "solver.max_iterations=2"],
             summary={"status": "interrupted", "message": "interrupted"}),
    ]


HARMONIC = 'model = "harmonic"\n[grid]\nT = 2\nN = 20\n[boundary]\nq0 = [0]\nqN = [1]\n'


def check_plot(name, stderr, out, png, expected):
    path = os.path.join(out, png)
    drawn = os.path.exists(path)
    errors = []
    if expected == "drawn":
        if not drawn:
            errors.append("%s: %s not drawn; stderr: %s" % (name, png, stderr))
        else:
            with open(path, "rb") as f:
                if f.read(8) != PNG_MAGIC:
                    errors.append("%s: %s is not a PNG file" % (name, png))
    else:
        if drawn:
            errors.append("%s: %s drawn, expected it to be skipped" % (name, png))
        if "plot.py: %s skipped: " % png not in stderr:
            errors.append("%s: no message says that %s was skipped; stderr: %s" % (name, png, stderr))
    return errors


def main(argv):
    if len(argv) != 5:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    pardel, plot_script, python, scenes = argv[1:]
    work = tempfile.mkdtemp(prefix="pardel_plots_")
    errors = []
    try:
        harmonic = os.path.join(work, "harmonic.toml")
        with open(harmonic, "w", encoding="utf-8") as f:
            f.write(HARMONIC)
        statuses, costs = set(), set()
        for case in cases():
            out = os.path.join(work, case.name)
            scene = harmonic if case.scene == "@harmonic" else os.path.join(scenes, case.scene)
            solve(pardel, scene, out, case.sets)
            if case.summary:
                edit_summary(out, **case.summary)
            for table, edit in case.tables:
                edit_table(out, table, edit)
            with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
                summary = json.load(f)
            statuses.add(summary["status"] + ("/" + summary["point"]["kind"] if summary["status"] == "converged" else ""))
            costs.add(summary["cost"]["name"] + ": " + summary["cost"]["definition"].split(",")[0])
            if case.trajectory == "skipped":
                with open(os.path.join(out, "trajectory.png"), "wb") as f:
                    f.write(PNG_MAGIC)  # an older solve's picture, which must not stay beside these outputs
            try:
                r = subprocess.run([python, plot_script, out], capture_output=True, text=True, timeout=120)
            except subprocess.TimeoutExpired:
                errors.append("%s: plot.py did not finish within 120 s" % case.name)
                continue
            if case.note and case.note not in r.stderr:
                errors.append("%s: stderr lacks the note '%s': %s" % (case.name, case.note, r.stderr))
            if r.returncode != 0:
                errors.append("%s: plot.py exited with %d: %s" % (case.name, r.returncode, r.stderr))
            if "Traceback" in r.stderr:
                errors.append("%s: a Python traceback:\n%s" % (case.name, r.stderr))
            errors += check_plot(case.name, r.stderr, out, "trajectory.png", case.trajectory)
            errors += check_plot(case.name, r.stderr, out, "convergence.png", case.convergence)
            print("%-40s %-28s trajectory %-7s convergence %s" % (case.name, summary["status"], case.trajectory,
                                                                   case.convergence))
        expected_statuses = {"converged/minimum", "converged/saddle", "converged/degenerate", "stalled",
                             "max_iterations", "diverged", "non_finite", "interrupted"}
        if not expected_statuses <= statuses:
            errors.append("statuses not covered: %s" % sorted(expected_statuses - statuses))
        print("costs covered:\n  " + "\n  ".join(sorted(costs)))
        if len(costs) < 4:
            errors.append("fewer than 4 kinds of cost covered: %s" % sorted(costs))
        # A picture that cannot be written (here a folder, not empty, where convergence.png goes; a
        # full disk printed a traceback): skipped with the reason, the other drawn, exit 0.
        out = os.path.join(work, "unwritable")
        solve(pardel, harmonic, out)
        os.makedirs(os.path.join(out, "convergence.png", "inside"))
        r = subprocess.run([python, plot_script, out], capture_output=True, text=True, timeout=120)
        if r.returncode != 0 or "Traceback" in r.stderr:
            errors.append("unwritable: plot.py exited %d: %s" % (r.returncode, r.stderr))
        if "plot.py: convergence.png skipped: it could not be written" not in r.stderr:
            errors.append("unwritable: no message says that convergence.png was skipped: %s" % r.stderr)
        errors += check_plot("unwritable", r.stderr, out, "trajectory.png", "drawn")
        if any(".tmp." in name for name in os.listdir(out)):
            errors.append("unwritable: a temporary file is left: %s" % os.listdir(out))
        # End to end: `pardel solve` draws the plots itself and reports no failure of the plot step.
        out = os.path.join(work, "end_to_end")
        r = subprocess.run([pardel, "solve", os.path.join(scenes, "zermelo_1.toml"), "--out", out, "--quiet",
                            "--threads", "1", "--set", "grid.N=40", "--set", "solver.method=newton"],
                           capture_output=True, text=True, timeout=300)
        if r.returncode != 0 or "plots not written" in r.stderr or "Traceback" in r.stderr:
            errors.append("end to end: pardel solve exited %d: %s" % (r.returncode, r.stderr))
        errors += check_plot("end to end", r.stderr, out, "trajectory.png", "drawn")
        errors += check_plot("end to end", r.stderr, out, "convergence.png", "drawn")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for e in errors:
        print("FAILED: " + e, file=sys.stderr)
    print("%d failure(s)" % len(errors))
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
