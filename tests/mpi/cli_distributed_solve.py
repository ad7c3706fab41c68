"""`mpirun -np 2 pardel solve` against the plain `pardel solve` of the same scene: the seed's
Jacobi-Newton writes the same trajectory.csv byte for byte (also under a clock: zermelo_tv with
free final time, spacecraft_sundman with fixed total time, whose nodes move with their times), Newton
the same trajectory to 1e-7; rank 0 alone writes the outputs and
summary.json records the ranks. Checkpoints: `mpirun -np 2 pardel solve` interrupted by SIGINT writes
checkpoint.json, and its --resume, under mpirun or in one process, ends with the trajectory.csv of the
uninterrupted run byte for byte. `--device cuda` over 2 ranks is refused (exit 2) and writes nothing."""
import argparse
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time


def run(command):
    result = subprocess.run(command, capture_output=True, text=True)
    return result.returncode, result.stdout, result.stderr


def read_rows(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


def interrupted_and_resumed(args):
    """SIGINT to mpirun (which passes it on to the ranks as SIGTERM): rank 0 writes checkpoint.json;
    `mpirun -np 2 pardel solve --resume DIR` and a one-process `pardel solve --resume` of a copy of
    DIR both end with the trajectory of the uninterrupted run (Jacobi-Newton to max_iterations)."""
    failures = []
    scene = os.path.join(args.scenes, "fuel_nav.toml")
    common = ["solve", scene, "--quiet", "--no-plot", "--threads", "1", "--set", "solver.method=jacobi-newton",
              "--set", "solver.max_iterations=150000", "--set", "grid.N=400"]
    mpirun = [args.mpirun, "-np", "2", "--oversubscribe"]
    plain_dir = os.path.join(args.work, "resume_plain")
    code, out, err = run(mpirun + [args.pardel] + common + ["--out", plain_dir])
    if code != 3:
        return [f"resume: the uninterrupted run exited {code}, expected 3\n{out}{err}"]
    ranks_dir = os.path.join(args.work, "resume_np2")
    started = time.time()
    process = subprocess.Popen(mpirun + [args.pardel] + common + ["--out", ranks_dir], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    # The output folder is made just before the solve (and its signal handlers); then half a second.
    while not os.path.isdir(ranks_dir) and process.poll() is None and time.time() - started < 60:
        time.sleep(0.05)
    time.sleep(0.5)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate()
    checkpoint = os.path.join(ranks_dir, "checkpoint.json")
    if not os.path.exists(checkpoint):
        return [f"resume: no checkpoint.json after SIGINT at {time.time() - started:.1f} s (exit {process.returncode})"
                f"\n{out}{err}"]
    if "checkpoint written; continue with: pardel solve --resume" not in err:
        failures.append(f"resume: the interrupted run did not report its checkpoint\n{out}{err}")
    one_dir = os.path.join(args.work, "resume_one")
    shutil.copytree(ranks_dir, one_dir)
    expected = open(os.path.join(plain_dir, "trajectory.csv")).read()
    for name, command, folder in [("mpirun -np 2 --resume", mpirun + [args.pardel], ranks_dir),
                                  ("one-process --resume", [args.pardel], one_dir)]:
        code, out, err = run(command + ["solve", "--resume", folder, "--quiet", "--no-plot"])
        if code != 3:
            failures.append(f"resume: {name} exited {code}, expected 3\n{out}{err}")
            continue
        if open(os.path.join(folder, "trajectory.csv")).read() != expected:
            failures.append(f"resume: {name}: trajectory.csv differs from the uninterrupted run's")
        if os.path.exists(os.path.join(folder, "checkpoint.json")):
            failures.append(f"resume: {name} left its checkpoint.json behind")
        with open(os.path.join(folder, "summary.json")) as f:
            print(f"resume: {name} ended at iteration {json.load(f).get('iterations')}")
    return failures


def device_refused_over_ranks(args):
    """solver.device = cuda over 2 ranks: exit 2 with the reason, nothing written."""
    out_dir = os.path.join(args.work, "device_np2")
    code, out, err = run([args.mpirun, "-np", "2", "--oversubscribe", args.pardel, "solve",
                          os.path.join(args.scenes, "fuel_nav.toml"), "--quiet", "--no-plot", "--device", "cuda",
                          "--set", "solver.method=jacobi-newton", "--out", out_dir])
    if code != 2 or "device cuda: a solve over 2 MPI ranks runs on their CPU cores" not in err:
        return [f"device over ranks: exit {code}, expected 2 with the reason\n{out}{err}"]
    if os.path.exists(out_dir):
        return ["device over ranks: the refused solve wrote " + out_dir]
    return []


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--pardel", required=True)
    parser.add_argument("--mpirun", required=True)
    parser.add_argument("--scenes", required=True)
    parser.add_argument("--work", required=True)
    args = parser.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    failures = []
    cases = [
        ("jacobi-newton", "fuel_nav.toml", ["--set", "solver.method=jacobi-newton",
                                            "--set", "solver.max_iterations=400", "--set", "grid.N=100"], 3, None),
        ("newton", "fuel_nav.toml", ["--set", "solver.method=newton"], 0, 1e-7),
        # free final time: node times from the clock, carried from rank to rank
        ("zermelo_tv", "zermelo_tv.toml", ["--set", "solver.method=jacobi-newton", "--set", "solver.max_iterations=300",
                                           "--set", "solver.clock_update_every=20"], 3, None),
        # fixed total time: the nodes move to their new times, interpolated from nodes of both ranks
        ("spacecraft_sundman", "spacecraft_sundman.toml", ["--set", "solver.method=jacobi-newton",
                                                           "--set", "solver.max_iterations=300"], 3, None),
    ]
    for name, scene_file, sets, expected_code, tolerance in cases:
        scene = os.path.join(args.scenes, scene_file)
        plain_dir = os.path.join(args.work, name + "_plain")
        ranks_dir = os.path.join(args.work, name + "_np2")
        common = ["solve", scene, "--quiet", "--no-plot", "--threads", "1"] + sets
        code, out, err = run([args.pardel] + common + ["--out", plain_dir])
        if code != expected_code:
            failures.append(f"{name}: plain run exited {code}, expected {expected_code}\n{out}{err}")
            continue
        code, out, err = run([args.mpirun, "-np", "2", "--oversubscribe", args.pardel] + common +
                             ["--out", ranks_dir])
        if code != expected_code:
            failures.append(f"{name}: mpirun -np 2 exited {code}, expected {expected_code}\n{out}{err}")
            continue
        # --quiet: nothing on stdout; a non-converged status is reported once (by rank 0), as in the plain run.
        if out.strip() or err.count("pardel solve:") != (0 if expected_code == 0 else 1):
            failures.append(f"{name}: the distributed run printed\n{out}{err}")
        with open(os.path.join(ranks_dir, "summary.json")) as f:
            summary = json.load(f)
        if summary.get("ranks") != 2:
            failures.append(f"{name}: summary.json records ranks = {summary.get('ranks')}, expected 2")
        plain_csv = os.path.join(plain_dir, "trajectory.csv")
        ranks_csv = os.path.join(ranks_dir, "trajectory.csv")
        if tolerance is None:
            with open(plain_csv) as a, open(ranks_csv) as b:
                if a.read() != b.read():
                    failures.append(f"{name}: trajectory.csv differs from the plain run's")
        else:
            head_a, rows_a = read_rows(plain_csv)
            head_b, rows_b = read_rows(ranks_csv)
            if head_a != head_b or len(rows_a) != len(rows_b):
                failures.append(f"{name}: trajectory.csv has another shape than the plain run's")
                continue
            worst = max(abs(x - y) for ra, rb in zip(rows_a, rows_b) for x, y in zip(ra, rb))
            print(f"{name}: max |difference| of trajectory.csv = {worst:.3g}")
            if worst > tolerance:
                failures.append(f"{name}: trajectories differ by {worst:.3g} > {tolerance}")
    failures += interrupted_and_resumed(args)
    failures += device_refused_over_ranks(args)
    for failure in failures:
        print("FAIL:", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
