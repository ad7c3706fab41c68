#!/usr/bin/python3
"""OpenMP wait policy next to a busy core: `pardel solve` on 1 thread, and on all cores with
threads that spin (OMP_WAIT_POLICY=active) or sleep (passive, the command's default) while
another process keeps one core busy.

For each N, starts a busy loop (a `sh` process spinning, pinned to the last core with taskset
when there is one), runs

    build/pardel solve tools/benchmarks/scenes/rb_kepler.toml --set grid.N=N --threads T --out DIR --quiet --no-plot

--repeat times in each configuration (OMP_WAIT_POLICY set explicitly, so the command does not
choose) and prints the solve's wall time (summary.json wall_seconds): the median and the range, and
the load average. Then the same without the busy loop. Writes docs/images/bench_busy_core.csv.

Usage (from the project root, Release build):
  /usr/bin/python3 tools/benchmarks/busy_core.py --build build [--N 2000,20000,200000,2000000] [--repeat 5]
"""
import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = "tools/benchmarks/scenes/rb_kepler.toml"


def solve_seconds(pardel, N, threads, policy, out):
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    env["OMP_WAIT_POLICY"] = policy
    subprocess.run([pardel, "solve", SCENE, "--set", f"grid.N={N}", "--threads", str(threads), "--out", out,
                    "--quiet", "--no-plot"], cwd=ROOT, env=env, check=True)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    assert summary["status"] == "converged", summary["message"]
    return summary["wall_seconds"]


def start_busy_loop():
    cores = os.cpu_count() or 1
    command = ["sh", "-c", "while :; do :; done"]
    if shutil.which("taskset") and cores > 1:
        command = ["taskset", "-c", str(cores - 1)] + command
    return subprocess.Popen(command, start_new_session=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--N", default="2000,20000,200000,2000000")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--csv", default=os.path.join(ROOT, "docs/images/bench_busy_core.csv"))
    args = ap.parse_args()
    pardel = os.path.abspath(os.path.join(args.build, "pardel"))
    cores = os.cpu_count() or 1
    configurations = [("1 thread", 1, "passive"), (f"{cores} threads, spin", cores, "active"),
                      (f"{cores} threads, passive", cores, "passive")]
    rows = []
    with tempfile.TemporaryDirectory() as out:
        for busy in (True, False):
            for N in [int(float(v)) for v in args.N.split(",")]:
                loop = start_busy_loop() if busy else None
                try:
                    for name, threads, policy in configurations:
                        times = [solve_seconds(pardel, N, threads, policy, out) for _ in range(args.repeat)]
                        load = open("/proc/loadavg").read().split()[0]
                        rows.append(dict(busy_core=int(busy), N=N, configuration=name, threads=threads,
                                         policy=policy, median_seconds=f"{statistics.median(times):.6g}",
                                         min_seconds=f"{min(times):.6g}", max_seconds=f"{max(times):.6g}",
                                         load=load))
                        print(f"{'busy core' if busy else 'idle'}  N={N:>8}  {name:<22} median "
                              f"{statistics.median(times) * 1e3:9.3f} ms  [{min(times) * 1e3:.3f}, "
                              f"{max(times) * 1e3:.3f}]  load {load}", flush=True)
                finally:
                    if loop:
                        os.killpg(loop.pid, 9)
                        loop.wait()
    with open(args.csv, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
