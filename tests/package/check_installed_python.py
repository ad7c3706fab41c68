"""The installed Python module pardel (package test, installed mode): imported from the prefix
alone, it compiles a .lag file with the installed pardel-gen and render script (not the build
tree's) and solves it; the projectile's end momenta equal the exact velocities. The package carries
its pure-Python modules, the type hints' marker py.typed and the compiled core's stub _pardel.pyi.

usage: check_installed_python.py PREFIX PROJECTILE_LAG   (PYTHONPATH names the installed package)
"""
import os
import sys

import numpy as np

import pardel

prefix, lag = os.path.realpath(sys.argv[1]), sys.argv[2]
module = os.path.realpath(pardel.__file__)
assert module.startswith(prefix + os.sep), "pardel imported from %s, not from %s" % (module, prefix)
for name in ("py.typed", "_pardel.pyi", "_sympy.py", "plot.py"):  # the type hints' marker, the core's stub
    assert os.path.isfile(os.path.join(os.path.dirname(module), name)), "the installed package has no %s" % name
toolchain = pardel._pardel.loader_toolchain()
for key in ("generator", "render_script", "abi_include"):
    path = os.path.realpath(toolchain[key])
    assert path.startswith(prefix + os.sep), "%s is %s, outside %s" % (key, path, prefix)
    assert os.path.exists(path), "%s %s does not exist" % (key, path)

g, T = 3.7, 2.0
r = pardel.solve(lag, q0=[0, 0], qN=[4, 1], T=T, N=40, params={"g": g}, tol=1e-12)
assert r.status == "converged", r.message
b = (1 + 2 * g) / 2
np.testing.assert_allclose(r.q[:, 1], b * r.t - g * r.t**2 / 2, atol=1e-9)
np.testing.assert_allclose(r.p0, [2, b], atol=1e-9)
np.testing.assert_allclose(r.pN, [2, b - g * T], atol=1e-9)
print("installed module: %s, compiled with %s" % (module, toolchain["generator"]))
