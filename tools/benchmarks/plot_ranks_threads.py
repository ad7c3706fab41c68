#!/usr/bin/env python3
"""Draws the ranks x threads chart of docs/benchmarks.md from docs/images/bench_ranks_threads.csv
(time per iteration of the distributed solve at N = 1e6, measured with mpi_distributed_timing,
on an idle and on a loaded machine)."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
IMAGES = os.path.join(ROOT, "docs", "images")


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(IMAGES, "bench_ranks_threads.csv")
    rows = list(csv.DictReader(open(src)))
    methods = sorted({r["method"] for r in rows})
    configs = sorted({(int(r["ranks"]), int(r["threads"])) for r in rows})
    conditions = sorted({r["condition"] for r in rows})
    width = 0.8 / len(conditions)
    fig, axes = plt.subplots(1, len(methods), figsize=(5.5 * len(methods), 4))
    for ax, method in zip(axes if len(methods) > 1 else [axes], methods):
        for c, condition in enumerate(conditions):
            for i, (ranks, threads) in enumerate(configs):
                times = [float(r["ms_per_iteration"]) for r in rows
                         if r["method"] == method and r["condition"] == condition
                         and int(r["ranks"]) == ranks and int(r["threads"]) == threads]
                if not times:
                    continue
                x = i + (c - (len(conditions) - 1) / 2) * width
                ax.bar(x, sum(times) / len(times), width=width, color="C%d" % c, alpha=0.6,
                       label=condition if i == 0 else None)
                ax.plot([x] * len(times), times, "k.")
        ax.set_xticks(range(len(configs)), [f"{r} rank(s) x {t} thread(s)" for r, t in configs], fontsize=8)
        ax.set_ylabel("ms per iteration (dots: rounds)")
        ax.set_title(f"{method}, fuel_nav, N = 10^6, 2-core machine", fontsize=9)
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = os.path.join(IMAGES, "bench_ranks_threads.png")
    fig.savefig(out, dpi=110)
    print("wrote", os.path.relpath(out, ROOT))


if __name__ == "__main__":
    main()
