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

import atexit
import hashlib
import json
import numbers
import os
import shutil
import stat
import tempfile
from typing import TYPE_CHECKING, Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

if TYPE_CHECKING:
    import sympy  # model_from_sympy's annotations (SymPy is imported by that function alone)
try:
    from numpy.typing import ArrayLike
except ImportError:  # NumPy before 1.20
    ArrayLike = Any  # type: ignore[misc]

# The annotations' names for the arguments (typing.get_type_hints resolves them):
# a model: a bundled model's name, a .lag path, .lag text or a Model;
ModelLike = Union[str, "os.PathLike[str]", "Model"]
# a path;
PathArg = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
# an initial guess: an (M+1) x dim array or a previous Result;
Guess = Union[ArrayLike, "Result", None]
# on_iteration(iteration, N, residual, action): a false return stops the solve;
OnIteration = Callable[[int, int, float, float], Any]
# params: numbers by name, or numbers in declaration order.
Params = Union[Mapping[str, float], Sequence[float], np.ndarray]

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

__all__ = [
    "Model", "Result", "Scene", "PardelError", "SceneError", "ModelError", "ModelWarning", "CheckpointError",
    "Interrupted", "model", "model_from_sympy", "models", "solve", "resume", "load_scene", "solve_scene", "check",
    "kernels", "lag_cache_dir",
    "sweep", "SweepResult", "SweepVariant", "SweepSolution", "solve_batch", "BatchResult",
]


def lag_cache_dir() -> str:
    """The folder of compiled models (the model loader's): $PARDEL_CACHE_DIR, else
    $XDG_CACHE_HOME/pardel, else $HOME/.cache/pardel; with none of them set, a private folder of
    this process (tempfile.mkdtemp, removed at exit), so nothing is reused between processes."""
    global _process_cache
    if os.environ.get("PARDEL_CACHE_DIR"):
        return os.environ["PARDEL_CACHE_DIR"]
    if os.environ.get("XDG_CACHE_HOME"):
        return os.path.join(os.environ["XDG_CACHE_HOME"], "pardel")
    if os.environ.get("HOME"):
        return os.path.join(os.environ["HOME"], ".cache", "pardel")
    if _process_cache is None:
        folder = tempfile.mkdtemp(prefix="pardel-cache-")
        atexit.register(shutil.rmtree, folder, True)
        _process_cache = folder
    return _process_cache


_process_cache: Optional[str] = None


def _private_folder(path):
    """Creates the cache folder `path` (mode 0700) if missing and checks that it is this user's
    alone: not a symbolic link, owned by this user, writable by no one else (as the model loader
    checks the cache). Raises ModelError naming the path and the reason otherwise."""
    path = path.rstrip("/") or "/"
    parent = os.path.dirname(path)
    if parent:
        os.makedirs(parent, exist_ok=True)
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    st = os.lstat(path)
    why = None
    if stat.S_ISLNK(st.st_mode):
        why = "a symbolic link"
    elif not stat.S_ISDIR(st.st_mode):
        why = "not a folder"
    elif st.st_uid != os.geteuid():
        why = "owned by user %d, not by this user (%d)" % (st.st_uid, os.geteuid())
    elif st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        why = "writable by %s (mode %04o)" % (
            "its group and by others" if st.st_mode & stat.S_IWGRP and st.st_mode & stat.S_IWOTH
            else "its group" if st.st_mode & stat.S_IWGRP else "others", stat.S_IMODE(st.st_mode))
    if why:
        raise ModelError("refusing the model cache folder %s: it is %s; a model cache must be a folder "
                         "of this user's that no one else can write (chmod 700 it, or set "
                         "PARDEL_CACHE_DIR to another folder)" % (path, why))
    return path


def _lag_text_file(text):
    """Writes .lag text to <cache>/lag-text/<hash>.lag and returns the path. The file is written
    afresh on every call (privately, mode 0600, flushed, then renamed over the old one), so a file
    edited since an earlier call is replaced, never compiled."""
    data = text.encode("utf-8")
    digest = hashlib.sha256(data).hexdigest()[:16]
    folder = _private_folder(os.path.join(_private_folder(lag_cache_dir()), "lag-text"))
    path = os.path.join(folder, digest + ".lag")
    fd, tmp = tempfile.mkstemp(prefix=digest + ".lag.tmp.", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _model_spec(spec):
    """The loader's spec for a model given as a Model, a bundled name, a .lag path or .lag text
    (a string with a line break)."""
    if isinstance(spec, Model):
        return spec.spec
    if isinstance(spec, os.PathLike):
        spec = os.fspath(spec)
    if not isinstance(spec, str):
        raise TypeError("model: a name, a .lag path, .lag text or a pardel.Model was expected")
    if "\n" in spec:
        return _lag_text_file(spec)
    if spec.endswith(".lag") or "/" in spec:
        return os.path.abspath(spec)
    return spec


class Model:
    """A compiled model: name, coords, order, ncoords (len(coords)), dim (ncoords x order: the values
    of a node), params (name -> default, in declaration order), discretizations, has_clock (whether
    it declares a clock), time_dependent (whether L or the clock uses t), source (the .lag file it
    was generated from, as the generator recorded it) and spec (what the loader loaded: the name,
    the absolute path, or the cache file of the text).

    lag_text is the .lag text it was built from (for .lag text and pardel.model_from_sympy; None for
    a bundled name or a .lag path). A Model pickles as what it was built from (the name, the absolute
    path or the text), and unpickling loads it again (compiling it, or finding it in the cache,
    in the process that unpickles: a path is read again there)."""

    name: str
    coords: List[str]
    order: int
    ncoords: int
    dim: int
    params: Dict[str, float]
    discretizations: List[str]
    has_clock: bool
    time_dependent: bool
    source: str
    spec: str
    lag_text: Optional[str]

    def __init__(self, spec: ModelLike) -> None:
        _check_model("pardel.model", "spec", spec)
        if isinstance(spec, Model):
            self.lag_text = spec.lag_text
        elif isinstance(spec, str) and "\n" in spec:
            self.lag_text = spec
        else:
            self.lag_text = None
        self.spec = _model_spec(spec)
        self._handle = _pardel.load_model(os.fsencode(self.spec))  # a path's bytes, also when not UTF-8
        info = self._handle.info()
        self.name = info["name"]
        self.source = info["source"]
        self.order = info["order"]
        self.ncoords = info["ncoords"]
        self.dim = info["dim"]
        self.coords = list(info["coords"])
        self.params = dict(info["params"])
        self.discretizations = list(info["discretizations"])
        self.has_clock = info["has_clock"]
        self.time_dependent = info["time_dependent"]

    def __repr__(self) -> str:
        return "pardel.Model(%r: coords %s, order %d, params %s, discretizations %s)" % (
            self.name, self.coords, self.order, self.params, self.discretizations)

    def __reduce__(self) -> Tuple[Any, Tuple[str]]:
        # What it was built from; the compiled handle is this process's alone.
        return (Model, (self.spec if self.lag_text is None else self.lag_text,))


def model(spec: ModelLike) -> Model:
    """The model of a bundled name, a .lag path, or .lag text (compiled on first use, cached in
    lag_cache_dir())."""
    return Model(spec)


def model_from_sympy(L: sympy.Expr, coords: Union[Sequence[sympy.Expr], sympy.Expr],
                     params: Optional[Mapping[Union[sympy.Symbol, str], Union[float, sympy.Expr]]] = None, *,
                     order: Optional[int] = None, name: str = "sympy_model",
                     discretizations: Optional[Sequence[str]] = None, clock: Optional[sympy.Expr] = None,
                     cost: Optional[Tuple[str, str]] = None, allow_singular: bool = False) -> Model:
    """A model from a Lagrangian written with SymPy: L is printed as .lag text (Model.lag_text) and
    compiled as pardel.model compiles .lag text, so its kernels are those of the same model written
    by hand.

    L: a SymPy expression in the coordinates, their time derivatives, the time and the params.
    coords: the coordinates, functions of one time symbol: sympy.Function("x")(t) (or
    sympy.physics.mechanics.dynamicsymbols("x")); derivatives are x.diff(t), x.diff(t, 2), ...
    (x', x'' in .lag), and the time symbol elsewhere in L is .lag's t. params: a dict {symbol or
    name: default} in declaration order, the default a real number or a constant SymPy expression
    (sympy.pi / 4); a symbol of L whose name is a param's is that param. order: the highest
    derivative L may use (default: the highest in L, at least 1). name: the model's name.
    discretizations: a list of names ("midpoint", "galerkin_gauss(s=4)"; docs/discretizations.md),
    None for the generator's default. clock: dt/ds (a SymPy expression, as L). cost: (name,
    "action" or "clock"). allow_singular: True writes "# pardel: allow-singular".

    Raises TypeError for an argument of the wrong type and PardelError (a ValueError) for what .lag
    cannot write (a function other than .lag's, a symbol that is neither the time nor a param, a
    function that is not a coordinate, a complex or infinite number), each naming the argument;
    pardel.ModelError when the generator refuses the model (one that is not regular, say).
    """
    from . import _sympy  # SymPy is needed for this function alone
    return Model(_sympy.lag_text("pardel.model_from_sympy", L, coords, params, order, name, discretizations,
                                 clock, cost, allow_singular))


def models() -> List[str]:
    """The names of the bundled models."""
    return list(_pardel.bundled_models())


class Scene:
    """A scene read and checked by pardel's scene reader (from a TOML file or from solve's
    arguments): model (the model's name), N, and info, a dict of its problem and options (path,
    model, model_spec, discretization, params by name, knots, clock, method, tol, rtol,
    max_iterations, threads, output_dir, T, N, ...)."""

    model: str
    N: int
    info: Dict[str, Any]

    def __init__(self, core: _pardel.Scene) -> None:
        self._core = core
        # What a checkpoint of its solve records: the scene file (absolute bytes) and overrides it
        # was read with (load_scene), or the scene text pardel.solve made; None for neither.
        self._file: Optional[bytes] = None
        self._overrides: List[str] = []
        self._text: Optional[str] = None
        self.info = core.info()
        self.model = self.info["model"].name
        self.N = self.info["N"]

    def __repr__(self) -> str:
        return "pardel.Scene(%r: model %s, N = %d, T = %g)" % (self.info["path"], self.model, self.N, self.info["T"])


def load_scene(path: PathArg, overrides: Sequence[str] = ()) -> Scene:
    """Reads a scene file; `overrides` are "key.path=value" strings, as `pardel solve --set` takes."""
    _check_path("pardel.load_scene", "path", path)
    overrides = _check_overrides("pardel.load_scene", "overrides", overrides)
    scene = Scene(_pardel.load_scene(os.fsencode(path), overrides))  # bytes: a path need not be UTF-8
    scene._file, scene._overrides = os.path.abspath(os.fsencode(path)), list(overrides)
    return scene


class Result:
    """What a solve returned.

    t (N+1 node times), q ((N+1) x dim: coords, then derivatives for order >= 2), status (the
    summary.json status: converged, max_iterations, diverged, non_finite, interrupted, stalled),
    message, iterations, residual, action, cost (the physical cost's value; cost_name,
    cost_definition), point (kind, inertia, lambda_min, ... as in summary.json), p0 and pN (the
    discrete boundary momenta -D1 Ld(q0, q1) and D2 Ld(q_{N-1}, q_N)), history (arrays iteration,
    N, residual, action, seconds), error_estimate (Richardson's estimate of the discretization error
    of the coordinates at the nodes, NaN when not estimated), error_by_coordinate (dict by name,
    empty when not estimated), error_note (how it was made, or "not estimated: " and why),
    extrapolated (whether q holds the extrapolated values), grid_sizes and grid_note (an adaptive
    solve's grids, in order, and its outcome; empty otherwise), method, N, final_time,
    wall_seconds, model (the model's name), coords (its coordinate names), stopped_by_callback
    (whether on_iteration stopped the solve), checkpoint (the folder of the checkpoint this
    interrupted solve wrote, or None), summary (the whole summary.json dictionary);
    converged (status == "converged") and coordinate(name). A Result pickles whole.
    """

    t: np.ndarray
    q: np.ndarray
    p0: np.ndarray
    pN: np.ndarray
    history: Dict[str, np.ndarray]
    coords: List[str]
    status: str
    message: str
    iterations: int
    residual: Optional[float]
    action: Optional[float]
    cost: Optional[float]
    cost_name: str
    cost_definition: str
    point: Dict[str, Any]
    error_estimate: float
    error_by_coordinate: Dict[str, float]
    error_note: str
    extrapolated: bool
    grid_sizes: List[int]
    grid_note: str
    method: str
    N: int
    final_time: float
    wall_seconds: float
    model: str
    stopped_by_callback: bool
    checkpoint: Optional[str]
    summary: Dict[str, Any]

    def __init__(self, raw: Dict[str, Any], model_coords: Sequence[str]) -> None:
        self.summary = raw["summary"]
        s = self.summary
        self.t = np.asarray(raw["t"])
        self.q = np.asarray(raw["q"])
        self.p0 = np.asarray(raw["p0"])
        self.pN = np.asarray(raw["pN"])
        self.history = {k: np.asarray(v) for k, v in raw["history"].items()}
        self.coords = list(model_coords)
        self.status = s["status"]
        self.message = s["message"]
        self.iterations = s["iterations"]
        self.residual = s["residual"]
        self.action = s["action"]
        self.cost = s["cost"]["value"]
        self.cost_name = s["cost"]["name"]
        self.cost_definition = s["cost"]["definition"]
        self.point = s["point"]
        # summary.json writes a missing estimate as null; here it is NaN, as in the C++ Summary.
        self.error_estimate = float("nan") if s["error_estimate"] is None else s["error_estimate"]
        self.error_by_coordinate = dict(s["error"]["by_coordinate"])
        self.error_note = s["error"]["note"]
        self.extrapolated = s["error"]["extrapolated"]
        self.grid_sizes = list(s["grid"]["sizes"])
        self.grid_note = s["grid"]["note"]
        self.method = s["method"]
        self.N = s["N"]
        self.final_time = s["final_time"]
        self.wall_seconds = s["wall_seconds"]
        self.model = s["model"]
        self.stopped_by_callback = raw["stopped_by_callback"]
        self.checkpoint = None

    @property
    def converged(self) -> bool:
        """Whether the solve converged (status == "converged")."""
        return self.status == "converged"

    def coordinate(self, name: str) -> np.ndarray:
        """The values of one coordinate (by name) at the nodes."""
        if name not in self.coords:
            raise PardelError("pardel.Result.coordinate: unknown coordinate %s (the model's: %s)" % (
                _shown(name), ", ".join(self.coords)))
        return self.q[:, self.coords.index(name)]

    def __repr__(self) -> str:
        # summary.json writes a non-finite residual, action or cost as null (None here).
        return "pardel.Result(%s: %s iterations, residual %s, %s = %s, %s)" % (
            self.status, self.iterations, _number_text(self.residual, "%.3g"), self.cost_name,
            _number_text(self.cost, "%.6g"), (self.point or {}).get("kind"))

    __str__ = __repr__


class Interrupted(KeyboardInterrupt):
    """A solve stopped by Ctrl-C (SIGINT) or by a KeyboardInterrupt raised in on_iteration: a
    KeyboardInterrupt that carries what the solve had reached. result: the Result of the stopped
    solve (status "interrupted" and its last iterate, or the status it had reached when the stop
    came after it ended, e.g. during the point assessment of a converged solve); checkpoint: the
    folder of the checkpoint it wrote (solve's or solve_scene's checkpoint argument, or resume's
    folder), which pardel.resume continues, or None."""

    result: "Result"
    checkpoint: Optional[str]

    def __init__(self, where: str, result: "Result", checkpoint: Optional[str]) -> None:
        text = "%s: interrupted at iteration %d (status %s, residual %s); the last iterate is this exception's .result" % (
            where, result.iterations, result.status, _number_text(result.residual, "%.3g"))
        if checkpoint is not None:
            text += "; checkpoint written to %s: continue with pardel.resume(%r)" % (checkpoint, checkpoint)
        super().__init__(text)
        self.result = result
        self.checkpoint = checkpoint

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        return (_interrupted, (str(self), self.result, self.checkpoint))


def _interrupted(text, result, checkpoint):
    """Interrupted as pickled: its message, result and checkpoint."""
    error = Interrupted.__new__(Interrupted)
    KeyboardInterrupt.__init__(error, text)
    error.result, error.checkpoint = result, checkpoint
    return error


def _finish(where, raw, coords, checkpoint):
    """The Result of a solve of the compiled core (raw), or the exception that stopped it raised:
    a KeyboardInterrupt as Interrupted carrying the result, any other as it was raised."""
    result = Result(raw, coords)
    result.checkpoint = checkpoint if raw["checkpoint_written"] else None
    pending = raw["pending"]
    if pending is None:
        return result
    if isinstance(pending, KeyboardInterrupt):
        raise Interrupted(where, result, result.checkpoint) from pending
    if raw["pending_trace"] is not None:
        raise pending.with_traceback(raw["pending_trace"])
    raise pending


def _checkpoint_path(where, checkpoint):
    """The checkpoint argument checked: None, or a folder path (str, bytes or os.PathLike), as a str
    (os.fsdecode: a path that is not UTF-8 keeps its bytes through os.fsencode)."""
    if checkpoint is None:
        return None
    _check_path(where, "checkpoint", checkpoint)
    path = os.fsdecode(os.fspath(checkpoint))
    if path == "":
        raise PardelError("%s: checkpoint must name a folder, got ''" % where)
    return path


def _number_text(value, form):
    """A number of a summary for repr: `form` for a number, "nan" for None (null: not finite)."""
    if value is None:
        return "nan"
    try:
        return form % value
    except TypeError:
        return repr(value)


# ---------------------------------------------------------------------------------------------
# Argument checks: every public function checks its arguments here before anything reaches the
# scene or the compiled core, with Python's exceptions (TypeError for a wrong type, a
# ValueError, PardelError, for a bad value) and messages that name the argument as the caller
# wrote it: "pardel.solve: N must be an int between 2 and 100000000, got 1e+30".

_INT_MAX = 2**31 - 1   # int members of pardel::Options (and Problem::N)
_LONG_MAX = 2**63 - 1  # long members (max_iterations, history_every)
# The scene reader's bound of grid.N (app/src/scene.cpp; test_argument_types.py checks
# that the two agree).
_MAX_N = 100000000
# The integer options of pardel::Options and the largest value their C++ type holds; the ranges
# themselves are the runtime's (pardel::option_bound, _pardel.option_bounds).
_INT_OPTIONS = {"max_iterations": _LONG_MAX, "newton_substeps": _INT_MAX, "threads": _INT_MAX,
                "refine_start_N": _INT_MAX, "clock_update_every": _INT_MAX, "history_every": _LONG_MAX,
                "accuracy_max_N": _INT_MAX}
_NUMBER_OPTIONS = ("tol", "rtol", "damping", "refine_factor", "refine_settle", "divergence_factor", "accuracy")
_STRING_OPTIONS = ("discretization", "clock", "method", "linear_solver", "newton_shift", "device")
_BOOL_OPTIONS = ("error_estimate", "extrapolate")


def _shown(value):
    """A value as a message shows it: short, huge integers as 1e+30."""
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)) and abs(int(value)) >= 10**15:
        try:
            return "%.3g" % float(value)
        except OverflowError:
            return "an int of %d digits" % len(str(abs(int(value))))
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _kind(value):
    """The type and value of a wrong argument, for a message: "str 'abc'", "None"."""
    if value is None:
        return "None"
    return "%s %s" % (type(value).__name__, _shown(value))


def _is_bool(value):
    return isinstance(value, (bool, np.bool_))


def _is_real(value):
    """int, float or a NumPy real scalar (not a bool, not complex, not a string)."""
    return isinstance(value, numbers.Real) and not _is_bool(value)


def _check_int(where, name, value, low, high, zero_allowed=False):
    """An int (or NumPy integer; not a bool) in [low, high] (or 0 where zero_allowed), as a Python int."""
    if not isinstance(value, numbers.Integral) or _is_bool(value):
        raise TypeError("%s: %s must be an int, got %s" % (where, name, _kind(value)))
    value = int(value)
    if not (low <= value <= high or (zero_allowed and value == 0)):
        raise PardelError("%s: %s must be an int %sbetween %d and %d, got %s" % (
            where, name, "0 (off) or " if zero_allowed else "", low, high, _shown(value)))
    return value


def _check_number(where, name, value, finite=True):
    """A real number (int, float or NumPy real scalar; not bool, str or complex) as a float; NaN
    refused, and inf too where `finite`."""
    if not _is_real(value):
        if isinstance(value, (complex, np.complexfloating)):
            raise TypeError("%s: %s must be real, got %s" % (where, name, _kind(value)))
        raise TypeError("%s: %s must be a number, got %s" % (where, name, _kind(value)))
    try:
        number = float(value)
    except OverflowError:
        raise PardelError("%s: %s is too large for a double, got %s" % (where, name, _shown(value))) from None
    if finite and (number != number or number in (float("inf"), float("-inf"))):
        raise PardelError("%s: %s must be a finite number, got %s" % (where, name, _shown(value)))
    if number != number:
        raise PardelError("%s: %s must be a number, not NaN" % (where, name))
    return number


def _check_option(where, name, value):
    """A numeric option of pardel::Options checked against the runtime's bound (option_bound)."""
    low, low_included, high, high_included, zero_allowed, rule = _pardel.option_bounds[name]
    if name in _INT_OPTIONS:
        first = int(low) if low_included else int(low) + 1
        last = _INT_OPTIONS[name] if high == float("inf") else (int(high) if high_included else int(high) - 1)
        return _check_int(where, name, value, first, last, zero_allowed)
    number = _check_number(where, name, value, finite=False)
    above = number >= low if low_included else number > low
    below = number <= high if high_included else number < high
    if not ((above and below) or (zero_allowed and number == 0)):
        raise PardelError("%s: %s %s, got %s" % (where, name, rule, _shown(value)))
    return number


def _check_bool(where, name, value):
    """True or False (a bool or NumPy bool; not an int), as a Python bool."""
    if not _is_bool(value):
        raise TypeError("%s: %s must be True or False, got %s" % (where, name, _kind(value)))
    return bool(value)


def _check_string(where, name, value):
    if not isinstance(value, str):
        raise TypeError("%s: %s must be a str, got %s" % (where, name, _kind(value)))
    return value


def _check_array(where, name, value, ndim, what):
    """A real array of `ndim` dimensions with finite elements, as float64: a complex dtype or
    element is a TypeError (never cast away), so are strings and bools; NaN and inf a ValueError.
    `what` says what was expected ("a sequence of numbers")."""
    if value is None or isinstance(value, (str, bytes, bytearray, dict, set, numbers.Number, np.generic)):
        raise TypeError("%s: %s must be %s, got %s" % (where, name, what, _kind(value)))
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as error:
        raise PardelError("%s: %s must be %s (rows of equal length): %s" % (where, name, what, error)) from None
    if array.dtype.kind == "O":
        for element in array.flat:
            if isinstance(element, (complex, np.complexfloating)):
                raise TypeError("%s: %s must be real, got a complex element %s" % (where, name, _shown(element)))
            if not _is_real(element):
                raise TypeError("%s: %s must be %s, got an element %s" % (where, name, what, _kind(element)))
        try:
            array = array.astype(float)
        except (OverflowError, ValueError, TypeError):
            raise PardelError("%s: %s holds a number too large for a double" % (where, name)) from None
    elif array.dtype.kind == "c":
        raise TypeError("%s: %s must be real, got %s" % (where, name, array.dtype))
    elif array.dtype.kind not in "iuf":
        raise TypeError("%s: %s must be %s, got elements of dtype %s" % (where, name, what, array.dtype))
    array = np.array(array, dtype=float)
    if array.ndim != ndim:
        raise PardelError("%s: %s must be %s, got an array of shape %s" % (where, name, what, array.shape))
    if not np.all(np.isfinite(array)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
        raise PardelError("%s: %s must be finite, got %s at index %s" % (
            where, name, array[bad], bad[0] if len(bad) == 1 else bad))
    return array


def _check_vector(where, name, value):
    return _check_array(where, name, value, 1, "a sequence of numbers").tolist()


def _check_model(where, name, spec):
    """A model argument: a bundled name, a .lag path, .lag text (str or os.PathLike) or a Model."""
    if not isinstance(spec, (str, os.PathLike, Model)):
        raise TypeError("%s: %s must be a bundled model's name, a .lag path, .lag text or a pardel.Model, got %s"
                        % (where, name, _kind(spec)))


def _check_path(where, name, value):
    if not isinstance(value, (str, bytes, os.PathLike)):
        raise TypeError("%s: %s must be a path (str or os.PathLike), got %s" % (where, name, _kind(value)))


def _check_overrides(where, name, overrides):
    """key=value strings, as --set takes them: a list or tuple of str (a bare str is refused)."""
    if isinstance(overrides, (str, bytes)) or not isinstance(overrides, (list, tuple)):
        raise TypeError("%s: %s must be a list of 'key=value' strings, got %s" % (where, name, _kind(overrides)))
    for i, item in enumerate(overrides):
        if not isinstance(item, str):
            raise TypeError("%s: %s[%d] must be a 'key=value' str, got %s" % (where, name, i, _kind(item)))
    return list(overrides)


def _check_params(where, name, params):
    """params: a dict name -> number, or a sequence of numbers in declaration order."""
    if isinstance(params, dict):
        checked = {}
        for key, value in params.items():
            if not isinstance(key, str):
                raise TypeError("%s: %s: the names must be str, got %s" % (where, name, _kind(key)))
            checked[key] = _check_number(where, "%s[%r]" % (name, key), value)
        return checked
    what = "a dict of numbers by name or a sequence of numbers"
    return _check_array(where, name, params, 1, what).tolist()


def _check_callback(where, name, value):
    if value is not None and not callable(value):
        raise TypeError("%s: %s must be callable or None, got %s" % (where, name, _kind(value)))


def _check_scene(where, name, scene):
    if not isinstance(scene, Scene):
        raise TypeError("%s: %s must be a pardel.Scene (from pardel.load_scene), got %s" % (where, name, _kind(scene)))


def _guess_arrays(guess, where="pardel.solve_scene", name="guess"):
    """(q, t) of an initial guess given as an array or a previous Result (t None: uniform)."""
    if guess is None:
        return None, None
    if isinstance(guess, Result):
        return guess.q, guess.t
    what = "an (N+1) x dim array of numbers or a pardel.Result"
    return _check_array(where, name, guess, 2, what), None


def solve_scene(scene: Scene, guess: Guess = None, threads: Optional[int] = None,
                on_iteration: Optional[OnIteration] = None, checkpoint: Optional[PathArg] = None) -> Result:
    """Solves a scene (from load_scene) as `pardel solve` does, without writing files other than
    its checkpoint.

    guess: None (the scene's guess), an (M+1) x dim array or a previous Result (resampled to the
    scene's N when M differs). on_iteration(iteration, N, residual, action): called after each
    recorded iteration; returning False stops the solve (status "interrupted",
    stopped_by_callback). Ctrl-C stops it too and raises pardel.Interrupted (a KeyboardInterrupt)
    whose .result is the stopped solve's Result; an exception raised by on_iteration is raised as
    it is.
    checkpoint: a folder (made if missing). A solve that ends "interrupted" (Ctrl-C, on_iteration)
    writes FOLDER/checkpoint.json there, the checkpoint of `pardel solve` recording the scene file,
    its overrides and threads (Result.checkpoint and Interrupted.checkpoint name the folder), which
    pardel.resume(FOLDER) and `pardel solve --resume FOLDER` continue; a solve that ends any other
    way removes FOLDER/checkpoint.json.
    """
    return _solve_scene("pardel.solve_scene", scene, guess, threads, on_iteration, checkpoint)


def _solve_scene(where, scene, guess, threads, on_iteration, checkpoint):
    """solve_scene's work; `where` names the function called in messages."""
    _check_scene(where, "scene", scene)
    q, t = _guess_arrays(guess, where)
    if threads is not None:
        threads = _check_option(where, "threads", threads)
    _check_callback(where, "on_iteration", on_iteration)
    path = _checkpoint_path(where, checkpoint)
    if path is not None and scene._text is None and scene._file is None:
        raise PardelError("%s: checkpoint needs a scene from pardel.load_scene (a checkpoint records its file)" % where)
    raw = _pardel.solve_scene(scene._core, q, t, on_iteration, threads, None if path is None else os.fsencode(path),
                              scene._text if path is not None else None, scene._file, scene._overrides)
    return _finish(where, raw, scene.info["model"].info()["coords"], path)


def solve(model: ModelLike, q0: Optional[ArrayLike] = None, qN: Optional[ArrayLike] = None, T: Optional[float] = None,
          N: Optional[int] = None, *, guess: Guess = None, on_iteration: Optional[OnIteration] = None,
          checkpoint: Optional[PathArg] = None, **options: Any) -> Result:
    """Solves one boundary-value problem.

    model: a bundled name, a .lag path, .lag text or a Model. q0, qN: boundary points (dim values:
    coords, then derivatives up to order - 1). T: final time minus t0. N: intervals (with accuracy:
    the first grid's, optional, default 16).
    accuracy (a positive number): an adaptive grid, refined until the estimated error of the
    coordinates at the nodes is at most accuracy (accuracy_max_N: the largest N it may use);
    Result.grid_sizes and grid_note say which grids it solved and whether it got there.
    Keyword options (the scene keys of `pardel solve`, docs/examples.md): discretization, params
    (dict by name, or a list in declaration order), t0, knots ([(t, q), ...]), polyline (guess
    vertices), clock, method, tol, rtol, max_iterations, damping, newton_substeps, newton_shift,
    linear_solver, device ("cpu" or "cuda": docs/gpu.md), threads, refine_start_N, refine_factor,
    clock_update_every, error_estimate (True/False), extrapolate (True/False); and history_every, refine_settle, divergence_factor of
    pardel::Options. guess and on_iteration: as in solve_scene; Ctrl-C raises pardel.Interrupted
    (a KeyboardInterrupt) whose .result is the stopped solve's Result.
    checkpoint: a folder (made if missing). A solve that ends "interrupted" (Ctrl-C, on_iteration)
    writes there the scene of these arguments, FOLDER/scene.toml, and the checkpoint of `pardel
    solve`, FOLDER/checkpoint.json, recording it; pardel.resume(FOLDER) (or `pardel solve --resume
    FOLDER`) continues the solve to the iterates of an uninterrupted one. A solve that ends any other
    way removes FOLDER/checkpoint.json. With a checkpoint, refine_settle needs refine_start_N.
    A wrong type raises TypeError, a missing argument too; unknown options and bad values raise
    PardelError (a ValueError); each names the argument.
    """
    arguments = _solve_arguments(model, q0, qN, T, N, guess, on_iteration, options)
    path = _checkpoint_path("pardel.solve", checkpoint)
    spec = _model_spec(model)
    if path is None:
        # a Model solves with the model it holds (its .lag file is not read again)
        loaded = model._handle if isinstance(model, Model) else None
        scene = Scene(_pardel.scene_from_arguments(os.fsencode(spec), arguments, loaded))
    else:  # the options all in the scene text, which the checkpoint records (a model's path absolute)
        if spec.endswith(".lag") or "/" in spec:
            spec = os.path.abspath(spec)
        text = _pardel.scene_text_from_arguments(os.fsencode(spec), arguments)
        scene = Scene(_pardel.scene_from_text(text))
        scene._text = text
    return _solve_scene("pardel.solve", scene, guess, None, on_iteration, path)


def resume(path: PathArg, *, threads: Optional[int] = None, on_iteration: Optional[OnIteration] = None,
           **options: Any) -> Result:
    """Continues the interrupted solve whose checkpoint is PATH/checkpoint.json (written by
    pardel.solve or pardel.solve_scene with checkpoint=PATH, or by `pardel solve` into its output
    folder PATH), as `pardel solve --resume PATH` does: the recorded scene is read again with its
    recorded overrides and the solve continues from the recorded state to the iterates, and the
    Result, of the uninterrupted solve (wall times aside).

    threads: the solve's threads (None: those recorded). on_iteration: as in solve_scene. Solver
    options of pardel.solve (method, tol, rtol, max_iterations, linear_solver, ...) make it a warm
    start instead, as `pardel solve --resume PATH --set solver.KEY=VALUE` does: the recorded
    problem solved from the recorded iterate with those options (another method, a tighter
    tolerance), the checkpoint of a new interruption recording them; an option of the problem (T,
    N, q0, params, ...) raises PardelError. An interruption writes the checkpoint into PATH again (Ctrl-C raises pardel.Interrupted carrying
    the Result); any other end removes PATH/checkpoint.json, so a finished solve is not resumed
    twice. A checkpoint that is missing, truncated, corrupted or edited, whose scene file or model
    changed since, or whose state does not fit its scene raises pardel.CheckpointError (a
    PardelError) naming PATH/checkpoint.json and the problem; a recorded scene that cannot be read
    raises pardel.SceneError.
    """
    where = "pardel.resume"
    path = _checkpoint_path(where, path)
    if path is None:
        raise TypeError("%s: path must be a path (str or os.PathLike), got None" % where)
    if threads is not None:
        threads = _check_option(where, "threads", threads)
    _check_callback(where, "on_iteration", on_iteration)
    raw = _pardel.resume(os.fsencode(path), threads, on_iteration, _checked_options(where, options))
    return _finish(where, raw, raw["coords"], path)


class BatchResult:
    """What pardel.solve_batch returned: results (a Result per problem, in order; len() and
    indexing reach them too), and over the batch: status (array of str), converged (array of
    bool), iterations, residual, action and cost (arrays), t and q (arrays of shape (B, N+1) and
    (B, N+1, dim); NaN rows for a problem whose trajectory is on another grid), threads (problems
    solved at once) and wall_seconds. Pickles whole."""

    results: List[Result]
    status: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    action: np.ndarray
    cost: np.ndarray
    t: np.ndarray
    q: np.ndarray
    threads: int
    wall_seconds: float

    def __init__(self, raw: Dict[str, Any], model_coords: Sequence[str]) -> None:
        self.results = [Result(r, model_coords) for r in raw["results"]]
        self.threads = raw["threads"]
        self.wall_seconds = raw["wall_seconds"]
        self.status = np.array([r.status for r in self.results], dtype=object)
        self.converged = np.array([r.converged for r in self.results], dtype=bool)
        self.iterations = np.array([r.iterations for r in self.results], dtype=np.int64)

        def numbers(name):
            return np.array([np.nan if getattr(r, name) is None else getattr(r, name) for r in self.results],
                            dtype=float)

        self.residual, self.action, self.cost = numbers("residual"), numbers("action"), numbers("cost")
        shape = max((r.q.shape for r in self.results), key=lambda s: s[0], default=(0, 0))
        self.q = np.full((len(self.results),) + shape, np.nan)
        self.t = np.full((len(self.results), shape[0]), np.nan)
        for i, r in enumerate(self.results):
            if r.q.shape == shape:
                self.q[i] = r.q
                self.t[i] = r.t

    def __len__(self) -> int:
        return len(self.results)

    def __getitem__(self, i: int) -> Result:
        return self.results[i]

    def __iter__(self) -> Iterator[Result]:
        return iter(self.results)

    def __repr__(self) -> str:
        return "pardel.BatchResult(%d problems, %d converged, %d threads, %.3g s)" % (
            len(self.results), int(self.converged.sum()), self.threads, self.wall_seconds)


def _batched(where, name, value, ndim, what, sizes):
    """A per-problem argument of solve_batch as a float array with a leading batch axis: `ndim`
    dimensions for one problem (broadcast later), ndim + 1 with the batch axis; its batch size is
    recorded in `sizes` by name."""
    try:
        given = np.ndim(value)
    except ValueError:  # ragged: _check_array says so
        given = ndim
    array = _check_array(where, name, value, given if given in (ndim, ndim + 1) else ndim, what)
    if array.ndim == ndim + 1:
        sizes[name] = array.shape[0]
    return array


def solve_batch(model: ModelLike, q0: Optional[ArrayLike] = None, qN: Optional[ArrayLike] = None,
                T: Optional[float] = None, N: Optional[int] = None, *,
                params: Union[Mapping[str, Union[float, ArrayLike]], ArrayLike, None] = None,
                guess: Optional[ArrayLike] = None, threads: Optional[int] = None, **options: Any) -> BatchResult:
    """Solves B independent problems that differ in their boundary values, params and initial
    guesses, several at once (pardel::solve_batch: one problem per thread, each solved as
    pardel.solve solves it with threads=1, bit for bit, whatever the number of threads).

    q0, qN: (B, dim) arrays, or one point (dim values) for every problem. params: a dict by name of
    numbers or (B,) arrays, or a (B, nparams) array, or one list in declaration order. guess: None
    (each problem's straight line, or the polyline option's), one (M+1, dim) array for all, or a
    (B, M+1, dim) array. The batch size B is the leading size of the arguments that have one; they
    must agree. threads: problems solved at once (default all cores). T, N and the other keyword
    options are pardel.solve's and the same for every problem. Returns a BatchResult; a problem
    that fails has its own status (invalid_input too). Ctrl-C stops the batch and raises
    KeyboardInterrupt; a batch whose estimated memory does not fit the machine raises PardelError.
    """
    return _solve_batch(model, q0, qN, T, N, params, guess, threads, options)


def _solve_batch(model, q0, qN, T, N, params, guess, threads, options):
    """solve_batch's work (unannotated: it rebinds its arguments to their checked forms)."""
    where = "pardel.solve_batch"
    _check_model(where, "model", model)
    if q0 is None or qN is None:
        raise TypeError("%s: missing argument %s" % (where, "q0" if q0 is None else "qN"))
    sizes = {}
    q0 = _batched(where, "q0", q0, 1, "an array of numbers: (dim,) or (B, dim)", sizes)
    qN = _batched(where, "qN", qN, 1, "an array of numbers: (dim,) or (B, dim)", sizes)
    if guess is not None:
        guess = _batched(where, "guess", guess, 2, "an array of numbers: (M+1, dim) or (B, M+1, dim)", sizes)
    if threads is not None:
        threads = _check_option(where, "threads", threads)
    named = isinstance(params, dict)
    if named:
        params = {key: _batched(where, "params[%r]" % key, value, 0, "a number or a (B,) array", sizes)
                  if not _is_real(value) else _check_number(where, "params[%r]" % key, value)
                  for key, value in params.items()}
    elif params is not None:
        params = _batched(where, "params", params, 1, "an array of numbers: (nparams,) or (B, nparams)", sizes)
    if len(set(sizes.values())) > 1:
        raise PardelError("%s: the batch sizes of the arguments differ: %s" % (
            where, ", ".join("%s has %d" % item for item in sizes.items())))
    B = next(iter(sizes.values()), 1)

    if B == 0:
        raise PardelError("%s: an empty batch (B = 0)" % where)
    m = model if isinstance(model, Model) else Model(model)
    for name, array, size, has in (("q0", q0, m.dim, "dim %d"), ("qN", qN, m.dim, "dim %d"),
                                    ("guess", guess, m.dim, "dim %d"), ("params", params, len(m.params), "%d params")):
        if isinstance(array, np.ndarray) and array.shape[-1] != size:
            raise PardelError("%s: %s must have %d values per %s (model %s has %s), got shape %s" % (
                where, name, size, "node" if name == "guess" else "problem", m.name, has % size, array.shape))
    if guess is not None and guess.shape[-2] < 2:
        raise PardelError("%s: guess must have at least 2 nodes, got shape %s" % (where, guess.shape))

    def batch_of(array, ndim):
        """The array with the batch axis, a single value repeated over it."""
        return np.ascontiguousarray(np.broadcast_to(array, (B,) + array.shape) if array.ndim == ndim else array)

    q0, qN = batch_of(q0, 1), batch_of(qN, 1)
    if named:
        base_params = {key: float(np.asarray(v).flat[0]) for key, v in params.items()}
    elif params is not None:
        params = batch_of(params, 1)
        base_params = params[0].tolist()
    else:
        base_params = None
    arguments = _solve_arguments(m, q0[0], qN[0], T, N, None, None, dict(options, params=base_params, threads=threads), where)
    scene = Scene(_pardel.scene_from_arguments(os.fsencode(m.spec), arguments, m._handle))
    if guess is not None:
        guess = batch_of(guess, 2)
    if named:  # the scene's params (defaults and scalars), with the per-problem columns given
        names = list(m.params)
        table = np.tile(np.array([scene.info["params"][n] for n in names], dtype=float), (B, 1))
        for key, value in params.items():
            table[:, names.index(key)] = value
        params = table
    raw = _pardel.solve_batch_scene(scene._core, q0, qN, params, guess, threads)
    return BatchResult(raw, m.coords)


# What each required argument of pardel.solve is, for the message when it is missing.
_REQUIRED = (("q0", "the boundary point at t0"), ("qN", "the boundary point at t0 + T"),
             ("T", "the final time minus t0"), ("N", "the number of intervals"))


def _solve_arguments(model, q0, qN, T, N, guess, on_iteration, options, where="pardel.solve"):
    """pardel.solve's arguments checked (types, NaN, the runtime's option bounds) and turned into
    plain values for the scene: floats, ints, strs and lists of them. Unknown option names are
    left to the core, which suggests the nearest valid name."""
    _check_model(where, "model", model)
    given = {"q0": q0, "qN": qN, "T": T, "N": N}
    adaptive = options.get("accuracy") is not None  # N is then the first grid's, and optional
    missing = [(name, what) for name, what in _REQUIRED if given[name] is None and not (name == "N" and adaptive)]
    if missing:
        raise TypeError("%s: missing argument%s %s" % (where, "s" if len(missing) > 1 else "",
                        ", ".join("%s (%s)" % m for m in missing)))
    arguments = {"q0": _check_vector(where, "q0", q0), "qN": _check_vector(where, "qN", qN),
                 "T": _check_number(where, "T", T)}
    if N is not None:
        arguments["N"] = _check_int(where, "N", N, 2, _MAX_N)
    if arguments["T"] <= 0:
        raise PardelError("%s: T must be > 0, got %s" % (where, _shown(T)))
    _guess_arrays(guess, where)
    _check_callback(where, "on_iteration", on_iteration)
    arguments.update(_checked_options(where, options))
    return arguments


def _checked_options(where, options):
    """Keyword options of pardel.solve checked (types, NaN, the runtime's option bounds) as plain
    values; None values left out, unknown names left to the core."""
    arguments = {}
    for name, value in options.items():
        if value is None:
            continue
        if name in _STRING_OPTIONS:
            value = _check_string(where, name, value)
        elif name in _BOOL_OPTIONS:
            value = _check_bool(where, name, value)
        elif name in _INT_OPTIONS or name in _NUMBER_OPTIONS:
            value = _check_option(where, name, value)
        elif name == "t0":
            value = _check_number(where, name, value)
        elif name == "params":
            value = _check_params(where, name, value)
        elif name == "polyline":
            value = _check_array(where, name, value, 2, "a sequence of points (sequences of numbers)").tolist()
        elif name == "knots":
            value = _check_knots(where, name, value)
        arguments[name] = value
    return arguments


def _check_knots(where, name, knots):
    """knots: a sequence of (t, q) pairs, t a number and q a sequence of numbers."""
    if isinstance(knots, (str, bytes, dict)) or not isinstance(knots, (list, tuple, np.ndarray)):
        raise TypeError("%s: %s must be a list of (t, q) pairs, got %s" % (where, name, _kind(knots)))
    checked = []
    for i, knot in enumerate(knots):
        item = "%s[%d]" % (name, i)
        if isinstance(knot, (str, bytes, dict)) or not isinstance(knot, (list, tuple, np.ndarray)) or len(knot) != 2:
            raise TypeError("%s: %s must be a pair (t, q), got %s" % (where, item, _kind(knot)))
        checked.append((_check_number(where, item + ".t", knot[0]), _check_vector(where, item + ".q", knot[1])))
    return checked


class SweepVariant:
    """One variant of a sweep (a row of variants.csv): id, configuration (its index), values (the
    varied keys' values as TOML text, by key), guess ("scene", "listed 0", "random 3") and
    guess_points (the polyline's vertices, [] for the scene's own guess), status, message,
    iterations, residual, action, cost, seconds, certificate (the point's verdict when converged,
    else None), solution (the id of the distinct solution it reached, or None), and t, q (its
    trajectory as arrays when converged, else None: the sweep keeps only converged trajectories)."""

    id: int
    configuration: int
    values: Dict[str, str]
    guess: str
    guess_points: List[List[float]]
    status: str
    message: str
    iterations: int
    residual: float
    action: float
    cost: float
    seconds: float
    certificate: Optional[str]
    solution: Optional[int]
    t: Optional[np.ndarray]
    q: Optional[np.ndarray]

    def __init__(self, raw: Dict[str, Any], values: Dict[str, str]) -> None:
        for key, value in raw.items():
            setattr(self, key, value)
        self.values = values
        self.guess_points = [list(p) for p in raw["guess_points"]]
        if self.t is not None:
            self.t = np.asarray(self.t)
            self.q = np.asarray(self.q)

    @property
    def converged(self) -> bool:
        """Whether the variant's solve converged (status == "converged")."""
        return self.status == "converged"

    def __repr__(self) -> str:
        return "pardel.SweepVariant(%d, %s: %s, cost %.10g, solution %s)" % (
            self.id, self.guess, self.status, self.cost, self.solution)


class SweepSolution:
    """A distinct local solution of a sweep (a row of solutions.csv): id, configuration, rank (1 =
    lowest cost in its configuration), cost, action, residual, variants (the ids of the variants
    that reached it), first_variant (the representative), certificate, and t, q (the
    representative's trajectory, what solution_<id>.csv holds)."""

    id: int
    configuration: int
    rank: int
    cost: float
    action: float
    residual: float
    variants: List[int]
    first_variant: int
    certificate: Optional[str]
    t: Optional[np.ndarray]
    q: Optional[np.ndarray]

    def __init__(self, raw: Dict[str, Any], representative: SweepVariant) -> None:
        for key, value in raw.items():
            setattr(self, key, value)
        self.variants = list(raw["variants"])
        self.certificate = representative.certificate
        self.t = representative.t
        self.q = representative.q

    def __repr__(self) -> str:
        return "pardel.SweepSolution(%d: configuration %d, rank %d, cost %.10g, %d variants, %s)" % (
            self.id, self.configuration, self.rank, self.cost, len(self.variants), self.certificate)


class SweepResult:
    """What pardel.sweep returned: variants (a SweepVariant per variant, in variant order),
    solutions (a SweepSolution per distinct solution, by configuration then cost), best (the
    lowest-cost solution or None), summary (the dictionary of sweep.json), and from it
    configurations, cost_name, converged (how many variants converged), failures (counts by
    status) and wall_seconds; out is the folder the files were written to, or None."""

    variants: List[SweepVariant]
    solutions: List[SweepSolution]
    best: Optional[SweepSolution]
    summary: Dict[str, Any]
    configurations: int
    cost_name: str
    converged: int
    failures: Dict[str, int]
    wall_seconds: float
    out: Optional[str]

    def __init__(self, raw: Dict[str, Any], out: Optional[str]) -> None:
        self.summary = json.loads(raw["summary"])
        s = self.summary
        axes = list(raw["axes"])
        values = [dict(zip(axes, v)) for v in raw["configuration_values"]]
        self.variants = [SweepVariant(v, values[v["configuration"]]) for v in raw["variants"]]
        self.solutions = [SweepSolution(g, self.variants[g["first_variant"]]) for g in raw["solutions"]]
        self.best = None if s["best"] is None else self.solutions[s["best"]["id"] - 1]
        self.configurations = s["configurations"]
        self.cost_name = s["cost"]["name"]
        self.converged = s["converged"]
        self.failures = s["failures"]
        self.wall_seconds = s["wall_seconds"]
        self.out = out

    def __repr__(self) -> str:
        return "pardel.SweepResult(%s: %d variants, %d converged, %d distinct solutions)" % (
            self.summary["sweep"], len(self.variants), self.converged, len(self.solutions))


def sweep(path: PathArg, overrides: Sequence[str] = (), *, threads: Optional[int] = None,
          out: Optional[Union[str, os.PathLike[str]]] = None) -> SweepResult:
    """Runs a sweep file as `pardel sweep` does (pardel::app's sweep: the same variants, solves,
    grouping and ranking) and returns a SweepResult.

    overrides: "key=value" strings for the base scene, as `pardel sweep --set` takes. threads:
    threads per variant (None: the scene's solver.threads, where 0 is all cores). out: a folder
    to write solutions.csv, variants.csv, sweep.json and solution_<id>.csv into (no sweep.png;
    None: no files). A bad sweep file raises SceneError with the command line's FILE:LINE:COL message.
    Ctrl-C stops the running solve; the outputs (when out is given) hold what was done, and
    KeyboardInterrupt is raised.
    """
    where = "pardel.sweep"
    _check_path(where, "path", path)
    overrides = _check_overrides(where, "overrides", overrides)
    if threads is not None:
        threads = _check_int(where, "threads", threads, 1, _pardel.max_threads)
    if out is not None:
        _check_path(where, "out", out)
    out = None if out is None else os.fspath(out)
    if out == "":
        raise PardelError("out: a folder was expected, got ''")
    raw = _pardel.run_sweep(os.fsencode(path), list(overrides), 0 if threads is None else int(threads),
                            os.fsencode(out or ""))  # bytes: paths need not be UTF-8
    return SweepResult(raw, out)


def check(scene: Scene, q: Guess = None) -> Dict[str, Any]:
    """`pardel check`: the seed's convergence certificate at a trajectory (q an array or a Result;
    None: the scene's initial guess), as the dictionary of `pardel check --json`; its "certificate"
    also holds free_components, intervals_violating, residual, tol, error and report (the text of
    `pardel check`), the members of pardel::Certificate that --json leaves out."""
    _check_scene("pardel.check", "scene", scene)
    arr, t = _guess_arrays(q, "pardel.check", "q")
    return json.loads(_pardel.check_scene(scene._core, arr, t))


def kernels(model: ModelLike, discretization: str, h: float, t0: float, t1: float, q0: ArrayLike, q1: ArrayLike,
            params: Optional[Params] = None) -> Dict[str, Any]:
    """The discrete Lagrangian and its derivatives on one interval (what `pardel kernels` prints):
    a dict Ld, D1, D2, D11, D12, D22. params: dict by name (defaults for the rest) or a list."""
    return _kernels(model, discretization, h, t0, t1, q0, q1, params)


def _kernels(model, discretization, h, t0, t1, q0, q1, params):
    """kernels' work (unannotated: it rebinds its arguments to their checked forms)."""
    where = "pardel.kernels"
    _check_model(where, "model", model)
    _check_string(where, "discretization", discretization)
    h, t0, t1 = (_check_number(where, name, value) for name, value in (("h", h), ("t0", t0), ("t1", t1)))
    q0, q1 = _check_vector(where, "q0", q0), _check_vector(where, "q1", q1)
    if params is not None:
        params = _check_params(where, "params", params)
    m = model if isinstance(model, Model) else Model(model)
    if discretization not in m.discretizations:
        raise PardelError("%s: unknown discretization '%s' for model %s (it has: %s)" % (
            where, discretization, m.name, ", ".join(m.discretizations)))
    if params is None or isinstance(params, dict):
        values = dict(m.params)
        for name, value in (params or {}).items():
            if name not in values:
                raise PardelError("%s: unknown param '%s' of model %s (it has: %s)" % (
                    where, name, m.name, ", ".join(values)))
            values[name] = value
        params = list(values.values())
    return _pardel.kernels(m._handle, discretization, h, t0, t1, q0, q1, [float(v) for v in params])
