"""Arguments of the wrong type or value raise Python's exceptions naming the argument: every
public function, every argument, fed a str, a float, a complex, None, a list of str, a huge int and
a bool where that is not valid, raises TypeError or ValueError (never pybind11's "Unable to cast"),
and arrays are never cast: a complex array is refused, not silently made real."""
import math
import re

import numpy as np
import pytest

import pardel
import pardel.plot

HOSTILE = {
    "str": "abc",
    "float": 2.5,
    "complex": 1 + 2j,
    "None": None,
    "list_of_str": ["a", "b"],
    "huge_int": 10**30,
    "bool": True,
}
ALL = tuple(HOSTILE)


def without(*valid):
    return tuple(kind for kind in ALL if kind not in valid)


# For each public function, its arguments and the hostile kinds each must refuse (the others are
# valid values of that argument: a float T, a None guess, the str of a model's name, ...).
SOLVE = {
    "model": without("str"),
    "q0": ALL,
    "qN": ALL,
    "T": without("float", "huge_int"),
    "N": ALL,
    "guess": without("None"),
    "on_iteration": without("None"),
    "discretization": without("None"),
    "clock": without("None"),
    "method": without("None"),
    "linear_solver": without("None"),
    "newton_shift": without("None"),
    "iterative_refinement": without("None"),
    "params": without("None"),
    "t0": without("None", "float", "huge_int"),
    "tol": without("None", "float", "huge_int"),
    "rtol": without("None"),
    "damping": without("None"),
    "refine_factor": without("None", "float"),
    "refine_settle": without("None"),
    "divergence_factor": without("None", "float", "huge_int"),
    "max_iterations": without("None"),
    "newton_substeps": without("None"),
    "threads": without("None"),
    "refine_start_N": without("None"),
    "clock_update_every": without("None"),
    "history_every": without("None"),
    "knots": without("None"),
    "polyline": without("None"),
    "error_estimate": without("None", "bool"),
    "extrapolate": without("None", "bool"),
}
MODEL = {"spec": without("str")}
LOAD_SCENE = {"path": without("str"), "overrides": without("list_of_str")}
SWEEP = {"path": without("str"), "overrides": without("list_of_str"), "threads": without("None"),
         "out": without("str", "None")}
SOLVE_SCENE = {"scene": ALL, "guess": without("None"), "threads": without("None"), "on_iteration": without("None")}
CHECK = {"scene": ALL, "q": without("None")}
KERNELS = {"model": without("str"), "discretization": ALL, "h": without("float", "huge_int"),
           "t0": without("float", "huge_int"), "t1": without("float", "huge_int"), "q0": ALL, "q1": ALL,
           "params": without("None")}

PLOT = {"result": ALL}

FUNCTIONS = {"solve": SOLVE, "model": MODEL, "load_scene": LOAD_SCENE, "sweep": SWEEP, "solve_scene": SOLVE_SCENE,
             "check": CHECK, "kernels": KERNELS, "plot.path": PLOT, "plot.coordinates": PLOT,
             "plot.convergence": PLOT}
CASES = [(function, argument, kind) for function, table in FUNCTIONS.items()
         for argument, kinds in table.items() for kind in kinds]

SWEEP_FILE = """\
scene = "spring.toml"
[[vary]]
key = "params.a"
values = [1.5]
"""
SCENE_FILE = """\
model = "spring.lag"
[grid]
T = 1
N = 10
[boundary]
q0 = [0, 0]
qN = [1, 2]
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory, spring_lag):
    folder = tmp_path_factory.mktemp("arguments")
    (folder / "spring.lag").write_text(spring_lag)
    (folder / "spring.toml").write_text(SCENE_FILE)
    (folder / "sweep.toml").write_text(SWEEP_FILE)
    return folder


@pytest.fixture(scope="module")
def valid(files, spring_lag):
    """Valid arguments of each function (by keyword): each case replaces one of them."""
    scene = pardel.load_scene(files / "spring.toml")
    result = pardel.solve_scene(scene)
    return {
        "solve": dict(model=spring_lag, q0=[0, 0], qN=[1, 2], T=1.0, N=10),
        "model": dict(spec=spring_lag),
        "load_scene": dict(path=files / "spring.toml", overrides=[]),
        "sweep": dict(path=files / "sweep.toml", overrides=[], threads=1, out=None),
        "solve_scene": dict(scene=scene, guess=None, threads=1, on_iteration=None),
        "check": dict(scene=scene, q=None),
        "kernels": dict(model=spring_lag, discretization="trapezoid", h=0.1, t0=0.0, t1=0.1, q0=[0, 0],
                        q1=[0.1, 0.2], params=None),
        "plot.path": dict(result=result),
        "plot.coordinates": dict(result=result),
        "plot.convergence": dict(result=result),
    }


def call(function, arguments):
    arguments = dict(arguments)
    if function == "model":
        return pardel.model(arguments["spec"])
    if function == "solve":
        return pardel.solve(arguments.pop("model"), **arguments)
    if function.startswith("plot."):
        return getattr(pardel.plot, function[len("plot."):])(**arguments)
    return getattr(pardel, function)(**arguments)


def names_argument(message, argument):
    """Whether the message names the argument as a word (q0, N, solver.method, params['a'], ...)."""
    return re.search(r"(^|[\s:'(.\[])%s($|[\s:'),.\[])" % re.escape(argument), message) is not None


@pytest.mark.parametrize("function,argument,kind", CASES, ids=["-".join(c) for c in CASES])
def test_hostile_argument_is_refused_naming_it(valid, function, argument, kind):
    arguments = dict(valid[function], **{argument: HOSTILE[kind]})
    with pytest.raises((TypeError, ValueError)) as info:
        call(function, arguments)
    message = str(info.value)
    assert "Unable to cast" not in message and "incompatible function arguments" not in message, message
    assert names_argument(message, argument), "%s does not name %s" % (message, argument)
    assert message.startswith("pardel.%s: " % function), message


def test_the_fuzz_covers_enough_cases():
    assert len(CASES) >= 40
    assert set(SOLVE) >= {"q0", "qN", "T", "N", "max_iterations", "threads", "params", "guess"}


# Exact messages of the issue: the argument, the expected type or range, what was given.

def test_huge_n_names_the_range(spring_lag):
    with pytest.raises(ValueError, match=r"^pardel\.solve: N must be an int between 2 and 100000000, got 1e\+30$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10**30)
    with pytest.raises(pardel.PardelError, match=r"N must be an int between 2 and 100000000, got 1$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=1)
    with pytest.raises(TypeError, match=r"^pardel\.solve: N must be an int, got float 10\.0$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10.0)
    with pytest.raises(TypeError, match=r"^pardel\.solve: N must be an int, got bool True$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=True)


def test_the_bound_of_n_is_the_scene_readers():
    with pytest.raises(pardel.SceneError) as info:
        pardel.load_scene("scenes/fuel_nav.toml", ["grid.N=1"])
    bound = re.search(r"grid\.N must be between 2 and (\d+)", str(info.value))
    assert bound and int(bound.group(1)) == pardel._MAX_N


def test_numpy_integers_and_floats_are_numbers(spring_lag):
    r = pardel.solve(spring_lag, q0=np.array([0, 0], dtype=np.int32), qN=[np.float32(1), 2], T=np.float64(1),
                     N=np.int64(10), max_iterations=np.int16(100), tol=np.float32(1e-9))
    assert r.converged and r.N == 10 and r.q.shape == (11, 2)


def test_complex_arrays_are_refused_not_cast(spring_lag):
    for q0 in (np.array([0, 0], dtype=complex), [0, 1j], np.array([0, 1j], dtype=object)):
        with pytest.raises(TypeError, match=r"^pardel\.solve: q0 must be real, got (complex128|a complex element 1j)$"):
            pardel.solve(spring_lag, q0=q0, qN=[1, 2], T=1, N=10)
    with pytest.raises(TypeError, match=r"guess must be real, got complex128"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, guess=np.zeros((11, 2), dtype=complex))
    with pytest.raises(TypeError, match=r"params must be real, got complex128"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, params=[1.5, 0.7 + 0j])
    with pytest.raises(TypeError, match=r"params\['a'\] must be real, got complex"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, params={"a": 1.5 + 0j})
    with pytest.raises(TypeError, match=r"^pardel\.kernels: q1 must be real, got complex128$"):
        pardel.kernels(spring_lag, "trapezoid", 0.1, 0, 0.1, [0, 0], np.array([0.1, 0.2], dtype=complex))
    # Refusals the compiled core makes name the function too.
    with pytest.raises(pardel.PardelError, match=r"^pardel\.solve: guess: shape \(11, 3\) given"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, guess=np.zeros((11, 3)))
    with pytest.raises(pardel.PardelError, match=r"^pardel\.solve: params: 3 values given"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, params=[1.0, 2.0, 3.0])
    with pytest.raises(pardel.PardelError, match=r"^pardel\.kernels: q0 and q1 need 2 values each"):
        pardel.kernels(spring_lag, "trapezoid", 0.1, 0, 0.1, [0, 0, 0], [0.1, 0.2])
    for h in (0.0, -0.1):  # as `pardel kernels --h`: no discrete Lagrangian without a positive step
        with pytest.raises(pardel.PardelError, match=r"^pardel\.kernels: h, the step, must be a finite number > 0"):
            pardel.kernels(spring_lag, "trapezoid", h, 0, 0.1, [0, 0], [0.1, 0.2])
    with pytest.raises(TypeError, match=r"^pardel\.solve: T must be real, got complex 1j$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1j, N=10)


def test_nan_and_inf_are_refused_where_not_allowed(spring_lag):
    with pytest.raises(ValueError, match=r"^pardel\.solve: q0 must be finite, got nan at index 1$"):
        pardel.solve(spring_lag, q0=[0, math.nan], qN=[1, 2], T=1, N=10)
    with pytest.raises(ValueError, match=r"^pardel\.solve: T must be a finite number, got nan$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=math.nan, N=10)
    with pytest.raises(ValueError, match=r"^pardel\.solve: T must be > 0, got -1$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=-1, N=10)
    guess = np.zeros((11, 2))
    guess[4, 1] = math.inf
    with pytest.raises(ValueError, match=r"guess must be finite, got inf at index \(4, 1\)"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, guess=guess)
    with pytest.raises(ValueError, match=r"^pardel\.solve: tol must be a finite number >= 0"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, tol=math.inf)
    with pytest.raises(ValueError, match=r"^pardel\.solve: rtol must be a number, not NaN$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, rtol=math.nan)
    with pytest.raises(ValueError, match=r"params\['b'\] must be a finite number, got nan"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, params={"b": math.nan})
    # divergence_factor's bound includes +inf (never diverged)
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, divergence_factor=math.inf)
    assert r.converged


def test_option_ranges_are_the_runtimes(spring_lag):
    with pytest.raises(ValueError, match=r"^pardel\.solve: threads must be an int between 0 and 4096, got 4097$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, threads=4097)
    with pytest.raises(ValueError, match=r"^pardel\.solve: max_iterations must be an int between 0 and "
                                         r"9223372036854775807, got 1e\+30$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, max_iterations=10**30)
    with pytest.raises(ValueError, match=r"refine_start_N must be an int 0 \(off\) or between 2 and 2147483647, got 1$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, refine_start_N=1)
    with pytest.raises(ValueError, match=r"^pardel\.solve: refine_factor must be in \(1, 16\], got 17$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, refine_factor=17)
    with pytest.raises(ValueError, match=r"^pardel\.solve_scene: threads must be an int between 0 and 4096, got -1$"):
        pardel.solve_scene(pardel.load_scene("scenes/fuel_nav.toml"), threads=-1)


def test_bare_solve_asks_for_its_arguments_in_python_words(spring_lag):
    with pytest.raises(TypeError) as info:
        pardel.solve(spring_lag)
    message = str(info.value)
    assert message == ("pardel.solve: missing arguments q0 (the boundary point at t0), qN (the boundary point at "
                       "t0 + T), T (the final time minus t0), N (the number of intervals)")
    assert "[grid]" not in message and "table" not in message
    with pytest.raises(TypeError, match=r"^pardel\.solve: missing argument N \(the number of intervals\)$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1)


def test_params_names_must_be_str_and_knots_pairs(spring_lag):
    with pytest.raises(TypeError, match=r"params: the names must be str, got int 1"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, params={1: 2.0})
    with pytest.raises(TypeError, match=r"knots\[0\] must be a pair \(t, q\), got float 0\.5"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, knots=[0.5])
    with pytest.raises(TypeError, match=r"knots\[0\]\.q must be real, got complex128"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, knots=[(0.5, [1j, 0])])
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, knots=[(np.float64(0.5), np.array([0.3, 0.4]))])
    assert r.converged and np.allclose(r.q[5], [0.3, 0.4], rtol=0, atol=1e-12)


def test_on_iteration_without_a_truth_value_raises_its_own_error(spring_lag):
    with pytest.raises(ValueError, match=r"truth value of an array"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, on_iteration=lambda *a: np.array([1, 2]))


def test_overrides_must_be_a_list_of_str(files):
    with pytest.raises(TypeError, match=r"^pardel\.load_scene: overrides must be a list of 'key=value' strings, "
                                        r"got str 'grid\.N=20'$"):
        pardel.load_scene(files / "spring.toml", "grid.N=20")
    with pytest.raises(TypeError, match=r"^pardel\.sweep: overrides\[1\] must be a 'key=value' str, got int 3$"):
        pardel.sweep(files / "sweep.toml", ["grid.N=20", 3])
    assert pardel.load_scene(files / "spring.toml", ("grid.N=20",)).N == 20
