"""A Zermelo sweep from Python: the time-optimal crossing of the four-vortex wind of
scenes/zermelo_1.toml from several polyline guesses, the distinct solutions ranked by travel time
(usage: zermelo_sweep.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import pardel  # noqa: E402
import pardel.plot  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/zermelo_sweep")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

here = os.path.dirname(os.path.abspath(__file__))
scene = pardel.load_scene(os.path.join(here, "..", "scenes", "zermelo_1.toml"))
guesses = [[[0, 0], [3, y], [6, 2]] for y in (-3, -1, 1, 3, 5)]
solutions = {}
for points in guesses:
    r = pardel.solve("zermelo", q0=[0, 0], qN=[6, 2], T=scene.info["T"], N=scene.N, polyline=points)
    print("guess through (3, %g): %s" % (points[1][1], r))
    if r.converged:
        solutions.setdefault(round(r.cost, 6), r)

_, ax = plt.subplots(figsize=(6, 5))
for cost, r in sorted(solutions.items()):
    pardel.plot.path(r, ax=ax, label="travel time %.4f" % cost)
ax.figure.savefig(os.path.join(out, "sweep.png"))
print("%d distinct solutions; plot in %s" % (len(solutions), out))
assert solutions
