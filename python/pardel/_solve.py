"""pardel's solves: Scene and load_scene, solve_scene, solve, resume, solve_batch, sweep, check and
kernels, each checking its arguments and calling the compiled core."""
from __future__ import annotations

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _pardel
from ._checks import (_MAX_N, _check_array, _check_callback, _check_int, _check_number, _check_option,
                      _check_overrides, _check_params, _check_path, _check_string, _check_vector, _checked_options,
                      _checkpoint_path, _core_call, _is_real, _kind, _shown)
from ._models import Model, _check_model, _model_of, _model_spec
from ._pardel import PardelError
from ._results import BatchResult, Result, SweepResult, _finish, _raise_pending
from ._types import ArrayLike, Guess, ModelLike, OnIteration, Params, PathArg


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
    raw = _core_call(where, _pardel.solve_scene, scene._core, q, t, on_iteration, threads,
                     None if path is None else os.fsencode(path), scene._text if path is not None else None,
                     scene._file, scene._overrides)
    return _finish(where, raw, scene.info["model"].info()["coords"], path)


def solve(model: ModelLike, q0: Optional[ArrayLike] = None, qN: Optional[ArrayLike] = None, T: Optional[float] = None,
          N: Optional[int] = None, *, guess: Guess = None, on_iteration: Optional[OnIteration] = None,
          checkpoint: Optional[PathArg] = None, **options: Any) -> Result:
    """Solves one boundary-value problem.

    model: a bundled name, a .lag path, .lag text or a Model. q0, qN: boundary points (dim values:
    coords, then derivatives up to order - 1). T: final time minus t0. N: intervals (with accuracy:
    the first grid's, optional, default 16 or accuracy_max_N if smaller, at most accuracy_max_N).
    accuracy (a positive number; 0 or None: a fixed grid of N): an adaptive grid, refined until
    the estimated error of the coordinates at the nodes is at most accuracy (accuracy_max_N: the
    largest N it may use);
    Result.grid_sizes and grid_note say which grids it solved and whether it got there.
    Keyword options (the scene keys of `pardel solve`, docs/examples.md): discretization, params
    (dict by name, or a list in declaration order), t0, knots ([(t, q), ...]), polyline (guess
    vertices), clock, method, tol, rtol, max_iterations, damping, newton_substeps, newton_shift,
    linear_solver, device ("cpu" or "cuda": docs/gpu.md), threads, refine_start_N, refine_factor,
    clock_update_every, error_estimate (True/False), extrapolate (True/False), iterative_refinement
    ("auto", "on" or "off"); and history_every, refine_settle, divergence_factor of
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
    spec = _model_spec(model, "pardel.solve", "model")
    if path is None:
        # a Model solves with the model it holds (its .lag file is not read again)
        loaded = model._handle if isinstance(model, Model) else None
        scene = Scene(_core_call("pardel.solve", _pardel.scene_from_arguments, os.fsencode(spec), arguments, loaded))
    else:  # the options all in the scene text, which the checkpoint records (a model's path absolute)
        if spec.endswith(".lag") or "/" in spec:
            spec = os.path.abspath(spec)
        text = _core_call("pardel.solve", _pardel.scene_text_from_arguments, os.fsencode(spec), arguments)
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
    raw = _core_call(where, _pardel.resume, os.fsencode(path), threads, on_iteration, _checked_options(where, options),
                     keep=(_pardel.CheckpointError, _pardel.SceneError))
    return _finish(where, raw, raw["coords"], path)


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
    pardel.Interrupted (a KeyboardInterrupt) whose .result is the BatchResult so far (the problems
    that had ended, with their statuses; the others "interrupted"); a batch whose estimated memory
    does not fit the machine raises PardelError.
    """
    return _solve_batch(model, q0, qN, T, N, params, guess, threads, options)


def _solve_batch(model, q0, qN, T, N, params, guess, threads, options):
    """solve_batch's work (unannotated: it rebinds its arguments to their checked forms)."""
    where = "pardel.solve_batch"
    _check_model(where, "model", model)
    for name in ("on_iteration", "checkpoint"):
        if name in options:
            raise TypeError("%s: %s is pardel.solve's; a batch takes none (each problem's solve runs "
                            "inside the batch, which Ctrl-C stops)" % (where, name))
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
    m = _model_of(where, model)
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
    _one_guess(where, guess is not None, arguments)
    scene = Scene(_core_call(where, _pardel.scene_from_arguments, os.fsencode(m.spec), arguments, m._handle, where))
    if guess is not None:
        guess = batch_of(guess, 2)
    if named:  # the scene's params (defaults and scalars), with the per-problem columns given
        names = list(m.params)
        table = np.tile(np.array([scene.info["params"][n] for n in names], dtype=float), (B, 1))
        for key, value in params.items():
            table[:, names.index(key)] = value
        params = table
    raw = _pardel.solve_batch_scene(scene._core, q0, qN, params, guess, threads)
    result = BatchResult(raw, m.coords)
    _raise_pending(where, raw, result)  # Ctrl-C: the core raises any other exception itself
    return result


# What each required argument of pardel.solve is, for the message when it is missing.
_REQUIRED = (("q0", "the boundary point at t0"), ("qN", "the boundary point at t0 + T"),
             ("T", "the final time minus t0"), ("N", "the number of intervals"))


def _solve_arguments(model, q0, qN, T, N, guess, on_iteration, options, where="pardel.solve"):
    """pardel.solve's arguments checked (types, NaN, the runtime's option bounds) and turned into
    plain values for the scene: floats, ints, strs and lists of them. Unknown option names are
    left to the core, which suggests the nearest valid name."""
    _check_model(where, "model", model)
    given = {"q0": q0, "qN": qN, "T": T, "N": N}
    accuracy = options.get("accuracy")
    # N is then the first grid's, and optional; accuracy 0 is a fixed grid (pardel::Options)
    adaptive = accuracy is not None and not (isinstance(accuracy, (int, float)) and accuracy == 0)
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
    _one_guess(where, guess is not None, arguments)
    return arguments


def _one_guess(where, guess_given, arguments):
    """A guess array and the polyline option both say where to start: refused, not one chosen."""
    if guess_given and arguments.get("polyline") is not None:
        raise PardelError("%s: give guess or polyline, not both (each is a starting trajectory)" % where)


def sweep(path: PathArg, overrides: Sequence[str] = (), *, threads: Optional[int] = None,
          out: Optional[Union[str, os.PathLike[str]]] = None) -> SweepResult:
    """Runs a sweep file as `pardel sweep` does (pardel::app's sweep: the same variants, solves,
    grouping and ranking) and returns a SweepResult.

    overrides: "key=value" strings for the base scene, as `pardel sweep --set` takes. threads:
    threads per variant (0: all cores; None: the scene's solver.threads). out: a folder
    to write solutions.csv, variants.csv, sweep.json and solution_<id>.csv into (no sweep.png;
    None: no files). A bad sweep file raises SceneError with the command line's FILE:LINE:COL message.
    Ctrl-C stops the running solve and raises pardel.Interrupted (a KeyboardInterrupt) whose
    .result is the SweepResult so far (its variants those started: the ones that had ended, the
    running one "interrupted"; summary["not_started"] counts the others); the outputs (when out is
    given) hold the same.
    """
    where = "pardel.sweep"
    _check_path(where, "path", path)
    overrides = _check_overrides(where, "overrides", overrides)
    if threads is not None:
        threads = _check_int(where, "threads", threads, 0, _pardel.max_threads)
    if out is not None:
        _check_path(where, "out", out)
    out = None if out is None else os.fspath(out)
    if out == "":
        raise PardelError(where + ": out: a folder was expected, got ''")
    raw = _pardel.run_sweep(os.fsencode(path), list(overrides), -1 if threads is None else int(threads),
                            os.fsencode(out or ""))  # bytes: paths need not be UTF-8
    result = SweepResult(raw, out)
    _raise_pending(where, raw, result)  # Ctrl-C: the core raises any other exception itself
    return result


def check(scene: Scene, q: Guess = None) -> Dict[str, Any]:
    """`pardel check`: the seed's convergence certificate at a trajectory (q an array or a Result;
    None: the scene's initial guess), as the dictionary of `pardel check --json` (trajectory, N,
    residual, action, certificate); its "certificate" also holds report, the text `pardel check`
    prints, which --json leaves out."""
    _check_scene("pardel.check", "scene", scene)
    arr, t = _guess_arrays(q, "pardel.check", "q")
    return _core_call("pardel.check", _pardel.check_scene, scene._core, arr, t)


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
    if not h > 0:  # as `pardel kernels --h`: a step that is not positive has no discrete Lagrangian
        raise PardelError("%s: h, the step, must be a finite number > 0, got %s" % (where, _shown(h)))
    q0, q1 = _check_vector(where, "q0", q0), _check_vector(where, "q1", q1)
    if params is not None:
        params = _check_params(where, "params", params)
    m = _model_of(where, model)
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
    return _core_call(where, _pardel.kernels, m._handle, discretization, h, t0, t1, q0, q1, [float(v) for v in params])
