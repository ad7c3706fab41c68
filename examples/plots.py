"""The plotting helpers of pardel.plot: the path, the coordinates and the convergence history of
two Zermelo crossings (scenes/zermelo_1.toml's wind, two polyline guesses that lead to different
minima), drawn into one figure with ax= and written as PNG files under --out with matplotlib's
Agg backend, which needs no display (usage: plots.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")  # before pyplot is imported: files only, no window
import matplotlib.image  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pardel  # noqa: E402
import pardel.plot  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/plots")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

# Two solves of the time-optimal crossing from (0, 0) to (6, 2), one from a guess bent north
# through (3, 5), one bent south through (3, -3); the model's path parameter runs over [0, 1]
# (T = 1, docs/models.md), and the cost is the travel time.
north = pardel.solve("zermelo", q0=[0, 0], qN=[6, 2], T=1, N=80, polyline=[[0, 0], [3, 5], [6, 2]])
south = pardel.solve("zermelo", q0=[0, 0], qN=[6, 2], T=1, N=80, polyline=[[0, 0], [3, -3], [6, 2]])
print("north:", north)
print("south:", south)
assert north.converged and south.converged and abs(north.cost - south.cost) > 0.1  # two different minima

# 1. Each helper alone: without ax= it opens a new figure and returns its axes.
files = []
for name, draw in (("path", pardel.plot.path), ("coordinates", pardel.plot.coordinates),
                   ("convergence", pardel.plot.convergence)):
    ax = draw(north)
    files.append(os.path.join(out, "north_%s.png" % name))
    ax.figure.savefig(files[-1], dpi=80)
    plt.close(ax.figure)

# 2. One figure with three panels: ax= draws into a given axes, and label= names a path, so both
# crossings share the first panel.
fig, (left, middle, right) = plt.subplots(1, 3, figsize=(15, 4.5))
labels = {"north guess: travel time %.4f" % north.cost: north, "south guess: travel time %.4f" % south.cost: south}
for label, r in labels.items():
    pardel.plot.path(r, ax=left, label=label)
pardel.plot.coordinates(south, ax=middle)
pardel.plot.convergence(south, ax=right)
fig.tight_layout()
files.append(os.path.join(out, "both.png"))
fig.savefig(files[-1], dpi=80)

# Checks: the helpers drew the results' own numbers, and every file is a readable PNG image.
drawn = {line.get_label(): line.get_xydata() for line in left.get_lines()}
for label, r in labels.items():
    assert np.array_equal(drawn[label], r.q[:, :2])
residual = np.asarray(south.history["residual"])
assert np.array_equal(right.get_lines()[0].get_ydata(), residual[residual > 0])  # log scale: zeros left out
for path in files:
    image = matplotlib.image.imread(path)
    print("%s: %d x %d pixels" % (path, image.shape[1], image.shape[0]))
    assert image.ndim == 3 and min(image.shape[:2]) > 100 and image.std() > 0  # not blank
