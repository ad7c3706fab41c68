"""setuptools build of the Python package pardel (`pip install .`, see pyproject.toml): configures
pardel with CMake (no tests, no benchmarks), builds only the compiled core pardel._pardel and the
generator pardel-gen, and puts into the package everything it needs at run time: the core (the
bundled models are linked into it), pardel-gen, the render script with its templates and the
headers that kernels compile against, under pardel/_toolchain/, and _installed.py naming them, so
that .lag files and .lag text compile from the installed package alone.

Offline, against Debian 12's packages: pip install --no-build-isolation .
Environment: PARDEL_PIP_BUILD_DIR, the build folder (default build/python-package in the
checkout; CMake builds in its subfolder cmake/, kept between installs so a second one rebuilds
only what changed); PARDEL_CMAKE_BUILD_DIR, instead, a build folder of pardel's already configured
(with the Python module for this interpreter's version and GiNaC), in which the two targets are
built without configuring it again; CMAKE_BUILD_PARALLEL_LEVEL, the build's parallel jobs (default: the CPU
count); CMAKE_ARGS, more arguments for CMake's configure step.
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))
BUILD_BASE = os.path.abspath(os.environ.get("PARDEL_PIP_BUILD_DIR") or os.path.join(ROOT, "build", "python-package"))
os.makedirs(BUILD_BASE, exist_ok=True)


def project_version():
    """The one version of pardel: project(pardel VERSION X.Y.Z) in the top-level CMakeLists.txt."""
    with open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8") as f:
        match = re.search(r"^project\(\s*pardel\s+VERSION\s+([0-9]+(?:\.[0-9]+)*)", f.read(), re.MULTILINE)
    if not match:
        raise RuntimeError("CMakeLists.txt: no `project(pardel VERSION X.Y.Z ...)` line to take the version from")
    return match.group(1)


def cmake_cache(build_dir):
    """CMakeCache.txt of `build_dir` as a dict NAME -> value."""
    values = {}
    with open(os.path.join(build_dir, "CMakeCache.txt"), encoding="utf-8") as f:
        for line in f:
            match = re.match(r"^([A-Za-z0-9_.+-]+):[A-Z_]+=(.*)$", line.rstrip("\n"))
            if match:
                values[match.group(1)] = match.group(2)
    return values


INSTALLED_PY = '''\
# Where the pip-installed package pardel finds the tools that compile .lag files: its own copies in
# _toolchain/ beside this file. Written by setup.py.
import os
import sys

_toolchain = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_toolchain")
LOADER_TOOLCHAIN = {
    "generator": os.path.join(_toolchain, "bin", "pardel-gen"),
    # The render script needs jinja2, a dependency of this package in this interpreter's environment.
    "python": sys.executable,
    "render_script": os.path.join(_toolchain, "codegen", "render.py"),
    "compiler": %r,
    "abi_include": os.path.join(_toolchain, "include"),
}
'''


class CMakeExtension(Extension):
    """pardel._pardel, built by CMake (target pardel_python), not by setuptools."""

    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        cmake = shutil.which("cmake")
        if not cmake:
            raise RuntimeError("pardel: cmake was not found on PATH (Debian: apt-get install cmake, or "
                               "bash tools/install-deps.sh)")
        existing = os.environ.get("PARDEL_CMAKE_BUILD_DIR")
        if existing:  # a configured build tree of pardel's: build there, leave its configuration alone
            build_dir = os.path.abspath(existing)
            if not os.path.isfile(os.path.join(build_dir, "CMakeCache.txt")):
                raise RuntimeError("pardel: PARDEL_CMAKE_BUILD_DIR=%s is not a configured CMake build folder "
                                   "(no CMakeCache.txt)" % existing)
        else:
            build_dir = os.path.join(BUILD_BASE, "cmake")
            self.configure(cmake, build_dir)
        self.build_targets(cmake, build_dir, ext)

    def configure(self, cmake, build_dir):
        os.makedirs(build_dir, exist_ok=True)
        configure = [cmake, "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
                     "-DPARDEL_CLI_ONLY=OFF", "-DPARDEL_BUILD_TESTS=OFF", "-DPARDEL_BUILD_BENCHMARKS=OFF",
                     "-DPARDEL_BUILD_PYTHON=ON",
                     "-DPython3_EXECUTABLE=" + sys.executable]
        if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")) and shutil.which("ninja"):
            configure += ["-G", "Ninja"]
        try:  # pybind11 of this environment (pip's, in an isolated online build; Debian's otherwise)
            import pybind11
            configure.append("-Dpybind11_DIR=" + pybind11.get_cmake_dir())
        except ImportError:
            pass
        configure += shlex.split(os.environ.get("CMAKE_ARGS", ""))
        subprocess.run(configure, check=True)

    def build_targets(self, cmake, build_dir, ext):
        cache = cmake_cache(build_dir)
        if not cache.get("PARDEL_PYTHON_PACKAGE_DIR"):
            raise RuntimeError("pardel: CMake skipped the Python module for %s (see its message above: it needs "
                               "pybind11 and this Python's headers; Debian: apt-get install pybind11-dev "
                               "python3-pybind11 python3-dev)" % sys.executable)
        if cache.get("GINAC_FOUND") != "1":
            raise RuntimeError("pardel: GiNaC was not found, so pardel-gen cannot be built and the package could "
                               "not compile .lag files (Debian: apt-get install libginac-dev libcln-dev pkg-config)")
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        subprocess.run([cmake, "--build", build_dir, "--target", "pardel_python", "pardel-gen", "--parallel", jobs],
                       check=True)

        # The core, where setuptools expects the extension; the toolchain beside it.
        target = self.get_ext_fullpath(ext.name)
        package = os.path.dirname(target)
        os.makedirs(package, exist_ok=True)
        core_dir = cache["PARDEL_PYTHON_PACKAGE_DIR"]
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        cores = [f for f in os.listdir(core_dir) if f == "_pardel" + suffix]
        if not cores:
            raise RuntimeError("pardel: no compiled core _pardel%s for this Python (%s) in %s: the build folder is "
                               "configured for another Python (Python3_EXECUTABLE)" % (suffix, sys.executable, core_dir))
        shutil.copy2(os.path.join(core_dir, cores[0]), target)

        toolchain = os.path.join(package, "_toolchain")
        shutil.rmtree(toolchain, ignore_errors=True)
        os.makedirs(os.path.join(toolchain, "bin"))
        shutil.copy2(os.path.join(build_dir, "pardel-gen"), os.path.join(toolchain, "bin", "pardel-gen"))
        shutil.copytree(os.path.join(ROOT, "codegen", "templates"), os.path.join(toolchain, "codegen", "templates"),
                        ignore=lambda folder, names: [n for n in names if not n.endswith(".j2")])
        shutil.copy2(os.path.join(ROOT, "codegen", "render.py"), os.path.join(toolchain, "codegen", "render.py"))
        shutil.copytree(os.path.join(ROOT, "runtime", "include", "pardel"), os.path.join(toolchain, "include", "pardel"))
        with open(os.path.join(package, "_installed.py"), "w", encoding="utf-8") as f:
            f.write(INSTALLED_PY % cache["CMAKE_CXX_COMPILER"])


setup(
    version=project_version(),
    packages=["pardel"],
    package_dir={"": "python"},
    # The type hints' marker (PEP 561) and the stub of the compiled core.
    package_data={"pardel": ["py.typed", "_pardel.pyi"]},
    ext_modules=[CMakeExtension("pardel._pardel")],
    cmdclass={"build_ext": CMakeBuild},
    zip_safe=False,
    # setuptools' build folder and its metadata (pardel.egg-info) go to BUILD_BASE, not into the
    # checkout's build/ (CMake's) or python/.
    options={"build": {"build_base": BUILD_BASE}, "egg_info": {"egg_base": BUILD_BASE}},
)
