"""repr() and str() of a pardel.Result work for every status, also when the solve ended non-finite
and summary.json holds null for its residual, action or cost."""
import numpy as np
import pytest

import pardel

# L = x'^2/2 + x'/x with x = 0 at the start: D2 Ld of the first interval holds 1/(h x_0), the
# residual is infinite from the first evaluation on (tests/reliability/test_nonfinite_models.cpp),
# and summary.json holds null for the residual and the action.
INVERSE_LAG = "model python_inverse\ncoords x\nL = 1/2*x'^2 + x'/x\n"
STATUSES = ("converged", "max_iterations", "diverged", "non_finite", "interrupted", "stalled")


def test_a_non_finite_solve_prints():
    r = pardel.solve(INVERSE_LAG, q0=[0.0], qN=[1.0], T=1, N=16, method="jacobi", tol=1e-10, max_iterations=2000,
                     threads=2)
    assert r.status == "non_finite", r.message
    assert r.summary["residual"] is None and r.residual is None
    text = repr(r)
    assert text.startswith("pardel.Result(non_finite: 0 iterations, residual nan, action = nan, ")
    assert str(r) == text
    assert np.all(np.isfinite(r.q))  # the last finite iterate: the initial line


def _with(result, **changes):
    """A Result like `result` with members of its summary replaced."""
    summary = dict(result.summary, **changes)
    raw = {"summary": summary, "t": result.t, "q": result.q, "p0": result.p0, "pN": result.pN,
           "history": result.history, "stopped_by_callback": False}
    return pardel.Result(raw, result.coords)


@pytest.fixture(scope="module")
def converged(spring_lag):
    return pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10)


@pytest.mark.parametrize("status", STATUSES)
def test_every_status_prints_also_with_null_numbers(converged, status):
    finite = _with(converged, status=status)
    assert repr(finite).startswith("pardel.Result(%s: " % status) and str(finite) == repr(finite)
    nulls = _with(converged, status=status, residual=None, action=None, cost=dict(converged.summary["cost"], value=None),
                  point=None)
    text = repr(nulls)
    assert text.startswith("pardel.Result(%s: %d iterations, residual nan, " % (status, converged.iterations))
    assert str(nulls) == text


def test_real_statuses_print(spring_lag):
    stopped = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, on_iteration=lambda *a: False)
    capped = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2, N=200, method="jacobi", max_iterations=3)
    assert (stopped.status, capped.status) == ("interrupted", "max_iterations")
    for r in (stopped, capped):
        assert repr(r).startswith("pardel.Result(%s: %d iterations, residual " % (r.status, r.iterations))


def test_an_unknown_coordinate_is_named(converged):
    assert np.array_equal(converged.coordinate("y"), converged.q[:, 1])
    with pytest.raises(ValueError, match=r"^pardel\.Result\.coordinate: unknown coordinate 'z' \(the model's: x, y\)$"):
        converged.coordinate("z")
    with pytest.raises(TypeError, match=r"^pardel\.Result\.coordinate: name must be a str, got int 0$"):
        converged.coordinate(0)
