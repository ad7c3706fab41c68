#!/usr/bin/python3
"""pardel.solve_batch on variants of the fuel-optimal navigation example: wall time against the
number of threads (problems solved at once).

The batch: B problems of scenes/fuel_nav.toml (q0 = (0, 0), T = 30, N = 200, method auto, the
error estimate on, as the scene solves it) whose end points qN are (6, 5) moved by up to 0.5 in
each coordinate (uniform, seed 1). For each thread count: the least wall time of `--repeat` calls
of pardel.solve_batch (the whole Python call, and BatchResult.wall_seconds: the solves alone,
without the results' conversion to Python objects), the CPU time of the process in that call (all
threads; on a machine that other work keeps busy the wall time does not fall with more threads,
while this total shows what the threads did), how many converged, and whether the trajectories
are bit for bit those of the first thread count.

  PYTHONPATH=build/python /usr/bin/python3 tools/benchmarks/batch_fuel_nav.py --batch 1000 --threads 1,2
"""
import argparse
import time

import numpy as np

import pardel


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--batch", type=int, default=1000, help="problems in the batch (default 1000)")
    parser.add_argument("--N", type=int, default=200, help="intervals of each problem (default 200)")
    parser.add_argument("--threads", default="1,2", help="thread counts to time, comma-separated (default 1,2)")
    parser.add_argument("--repeat", type=int, default=3, help="calls per thread count; the least time counts")
    args = parser.parse_args()

    rng = np.random.default_rng(1)
    qN = np.array([6.0, 5.0]) + rng.uniform(-0.5, 0.5, (args.batch, 2))
    first = None
    print("batch %d, N = %d, model fuel_nav (trapezoid), T = 30" % (args.batch, args.N))
    for threads in (int(t) for t in args.threads.split(",")):
        best, cpu, solving, batch = float("inf"), float("inf"), float("inf"), None
        for _ in range(args.repeat):
            start, start_cpu = time.perf_counter(), time.process_time()
            batch = pardel.solve_batch("fuel_nav", q0=[0, 0], qN=qN, T=30, N=args.N, threads=threads)
            best = min(best, time.perf_counter() - start)
            cpu = min(cpu, time.process_time() - start_cpu)
            solving = min(solving, batch.wall_seconds)
        if first is None:
            first = batch.q
        same = first.tobytes() == batch.q.tobytes()
        print("threads %2d: wall %.3f s (least of %d; the solves alone %.3f s), CPU %.3f s, %d of %d converged, "
              "same bits as the first: %s" % (threads, best, args.repeat, solving, cpu, int(batch.converged.sum()),
                                               len(batch), same))


if __name__ == "__main__":
    main()
