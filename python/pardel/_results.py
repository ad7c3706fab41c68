"""What pardel's solves return: Result (one solve), Interrupted (a solve, batch or sweep stopped by
Ctrl-C, carrying what it had reached), BatchResult (pardel.solve_batch), and SweepResult with its
SweepVariant and SweepSolution (pardel.sweep)."""
from __future__ import annotations

from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union, overload

import numpy as np

from ._checks import _check_string, _shown
from ._pardel import PardelError


def _number_text(value, form):
    """A number of a summary for repr: `form` for a number, "nan" for None (null: not finite)."""
    if value is None:
        return "nan"
    try:
        return form % value
    except TypeError:
        return repr(value)


class Result:
    """What a solve returned.

    t (N+1 node times), q ((N+1) x dim: coords, then derivatives for order >= 2), status (the
    summary.json status: converged, max_iterations, diverged, non_finite, interrupted, stalled),
    message, iterations, residual, action, cost (the physical cost's value; cost_name,
    cost_definition), point (kind, inertia, lambda_min, ... as in summary.json), p0 and pN (the
    discrete boundary momenta -D1 Ld(q0, q1) and D2 Ld(q_{N-1}, q_N)), history (arrays iteration,
    N, residual, action, seconds), error_estimate (Richardson's estimate of the discretization error
    of the coordinates at the nodes plus solve_error, NaN when not estimated), error_by_coordinate
    (dict by name, empty when not estimated), solve_error (the solve's own error, the largest absolute
    value of the Newton correction delta = -H^-1 r at the returned iterate over the nodes and
    coordinates, NaN where not computed), error_note (how it was made, or "not estimated: " and why),
    error_reliable (whether a third grid level confirmed the estimate) and error_observed_order (the
    order it observed, NaN where none), error_time_estimate (under the free_final_time clock, the same
    rule's estimate of the node times' error, NaN where not made), extrapolated (whether q holds the extrapolated values), refinement_steps and refinement_note
    (iterative refinement in extended precision: corrections applied, and what happened or why it
    did not run; "" where it was off), grid_sizes and grid_note (an adaptive
    solve's grids, in order, and its outcome; empty otherwise), method, N, final_time,
    wall_seconds, assessment_seconds (the point assessment's part of it), model (the model's name), coords (its coordinate names), stopped_by_callback
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
    solve_error: float
    error_note: str
    error_reliable: bool
    error_observed_order: float
    error_time_estimate: float
    extrapolated: bool
    refinement_steps: int
    refinement_note: str
    grid_sizes: List[int]
    grid_note: str
    method: str
    N: int
    final_time: float
    wall_seconds: float
    assessment_seconds: float
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
        self.solve_error = float("nan") if s["error"].get("solve") is None else s["error"]["solve"]
        self.error_note = s["error"]["note"]
        self.error_reliable = bool(s["error"]["reliable"])
        order = s["error"].get("observed_order")
        self.error_observed_order = float("nan") if order is None else float(order)
        time_error = s["error"].get("time")
        self.error_time_estimate = float("nan") if time_error is None else float(time_error)
        self.extrapolated = s["error"]["extrapolated"]
        self.refinement_steps = s["refinement"]["steps"]
        self.refinement_note = s["refinement"]["note"]
        self.grid_sizes = list(s["grid"]["sizes"])
        self.grid_note = s["grid"]["note"]
        self.method = s["method"]
        self.N = s["N"]
        self.final_time = s["final_time"]
        self.wall_seconds = s["wall_seconds"]
        self.assessment_seconds = s["assessment_seconds"]
        self.model = s["model"]
        self.stopped_by_callback = raw["stopped_by_callback"]
        self.checkpoint = None

    @property
    def converged(self) -> bool:
        """Whether the solve converged (status == "converged")."""
        return self.status == "converged"

    def coordinate(self, name: str) -> np.ndarray:
        """The values of one coordinate (by name) at the nodes."""
        _check_string("pardel.Result.coordinate", "name", name)
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
    came after it ended, e.g. during the point assessment of a converged solve), for solve_batch
    the BatchResult so far (the problems that had ended with their statuses, the others
    "interrupted"), for sweep the SweepResult so far (the variants started: those that had ended,
    the running one "interrupted"; summary["not_started"] counts the others); checkpoint: the
    folder of the checkpoint it wrote (solve's or solve_scene's checkpoint argument, or resume's
    folder), which pardel.resume continues, or None."""

    result: Union["Result", "BatchResult", "SweepResult"]
    checkpoint: Optional[str]

    def __init__(self, where: str, result: Union["Result", "BatchResult", "SweepResult"],
                 checkpoint: Optional[str]) -> None:
        if isinstance(result, BatchResult):
            stopped = int(np.sum(result.status == "interrupted"))
            text = "%s: interrupted with %d of %d problems ended (%d converged); the batch so far is this exception's .result" % (
                where, len(result) - stopped, len(result), int(np.sum(result.converged)))
        elif isinstance(result, SweepResult):  # its variants are those started; sweep.json counts the rest
            stopped = sum(v.status == "interrupted" for v in result.variants)
            text = ("%s: interrupted with %d of %d variants ended (%d converged, %d not started); the sweep so far "
                    "is this exception's .result" % (where, len(result.variants) - stopped, result.summary["variants"],
                                                     result.converged, result.summary.get("not_started", 0)))
        else:
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
    _raise_pending(where, raw, result, result.checkpoint)
    return result


def _raise_pending(where, raw, result, checkpoint=None):
    """Raises the exception that stopped a call of the compiled core (raw["pending"], None where
    nothing did): a KeyboardInterrupt as Interrupted carrying `result` (a Result, BatchResult or
    SweepResult) and `checkpoint`, any other as it was raised (with raw["pending_trace"], where
    the core kept it)."""
    pending = raw["pending"]
    if pending is None:
        return
    if isinstance(pending, KeyboardInterrupt):
        raise Interrupted(where, result, checkpoint) from pending
    if raw.get("pending_trace") is not None:
        raise pending.with_traceback(raw["pending_trace"])
    raise pending


class BatchResult:
    """What pardel.solve_batch returned: results (a Result per problem, in order; len(), iteration
    and b[i] reach them too), and over the batch: status (array of str), converged (array of
    bool), iterations, residual, action and cost (arrays), t and q (arrays of shape (B, N+1) and
    (B, N+1, dim), N the largest grid's; all NaN in t[i] and q[i] for a problem whose trajectory is
    on another grid, which is in b[i]), threads (problems solved at once) and wall_seconds.
    b[key] with a slice, a boolean mask (b[b.converged]) or integers is a BatchResult of those
    problems. Pickles whole."""

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

    @overload
    def __getitem__(self, key: Union[int, np.integer]) -> Result: ...

    @overload
    def __getitem__(self, key: Union[slice, Sequence[int], Sequence[bool], np.ndarray]) -> BatchResult: ...

    def __getitem__(self, key: Any) -> Union[Result, BatchResult]:
        """b[i]: problem i's Result. b[key] with a slice, a boolean mask of length B (b[b.converged])
        or a list or 1-D array of ints: a BatchResult of those problems, in that order, whose
        arrays are the batch's indexed by key (b[key].q is b.q[key]: the batch's grid) and whose
        threads and wall_seconds are the batch's."""
        where = "pardel.BatchResult"
        if isinstance(key, (int, np.integer)) and not isinstance(key, (bool, np.bool_)):
            return self.results[key]
        if isinstance(key, slice):
            chosen = np.arange(len(self.results))[key]
        else:
            array = np.asarray(key) if isinstance(key, (list, range, np.ndarray)) else None
            if array is not None and array.size == 0 and array.dtype == float:
                array = array.astype(np.intp)  # [] chooses none, as in NumPy
            if array is None or array.ndim != 1 or not (array.dtype == bool or np.issubdtype(array.dtype, np.integer)):
                shown = "%s %.60r" % (type(key).__name__, key) if array is None else \
                    "%s of shape %s and dtype %s" % (type(key).__name__, array.shape, array.dtype)
                raise TypeError("%s: an index must be an int, a slice, a boolean mask of length %d, or a list or 1-D "
                                "array of ints, got %s" % (where, len(self.results), shown))
            try:
                chosen = np.arange(len(self.results))[array]
            except IndexError as error:
                raise IndexError("%s: %s" % (where, error)) from None
        part = BatchResult.__new__(BatchResult)
        part.results = [self.results[i] for i in chosen]
        for name in ("status", "converged", "iterations", "residual", "action", "cost", "t", "q"):
            setattr(part, name, getattr(self, name)[chosen])
        part.threads, part.wall_seconds = self.threads, self.wall_seconds
        return part

    def __iter__(self) -> Iterator[Result]:
        return iter(self.results)

    def __repr__(self) -> str:
        return "pardel.BatchResult(%d problems, %d converged, %d threads, %.3g s)" % (
            len(self.results), int(self.converged.sum()), self.threads, self.wall_seconds)


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
        self.summary = raw["summary"]
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
