"""A parameter study from Python: the fuel of the navigation example of scenes/fuel_nav.toml as
the final time T varies from 8 to 30, each solve started from the previous answer
(usage: parameter_study.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/parameter_study")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

model = pardel.model("fuel_nav")
print(model)
values = np.linspace(8, 30, 12)
fuel, previous = [], None
for T in values:
    r = pardel.solve(model, q0=[0, 0], qN=[6, 5], T=T, N=200, guess=None if previous is None else previous.q)
    print("T = %5.2f: %s" % (T, r))
    assert r.converged
    fuel.append(r.cost)
    previous = r

_, ax = plt.subplots()
ax.plot(values, fuel, "o-")
ax.set_xlabel("T")
ax.set_ylabel("fuel")
ax.figure.savefig(os.path.join(out, "fuel_vs_T.png"))
print("plot in", out)
