"""pardel from Python: solve the discrete Euler-Lagrange boundary-value problems of variational
integrators from NumPy arrays, with the bundled models, .lag files or .lag text. Example::

    import pardel
    r = pardel.solve("fuel_nav", q0=[0, 0], qN=[6, 5], T=30, N=200)
    r.status, r.cost, r.q          # "converged", the fuel, an (N+1) x dim array

Everything here checks its arguments (TypeError for a wrong type, ValueError for a bad value,
naming the argument) and translates to the compiled core (pardel._pardel), which calls the pardel
runtime, the model loader and the scene reader that `pardel solve` uses: the remaining checks,
their messages and the numbers are the command line's.

The public functions and classes carry type hints (the package has a py.typed marker, and the
compiled core a stub, _pardel.pyi), and help() describes each of them.
"""
from __future__ import annotations

import os
# The names the public classes' attribute annotations use (resolved in this module: see below).
from typing import Any, Dict, List, Optional  # noqa: F401

import numpy as np  # noqa: F401

# OpenMP threads wait passively (sleep) between parallel loops unless the user chose otherwise:
# spinning threads cost a scheduler quantum per loop where another process keeps a core busy (as
# the command line, docs/solvers.md). OpenMP reads this when its library is loaded: by the import
# below, unless something imported before pardel loaded it already.
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "passive"

from . import _pardel  # noqa: E402
from ._pardel import CheckpointError, ModelError, ModelWarning, PardelError, SceneError  # noqa: E402

# The compiled core's exceptions, described for help().
PardelError.__doc__ = ("A bad value given to pardel (a ValueError): the message starts with the function and names "
                       "the argument, or is the command line's message for input the runtime refuses.")
SceneError.__doc__ = ("A scene pardel's scene reader refuses (a PardelError): the message is the command line's "
                      "FILE:LINE:COL: error: ..., or --set KEY=VALUE: error: ... for an override.")
ModelError.__doc__ = ("A model that cannot be loaded (a PardelError): a malformed or irregular .lag (the generator's "
                      "FILE:LINE:COL: error: ... with its caret line), a failed compile, or a cache folder refused.")
CheckpointError.__doc__ = ("A checkpoint that cannot be written or resumed (a PardelError): the message is "
                           "`pardel solve --resume`'s FOLDER/checkpoint.json: error: ... (missing, truncated or "
                           "corrupted, of another scene or model, not fitting the scene), or names a checkpoint "
                           "folder that cannot be made.")

# The version of project(pardel VERSION ...) in the top-level CMakeLists.txt, compiled into the core
# (also what `pardel --version` prints and what pip records for the package).
__version__ = _pardel.__version__

# An installed package compiles .lag files with the installed pardel-gen and render script, which
# _installed.py names (written by `cmake --install`, or by setup.py for `pip install`: then the
# package's own copies beside it); the build tree's package uses the build tree's.
try:
    from ._installed import LOADER_TOOLCHAIN as _INSTALLED_TOOLCHAIN
except ImportError:
    _INSTALLED_TOOLCHAIN = None  # type: ignore[assignment]
if _INSTALLED_TOOLCHAIN:
    _pardel.set_loader_toolchain(**_INSTALLED_TOOLCHAIN)

from ._checks import _MAX_N  # noqa: E402,F401  (the scene reader's bound of grid.N)
from ._models import Model, lag_cache_dir, model, model_from_sympy, models  # noqa: E402
# _interrupted: what a pickled Interrupted is rebuilt by (pardel._interrupted)
from ._results import (BatchResult, Interrupted, Result, SweepResult, SweepSolution, SweepVariant,  # noqa: E402
                       _interrupted)
from ._solve import Scene, check, kernels, load_scene, resume, solve, solve_batch, solve_scene, sweep  # noqa: E402
from ._types import ArrayLike, Guess, ModelLike, OnIteration, Params, PathArg  # noqa: E402,F401
from . import plot  # noqa: E402,F401  (pardel.plot after `import pardel`; matplotlib is imported when it draws)

__all__ = [
    "Model", "Result", "Scene", "PardelError", "SceneError", "ModelError", "ModelWarning", "CheckpointError",
    "Interrupted", "model", "model_from_sympy", "models", "solve", "resume", "load_scene", "solve_scene", "check",
    "kernels", "lag_cache_dir",
    "sweep", "SweepResult", "SweepVariant", "SweepSolution", "solve_batch", "BatchResult",
]

# The public classes and functions are pardel's, wherever their code lies: their reprs, pickles and
# help() name pardel.X, and a class's attribute annotations resolve (typing.get_type_hints) in this
# module, which holds the names they use (np, Any, Dict, List, Optional).
for _public in (Model, Result, Scene, Interrupted, BatchResult, SweepResult, SweepVariant, SweepSolution,
                _interrupted, model, model_from_sympy, models, solve, resume, load_scene, solve_scene, check,
                kernels, lag_cache_dir, sweep, solve_batch):
    _public.__module__ = __name__
del _public
