"""pardel from Python: solve the discrete Euler-Lagrange boundary-value problems of variational
integrators from NumPy arrays, with the bundled models, .lag files or .lag text.

    import pardel
    r = pardel.solve("fuel_nav", q0=[0, 0], qN=[6, 5], T=30, N=200)
    r.status, r.cost, r.q          # "converged", the fuel, an (N+1) x dim array

Everything here translates to the compiled core (pardel._pardel), which calls the pardel runtime,
the model loader and the scene reader that `pardel solve` uses: the checks, the messages and the
numbers are the command line's.
"""
import hashlib
import json
import os

import numpy as np

# OpenMP threads wait passively (sleep) between parallel loops unless the user chose otherwise:
# spinning threads cost a scheduler quantum per loop where another process keeps a core busy (as
# the command line, docs/solvers.md). OpenMP reads this when its library is loaded: by the import
# below, unless something imported before pardel loaded it already.
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "passive"

from . import _pardel  # noqa: E402
from ._pardel import ModelError, ModelWarning, PardelError, SceneError  # noqa: E402

# An installed package compiles .lag files with the installed pardel-gen and render script, which
# `cmake --install` names in _installed.py; the build tree's package uses the build tree's.
try:
    from ._installed import LOADER_TOOLCHAIN as _INSTALLED_TOOLCHAIN
except ImportError:
    _INSTALLED_TOOLCHAIN = None
if _INSTALLED_TOOLCHAIN:
    _pardel.set_loader_toolchain(**_INSTALLED_TOOLCHAIN)

__all__ = [
    "Model", "Result", "Scene", "PardelError", "SceneError", "ModelError", "ModelWarning",
    "model", "models", "solve", "load_scene", "solve_scene", "check", "kernels", "lag_cache_dir",
    "sweep", "SweepResult", "SweepVariant", "SweepSolution",
]


def lag_cache_dir():
    """The folder of compiled models (the model loader's): $PARDEL_CACHE_DIR, else
    $XDG_CACHE_HOME/pardel, else ~/.cache/pardel."""
    if os.environ.get("PARDEL_CACHE_DIR"):
        return os.environ["PARDEL_CACHE_DIR"]
    if os.environ.get("XDG_CACHE_HOME"):
        return os.path.join(os.environ["XDG_CACHE_HOME"], "pardel")
    return os.path.join(os.path.expanduser("~"), ".cache", "pardel")


def _lag_text_file(text):
    """Writes .lag text to <cache>/lag-text/<hash>.lag (once per text) and returns the path."""
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    folder = os.path.join(lag_cache_dir(), "lag-text")
    path = os.path.join(folder, digest + ".lag")
    if not os.path.exists(path):
        os.makedirs(folder, exist_ok=True)
        tmp = "%s.tmp.%d" % (path, os.getpid())
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
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
    """A compiled model: name, coords, order, dim, params (name -> default), discretizations."""

    def __init__(self, spec):
        self.spec = _model_spec(spec)
        self._handle = _pardel.load_model(self.spec)
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

    def __repr__(self):
        return "pardel.Model(%r: coords %s, order %d, params %s, discretizations %s)" % (
            self.name, self.coords, self.order, self.params, self.discretizations)


def model(spec):
    """The model of a bundled name, a .lag path, or .lag text (compiled on first use, cached in
    lag_cache_dir())."""
    return Model(spec)


def models():
    """The names of the bundled models."""
    return list(_pardel.bundled_models())


class Scene:
    """A scene read and checked by pardel's scene reader (from a TOML file or from solve's
    arguments); `info` holds its problem and options."""

    def __init__(self, core):
        self._core = core
        self.info = core.info()
        self.model = self.info["model"].name
        self.N = self.info["N"]

    def __repr__(self):
        return "pardel.Scene(%r: model %s, N = %d, T = %g)" % (self.info["path"], self.model, self.N, self.info["T"])


def load_scene(path, overrides=()):
    """Reads a scene file; `overrides` are "key.path=value" strings, as `pardel solve --set` takes."""
    return Scene(_pardel.load_scene(os.fspath(path), list(overrides)))


class Result:
    """What a solve returned.

    t (N+1 node times), q ((N+1) x dim: coords, then derivatives for order >= 2), status (the
    summary.json status: converged, max_iterations, diverged, non_finite, interrupted, stalled),
    message, iterations, residual, action, cost (the physical cost's value; cost_name,
    cost_definition), point (kind, inertia, lambda_min, ... as in summary.json), p0 and pN (the
    discrete boundary momenta -D1 Ld(q0, q1) and D2 Ld(q_{N-1}, q_N)), history (arrays iteration,
    N, residual, action, seconds), summary (the whole summary.json dictionary).
    """

    def __init__(self, raw, model_coords):
        self.summary = json.loads(raw["summary"])
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
        self.method = s["method"]
        self.N = s["N"]
        self.final_time = s["final_time"]
        self.wall_seconds = s["wall_seconds"]
        self.model = s["model"]
        self.stopped_by_callback = raw["stopped_by_callback"]

    @property
    def converged(self):
        return self.status == "converged"

    def coordinate(self, name):
        """The values of one coordinate (by name) at the nodes."""
        return self.q[:, self.coords.index(name)]

    def __repr__(self):
        return "pardel.Result(%s: %d iterations, residual %.3g, %s = %.6g, %s)" % (
            self.status, self.iterations, self.residual, self.cost_name,
            self.cost if self.cost is not None else float("nan"), self.point.get("kind"))


def _guess_arrays(guess):
    """(q, t) of an initial guess given as an array or a previous Result (t None: uniform)."""
    if guess is None:
        return None, None
    if isinstance(guess, Result):
        return guess.q, guess.t
    return np.asarray(guess, dtype=float), None


def solve_scene(scene, guess=None, threads=None, on_iteration=None):
    """Solves a scene (from load_scene) as `pardel solve` does, without writing files.

    guess: None (the scene's guess), an (M+1) x dim array or a previous Result (resampled to the
    scene's N when M differs). on_iteration(iteration, N, residual, action): called after each
    recorded iteration; returning False stops the solve (status "interrupted"). Ctrl-C stops it
    too and raises KeyboardInterrupt.
    """
    q, t = _guess_arrays(guess)
    raw = _pardel.solve_scene(scene._core, q, t, on_iteration, threads)
    return Result(raw, scene.info["model"].info()["coords"])


def solve(model, q0=None, qN=None, T=None, N=None, *, guess=None, on_iteration=None, **options):
    """Solves one boundary-value problem.

    model: a bundled name, a .lag path, .lag text or a Model. q0, qN: boundary points (dim values:
    coords, then derivatives up to order - 1). T: final time minus t0. N: intervals.
    Keyword options (the scene keys of `pardel solve`, docs/examples.md): discretization, params
    (dict by name, or a list in declaration order), t0, knots ([(t, q), ...]), polyline (guess
    vertices), clock, method, tol, rtol, max_iterations, damping, newton_substeps, newton_shift,
    linear_solver, threads, refine_start_N, refine_factor, clock_update_every; and history_every,
    refine_settle, divergence_factor of pardel::Options. guess and on_iteration: as in solve_scene.
    Unknown options and bad values raise PardelError (a ValueError) naming them.
    """
    arguments = dict(options)
    for name, value in (("q0", q0), ("qN", qN), ("T", T), ("N", N)):
        if value is not None:
            arguments[name] = value
    spec = _model_spec(model)
    scene = Scene(_pardel.scene_from_arguments(spec, arguments))
    return solve_scene(scene, guess=guess, on_iteration=on_iteration)


class SweepVariant:
    """One variant of a sweep (a row of variants.csv): id, configuration (its index), values (the
    varied keys' values as TOML text, by key), guess ("scene", "listed 0", "random 3") and
    guess_points (the polyline's vertices, [] for the scene's own guess), status, message,
    iterations, residual, action, cost, seconds, certificate (the point's verdict when converged,
    else None), solution (the id of the distinct solution it reached, or None), and t, q (its
    trajectory as arrays when converged, else None: the sweep keeps only converged trajectories)."""

    def __init__(self, raw, values):
        for key, value in raw.items():
            setattr(self, key, value)
        self.values = values
        self.guess_points = [list(p) for p in raw["guess_points"]]
        if self.t is not None:
            self.t = np.asarray(self.t)
            self.q = np.asarray(self.q)

    @property
    def converged(self):
        return self.status == "converged"

    def __repr__(self):
        return "pardel.SweepVariant(%d, %s: %s, cost %.10g, solution %s)" % (
            self.id, self.guess, self.status, self.cost, self.solution)


class SweepSolution:
    """A distinct local solution of a sweep (a row of solutions.csv): id, configuration, rank (1 =
    lowest cost in its configuration), cost, action, residual, variants (the ids of the variants
    that reached it), first_variant (the representative), certificate, and t, q (the
    representative's trajectory, what solution_<id>.csv holds)."""

    def __init__(self, raw, representative):
        for key, value in raw.items():
            setattr(self, key, value)
        self.variants = list(raw["variants"])
        self.certificate = representative.certificate
        self.t = representative.t
        self.q = representative.q

    def __repr__(self):
        return "pardel.SweepSolution(%d: configuration %d, rank %d, cost %.10g, %d variants, %s)" % (
            self.id, self.configuration, self.rank, self.cost, len(self.variants), self.certificate)


class SweepResult:
    """What pardel.sweep returned: variants (a SweepVariant per variant, in variant order),
    solutions (a SweepSolution per distinct solution, by configuration then cost), best (the
    lowest-cost solution or None), summary (the dictionary of sweep.json), and from it
    configurations, cost_name, converged (how many variants converged), failures (counts by
    status) and wall_seconds; out is the folder the files were written to, or None."""

    def __init__(self, raw, out):
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

    def __repr__(self):
        return "pardel.SweepResult(%s: %d variants, %d converged, %d distinct solutions)" % (
            self.summary["sweep"], len(self.variants), self.converged, len(self.solutions))


def sweep(path, overrides=(), *, threads=None, out=None):
    """Runs a sweep file as `pardel sweep` does (pardel::app's sweep: the same variants, solves,
    grouping and ranking) and returns a SweepResult.

    overrides: "key=value" strings for the base scene, as `pardel sweep --set` takes. threads:
    threads per variant (None: the scene's solver.threads, where 0 is all cores). out: a folder
    to write solutions.csv, variants.csv, sweep.json and solution_<id>.csv into (no sweep.png;
    None: no files). A bad sweep file raises SceneError with the command line's FILE:LINE:COL message.
    Ctrl-C stops the running solve; the outputs (when out is given) hold what was done, and
    KeyboardInterrupt is raised.
    """
    if threads is not None and (isinstance(threads, bool) or int(threads) != threads
                                or not 1 <= threads <= _pardel.max_threads):
        raise PardelError("threads: an integer in [1, %d] was expected, got %r" % (_pardel.max_threads, threads))
    out = None if out is None else os.fspath(out)
    if out == "":
        raise PardelError("out: a folder was expected, got ''")
    raw = _pardel.run_sweep(os.fspath(path), list(overrides), 0 if threads is None else int(threads), out or "")
    return SweepResult(raw, out)


def check(scene, q=None):
    """`pardel check`: the seed's convergence certificate at a trajectory (q an array or a Result;
    None: the scene's initial guess), as the dictionary of `pardel check --json`; its "certificate"
    also holds free_components, intervals_violating, residual, tol, error and report (the text of
    `pardel check`), the members of pardel::Certificate that --json leaves out."""
    arr, t = _guess_arrays(q)
    return json.loads(_pardel.check_scene(scene._core, arr, t))


def kernels(model, discretization, h, t0, t1, q0, q1, params=None):
    """The discrete Lagrangian and its derivatives on one interval (what `pardel kernels` prints):
    a dict Ld, D1, D2, D11, D12, D22. params: dict by name (defaults for the rest) or a list."""
    m = model if isinstance(model, Model) else Model(model)
    if params is None or isinstance(params, dict):
        values = dict(m.params)
        for name, value in (params or {}).items():
            if name not in values:
                raise PardelError("unknown param '%s' of model %s (it has: %s)" % (name, m.name, ", ".join(values)))
            values[name] = value
        params = list(values.values())
    return _pardel.kernels(m._handle, discretization, float(h), float(t0), float(t1),
                           [float(v) for v in q0], [float(v) for v in q1], [float(v) for v in params])
