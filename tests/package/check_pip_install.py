"""pardel as a pip package: creates a virtual environment in a temporary folder, installs the
package from the checkout into it (pip install --no-build-isolation --no-index, Debian's numpy and
jinja2 visible through --system-site-packages) and, from a folder outside the checkout with no
PYTHONPATH, checks that the installed package is the one imported, that it compiles and solves a
.lag text written here (a charged particle in a uniform magnetic field, which no bundled model
resembles) to its exact solution with its own pardel-gen, that it carries its type hints' marker
py.typed and the compiled core's stub _pardel.pyi, and that pardel.__version__,
importlib.metadata.version("pardel") and `pardel --version` all give the version of
project(pardel VERSION ...) in CMakeLists.txt.

usage: check_pip_install.py --source CHECKOUT --cli BUILD/pardel --work FOLDER [--cmake-build-dir BUILD]
(--work holds pip's build folder, kept between runs so that a second run rebuilds only what changed;
with --cmake-build-dir, pip builds the Python core and pardel-gen in that configured build folder).
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

# Runs inside the installed package's interpreter: solve the model, compare to the exact motion.
CHECK = r'''
import importlib.metadata, json, os, sys
import numpy as np
import pardel
import pardel._installed

B, T = 1.3, 2.0
LAG = """
model gyrating_charge
order 1
coords x y
param B = 1
L = 1/2*(x'^2 + y'^2) + B/2*(x*y' - y*x')
discretizations galerkin_gauss(s=3)
"""
r = pardel.solve(LAG, q0=[0.5, -1.0], qN=[2.0, 1.5], T=T, N=24, params={"B": B},
                 discretization="galerkin_gauss(s=3)")
# Exact: x'' = B y', y'' = -B x', so z = x + iy = a + b exp(-iBt) with z(0), z(T) given.
z0, zT = 0.5 - 1.0j, 2.0 + 1.5j
b = (zT - z0) / (np.exp(-1j * B * T) - 1)
a = z0 - b
z = a + b * np.exp(-1j * B * np.asarray(r.t))
exact = np.column_stack([z.real, z.imag])
print(json.dumps({
    "file": pardel.__file__,
    "version": pardel.__version__,
    "metadata_version": importlib.metadata.version("pardel"),
    "status": r.status,
    "nodes": len(r.t),
    "t_end": float(r.t[-1]),
    "error": float(np.max(np.abs(np.asarray(r.q) - exact))),
    "straight_line_distance": float(np.max(np.abs(exact - np.column_stack(
        [np.interp(r.t, [0, T], [0.5, 2.0]), np.interp(r.t, [0, T], [-1.0, 1.5])])))),
    "models": sorted(pardel.models()),
    "toolchain": pardel._installed.LOADER_TOOLCHAIN,
}))
'''


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--source", required=True)
    parser.add_argument("--cli", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--cmake-build-dir", help="a configured build folder for pip to build in "
                        "(PARDEL_CMAKE_BUILD_DIR) instead of configuring one of its own in --work")
    args = parser.parse_args()
    source = os.path.abspath(args.source)
    os.makedirs(args.work, exist_ok=True)
    with open(os.path.join(source, "CMakeLists.txt"), encoding="utf-8") as f:
        version = re.search(r"^project\(\s*pardel\s+VERSION\s+([0-9.]+)", f.read(), re.MULTILINE).group(1)

    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PARDEL_PIP_BUILD_DIR"] = os.path.join(os.path.abspath(args.work), "pip-build")
    if args.cmake_build_dir:
        env["PARDEL_CMAKE_BUILD_DIR"] = os.path.abspath(args.cmake_build_dir)
    with tempfile.TemporaryDirectory(prefix="pardel-pip-") as tmp:
        venv = os.path.join(tmp, "venv")
        subprocess.run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", venv], check=True, env=env)
        python = os.path.join(venv, "bin", "python")
        started = time.monotonic()
        subprocess.run([python, "-m", "pip", "install", "--no-build-isolation", "--no-index", "--progress-bar", "off",
                        source], check=True, env=env)
        print("pip install: %.0f s" % (time.monotonic() - started))

        outside = os.path.join(tmp, "elsewhere")
        os.makedirs(outside)
        env["PARDEL_CACHE_DIR"] = os.path.join(tmp, "cache")
        out = subprocess.run([python, "-c", CHECK], cwd=outside, env=env, check=True, stdout=subprocess.PIPE,
                             universal_newlines=True).stdout
        print(out)
        import json
        got = json.loads(out.strip().splitlines()[-1])

        if not os.path.realpath(got["file"]).startswith(os.path.realpath(venv) + os.sep):
            fail("pardel was imported from %s, not from the virtual environment %s" % (got["file"], venv))
        package = os.path.dirname(got["file"])
        for tool in ("_toolchain/bin/pardel-gen", "_toolchain/codegen/render.py",
                     "_toolchain/codegen/templates/model.cpp.j2", "_toolchain/include/pardel/kernel_abi.h",
                     "py.typed", "_pardel.pyi", "_sympy.py", "plot.py"):
            if not os.path.isfile(os.path.join(package, tool)):
                fail("the installed package has no %s" % tool)
        for tool, path in got["toolchain"].items():
            if tool != "python" and tool != "compiler" and not os.path.realpath(path).startswith(
                    os.path.realpath(package) + os.sep):
                fail("the installed package compiles .lag files with %s %s, not with its own" % (tool, path))
        if not os.access(os.path.join(package, "_toolchain/bin/pardel-gen"), os.X_OK):
            fail("the installed pardel-gen is not executable")
        if "fuel_nav" not in got["models"]:
            fail("the bundled model fuel_nav is not among the installed package's models: %r" % got["models"])
        if got["status"] != "converged":
            fail("the .lag text's solve ended %r" % got["status"])
        if got["nodes"] != 25 or abs(got["t_end"] - 2.0) > 1e-12:
            fail("expected 25 nodes up to t = 2, got %d up to %r" % (got["nodes"], got["t_end"]))
        # Order 6 at h = 1/12: the error at the nodes is near 1e-9; the exact motion is ~0.8 away
        # from the straight line between the ends, which is what a solve that did nothing returns.
        if not got["error"] < 1e-7:
            fail("largest error against the exact motion %.3g (expected < 1e-7)" % got["error"])
        if not got["straight_line_distance"] > 0.1:
            fail("the exact motion is too close to a straight line to tell a solve from none")

        cli = subprocess.run([args.cli, "--version"], check=True, stdout=subprocess.PIPE,
                             universal_newlines=True).stdout.strip()
        versions = {"CMakeLists.txt": version, "pardel.__version__": got["version"],
                    "importlib.metadata.version": got["metadata_version"], "pardel --version": cli}
        print(versions)
        if cli != "pardel " + version or got["version"] != version or got["metadata_version"] != version:
            fail("the versions disagree: %r" % versions)
    print("OK")


if __name__ == "__main__":
    main()
