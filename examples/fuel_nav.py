"""The seed's fuel-optimal navigation example from Python: solve scenes/fuel_nav.toml and plot the
path, the coordinates and the convergence (usage: fuel_nav.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import pardel  # noqa: E402
import pardel.plot  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/fuel_nav")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

here = os.path.dirname(os.path.abspath(__file__))
result = pardel.solve_scene(pardel.load_scene(os.path.join(here, "..", "scenes", "fuel_nav.toml")))
# the same problem without the scene file:
same = pardel.solve("fuel_nav", q0=[0, 0], qN=[6, 5], T=30, N=200)
print(result)
print("fuel %.6f, boundary momenta p0 = %s, pN = %s" % (result.cost, result.p0, result.pN))
assert result.converged and abs(same.cost - result.cost) < 1e-9

pardel.plot.path(result).figure.savefig(os.path.join(out, "path.png"))
pardel.plot.coordinates(result).figure.savefig(os.path.join(out, "coordinates.png"))
pardel.plot.convergence(result).figure.savefig(os.path.join(out, "convergence.png"))
print("plots in", out)
