"""A batch of problems in one call: pardel.solve_batch solves 200 harmonic oscillators (the bundled
model harmonic, L = (x'^2 - omega^2 x^2)/2) that differ in their frequency and end points, several
at a time on the machine's cores, and checks every answer against the exact solution of the
discrete equations and the continuous motion x(t) = A cos(omega t) + B sin(omega t)
(usage: batch.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/batch")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

B, T, N = 200, 1.0, 100
rng = np.random.default_rng(7)
omega = rng.uniform(0.5, 2.5, B)  # omega T < pi: each problem has exactly one solution
x0 = rng.uniform(-1, 1, (B, 1))  # q0 and qN: one row per problem (a single point would serve all)
xT = rng.uniform(-1, 1, (B, 1))

# One call: the per-problem arguments carry the batch axis first; T, N and the options are shared.
batch = pardel.solve_batch("harmonic", q0=x0, qN=xT, T=T, N=N, params={"omega": omega})
print(batch)
print("statuses:", dict(zip(*np.unique(batch.status.astype(str), return_counts=True))))
print("iterations: %d to %d" % (batch.iterations.min(), batch.iterations.max()))
assert batch.converged.all()
assert batch.q.shape == (B, N + 1, 1)

# Independent truth 1, the discrete equations solved by hand. The default discretization of
# harmonic is trapezoid, L_d(q0, q1) = h L(q0, v)/2 + h L(q1, v)/2 with v = (q1 - q0)/h; its
# discrete Euler-Lagrange equation q_{k+1} - 2 q_k + q_{k-1} = -(omega h)^2 q_k is solved exactly
# by q_k = a cos(k theta) + b sin(k theta) with cos(theta) = 1 - (omega h)^2/2. The batch must
# match it to the solver's tolerance.
h = T / N
k = np.arange(N + 1)
theta = np.arccos(1 - (omega * h) ** 2 / 2)
b = (xT[:, 0] - x0[:, 0] * np.cos(N * theta)) / np.sin(N * theta)
discrete = x0[:, 0, None] * np.cos(np.outer(theta, k)) + b[:, None] * np.sin(np.outer(theta, k))
discrete_error = np.max(np.abs(batch.q[:, :, 0] - discrete))
print("largest difference from the exact discrete solution: %.2e" % discrete_error)
assert discrete_error < 1e-10

# Independent truth 2, the continuous motion through the same end points. Trapezoid is second
# order: the error is O((omega h)^2), here at most (2.5 * 0.01)^2 = 6e-4 times a factor of order 1.
t = batch.t[0]
B_coef = (xT[:, 0] - x0[:, 0] * np.cos(omega * T)) / np.sin(omega * T)
exact = x0[:, 0, None] * np.cos(np.outer(omega, t)) + B_coef[:, None] * np.sin(np.outer(omega, t))
error = np.max(np.abs(batch.q[:, :, 0] - exact), axis=1)
print("largest error against x(t) = A cos(omega t) + B sin(omega t): %.2e (problem %d, omega = %.3f)" % (
    error.max(), error.argmax(), omega[error.argmax()]))
print("largest error / (omega h)^2: %.3f" % np.max(error / (omega * h) ** 2))
assert np.all(error < (omega * h) ** 2)

# Each problem of the batch is, bit for bit, what pardel.solve gives for it alone with threads=1.
i = int(error.argmax())
alone = pardel.solve("harmonic", q0=x0[i], qN=xT[i], T=T, N=N, params={"omega": omega[i]}, threads=1)
print("problem %d alone: %s" % (i, alone))
assert np.array_equal(alone.q, batch[i].q) and alone.iterations == batch[i].iterations

_, ax = plt.subplots()
ax.semilogy(omega, error, ".")
ax.set_xlabel("omega")
ax.set_ylabel("max |x_k - x(t_k)|")
ax.set_title("%d harmonic oscillators in one batch, N = %d" % (B, N))
ax.figure.savefig(os.path.join(out, "errors.png"))
print("plot in", out)
