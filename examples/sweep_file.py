"""A sweep file run from Python: scenes/sweeps/zermelo_50.toml (the Zermelo crossing from 50 random
polyline guesses) through pardel.sweep, the same sweep as `pardel sweep`, its distinct solutions
ranked by travel time and drawn (usage: sweep_file.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/sweep_file")
out = parser.parse_args().out

here = os.path.dirname(os.path.abspath(__file__))
result = pardel.sweep(os.path.join(here, "..", "scenes", "sweeps", "zermelo_50.toml"), out=out)
print(result)
for s in result.solutions:
    print("solution %d: %s = %.10g, reached by %d variants, %s" % (s.id, result.cost_name, s.cost, len(s.variants),
                                                                  s.certificate))

_, ax = plt.subplots(figsize=(6, 5))
others = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:gray", "tab:olive"]
for i, s in enumerate(result.solutions):
    best = s is result.best
    ax.plot(s.q[:, 0], s.q[:, 1], "-", color="tab:red" if best else others[i % len(others)], lw=2.5 if best else 1,
            label="%s %.4f" % (result.cost_name.replace("_", " "), s.cost))
ax.set_aspect("equal", adjustable="datalim")
ax.legend(loc="best", fontsize="small")
ax.figure.savefig(os.path.join(out, "solutions.png"))
print("files and plot in", out)
assert result.solutions
