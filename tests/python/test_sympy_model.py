"""pardel.model_from_sympy: Lagrangians built with SymPy (a charged particle in a magnetic field, a
forced Duffing oscillator with explicit time dependence, a second-order beam-like model) solve to
the numbers of the same models written by hand as .lag text, and to independent solutions: the
closed-form motion and the exact solution of the discrete recursion (solved here with NumPy), a
Runge-Kutta shot of the continuous equation, and the closed-form solution of a fourth-order ODE.
Two bundled models written again with SymPy (zermelo_tv with its clock and cost, the pendulum with
dynamicsymbols) solve as the bundled ones. What .lag cannot write is refused, naming the argument."""
import math
import pickle

import numpy as np
import pytest

import pardel

sp = pytest.importorskip("sympy")

t = sp.Symbol("t")
x, y = sp.Function("x")(t), sp.Function("y")(t)


# ---------------------------------------------------------------------------------------------
# A charged particle in a uniform magnetic field: L = m|q'|^2/2 + (qB/2)(x y' - y x').
# Equations m x'' = qB y', m y'' = -qB x': with z = x + i y, z(t) = c + a exp(-i w t), w = qB/m.

MAGNETIC_LAG = """\
model magnetic_hand
coords x y
param m = 2
param qB = 1.5
L = 1/2*m*(x'^2 + y'^2) + 1/2*qB*(x*y' - y*x')
discretizations midpoint galerkin_gauss(s=4)
"""


def magnetic_sympy(**overrides):
    m, qB = sp.symbols("m qB")
    L = m / 2 * (x.diff(t) ** 2 + y.diff(t) ** 2) + qB / 2 * (x * y.diff(t) - y * x.diff(t))
    arguments = dict(name="magnetic", discretizations=["midpoint", "galerkin_gauss(s=4)"])
    arguments.update(overrides)
    return pardel.model_from_sympy(L, [x, y], {m: 2, "qB": 1.5}, **arguments)


def magnetic_exact(t_nodes, m, qB, z0, zT, T):
    w = qB / m
    a = (z0 - zT) / (1 - np.exp(-1j * w * T))
    z = z0 - a + a * np.exp(-1j * w * t_nodes)
    return np.column_stack([z.real, z.imag])


def magnetic_midpoint_discrete(m, qB, q0, qN, T, N):
    """The exact solution of the midpoint DEL equations, derived by hand: Ld(a, b) =
    m|b - a|^2/(2h) + (qB/2)(a_x b_y - b_x a_y), so at node k
    (m/h)(2 q_k - q_{k-1} - q_{k+1}) + (qB/2)(y_{k+1} - y_{k-1}, x_{k-1} - x_{k+1}) = 0,
    a linear system in the interior nodes."""
    h = T / N
    n = N - 1
    A = np.zeros((2 * n, 2 * n))
    rhs = np.zeros(2 * n)
    q = np.vstack([q0, np.zeros((n, 2)), qN])

    def add(row, node, comp, coef):
        if node == 0 or node == N:
            rhs[row] -= coef * q[node, comp]
        else:
            A[row, 2 * (node - 1) + comp] += coef

    for k in range(1, N):
        rx, ry = 2 * (k - 1), 2 * (k - 1) + 1
        for comp, row in ((0, rx), (1, ry)):
            add(row, k, comp, 2 * m / h)
            add(row, k - 1, comp, -m / h)
            add(row, k + 1, comp, -m / h)
        add(rx, k + 1, 1, qB / 2)
        add(rx, k - 1, 1, -qB / 2)
        add(ry, k - 1, 0, qB / 2)
        add(ry, k + 1, 0, -qB / 2)
    q[1:N] = np.linalg.solve(A, rhs).reshape(n, 2)
    return q


def test_magnetic_model_is_the_hand_written_one():
    model = magnetic_sympy()
    hand = pardel.model(MAGNETIC_LAG)
    assert model.name == "magnetic" and model.coords == ["x", "y"] and model.order == 1
    assert model.params == {"m": 2.0, "qB": 1.5} == hand.params
    assert model.discretizations == hand.discretizations == ["midpoint", "galerkin_gauss(s=4)"]
    assert model.lag_text.startswith("# written by pardel.model_from_sympy\n")
    rng = np.random.default_rng(3)
    for discretization in model.discretizations:
        for _ in range(3):
            q0, q1 = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
            a = pardel.kernels(model, discretization, 0.1, 0.3, 0.4, q0, q1, params={"qB": -0.7})
            b = pardel.kernels(hand, discretization, 0.1, 0.3, 0.4, q0, q1, params={"qB": -0.7})
            for key in ("Ld", "D1", "D2", "D11", "D12", "D22"):
                np.testing.assert_allclose(a[key], b[key], rtol=1e-13, atol=1e-13)
        r = pardel.solve(model, q0=[0, 0], qN=[1, 0.5], T=2, N=40, discretization=discretization)
        s = pardel.solve(hand, q0=[0, 0], qN=[1, 0.5], T=2, N=40, discretization=discretization)
        assert r.converged and s.converged
        np.testing.assert_allclose(r.q, s.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("m,qB", [(2.0, 1.5), (0.5, -3.0)])
def test_magnetic_model_against_exact_solutions(m, qB):
    model = magnetic_sympy()
    T, N, q0, qN = 2.0, 40, np.array([0.2, -0.1]), np.array([1.0, 0.5])
    params = {"m": m, "qB": qB}
    # Midpoint: the exact solution of its discrete equations.
    r = pardel.solve(model, q0=q0, qN=qN, T=T, N=N, discretization="midpoint", params=params)
    assert r.converged, r.message
    np.testing.assert_allclose(r.q, magnetic_midpoint_discrete(m, qB, q0, qN, T, N), rtol=0, atol=1e-12)
    # galerkin_gauss(s=4), of order 8: the continuous motion, to h^8 (w h = 0.075 or 0.3).
    r = pardel.solve(model, q0=q0, qN=qN, T=T, N=N, discretization="galerkin_gauss(s=4)", params=params)
    assert r.converged, r.message
    exact = magnetic_exact(r.t, m, qB, q0[0] + 1j * q0[1], qN[0] + 1j * qN[1], T)
    assert np.abs(r.q - exact).max() < 1e-9


# ---------------------------------------------------------------------------------------------
# A forced Duffing oscillator: L = x'^2/2 - k x^2/2 - beta x^4/4 + F cos(Omega t) x, explicit in t,
# with a constant SymPy expression (pi/2) as a default: x'' = -k x - beta x^3 + F cos(Omega t).

DUFFING_LAG = """\
model duffing_hand
coords x
param k = 1
param beta = 0.5
param F = 3/10
param Omega = pi/2
L = 1/2*x'^2 - 1/2*k*x^2 - 1/4*beta*x^4 + F*cos(Omega*t)*x
discretizations trapezoid galerkin_gauss(s=4)
"""


def duffing_sympy():
    k, beta, F, Omega = sp.symbols("k beta F Omega")
    time = sp.Symbol("t", real=True)  # another Symbol named t than the coordinate's: still the time
    L = x.diff(t) ** 2 / 2 - k * x ** 2 / 2 - beta * x ** 4 / 4 + F * sp.cos(Omega * time) * x
    return pardel.model_from_sympy(L, [x], {k: 1, beta: 0.5, F: sp.Rational(3, 10), Omega: sp.pi / 2},
                                   name="duffing", discretizations=["trapezoid", "galerkin_gauss(s=4)"])


def rk4_shot(t0, x0, v0, T, steps, k, beta, F, Omega):
    """x and x' at the T/steps-spaced times from t0, from (x0, v0), by the classical Runge-Kutta
    method on the continuous equation x'' = -k x - beta x^3 + F cos(Omega t)."""
    def f(s, u):
        return np.array([u[1], -k * u[0] - beta * u[0] ** 3 + F * math.cos(Omega * s)])

    h, u = T / steps, np.array([x0, v0], dtype=float)
    out = [u]
    for i in range(steps):
        s = t0 + i * h
        k1 = f(s, u)
        k2 = f(s + h / 2, u + h / 2 * k1)
        k3 = f(s + h / 2, u + h / 2 * k2)
        k4 = f(s + h, u + h * k3)
        u = u + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(u)
    return np.array(out)


def test_time_dependent_duffing_is_the_hand_written_one_and_the_continuous_motion():
    model, hand = duffing_sympy(), pardel.model(DUFFING_LAG)
    assert model.time_dependent and hand.time_dependent
    assert model.params == pytest.approx({"k": 1, "beta": 0.5, "F": 0.3, "Omega": math.pi / 2}, rel=1e-15)
    assert hand.params == pytest.approx(model.params, rel=1e-15)
    T, N, t0 = 3.0, 30, 0.4
    params = {"beta": 2.0}
    for discretization in model.discretizations:
        r = pardel.solve(model, q0=[0.1], qN=[-0.6], T=T, N=N, t0=t0, params=params, discretization=discretization)
        s = pardel.solve(hand, q0=[0.1], qN=[-0.6], T=T, N=N, t0=t0, params=params, discretization=discretization)
        assert r.converged and s.converged
        np.testing.assert_allclose(r.q, s.q, rtol=0, atol=1e-12)
    # The continuous motion through the solve's first node with its velocity x'(t0) = p0 (the
    # momentum dL/dx' is x'): galerkin_gauss(s=4) is of order 8 in h = 0.1, and RK4 with 3000
    # steps is accurate to ~1e-13, so the nodes and the end momentum agree to well below 1e-9.
    steps = 3000
    shot = rk4_shot(t0, 0.1, r.p0[0], T, steps, 1.0, 2.0, 0.3, math.pi / 2)
    nodes = shot[:: steps // N]
    np.testing.assert_allclose(r.t, t0 + np.linspace(0, T, N + 1), rtol=0, atol=1e-13)
    assert np.abs(r.q[:, 0] - nodes[:, 0]).max() < 1e-9
    assert abs(r.pN[0] - nodes[-1, 1]) < 1e-9


# ---------------------------------------------------------------------------------------------
# Second order: L = x''^2/2 + c x'^2/2, Euler-Lagrange x'''' = c x'', so x = A + B t +
# C cosh(s t) + D sinh(s t) with s = sqrt(c), fixed by x and x' at both ends.

BEAM_LAG = """\
model beam_hand
order 2
coords x
param c = 4
L = 1/2*x''^2 + 1/2*c*x'^2
discretizations gauss2 galerkin_gauss(s=4)
"""


def beam_exact(times, c, start, end, T):
    """x and x' of the solution of x'''' = c x'' with x, x' given at 0 and T."""
    s = math.sqrt(c)

    def rows(u):
        return [[1, u, math.cosh(s * u), math.sinh(s * u)], [0, 1, s * math.sinh(s * u), s * math.cosh(s * u)]]

    coefficients = np.linalg.solve(np.array(rows(0.0) + rows(T)), np.array(list(start) + list(end)))
    basis = np.column_stack([np.ones_like(times), times, np.cosh(s * times), np.sinh(s * times)])
    slopes = np.column_stack([np.zeros_like(times), np.ones_like(times), s * np.sinh(s * times),
                              s * np.cosh(s * times)])
    return np.column_stack([basis @ coefficients, slopes @ coefficients])


def test_second_order_model_prints_derivatives_as_primes():
    c = sp.Symbol("c")
    L = x.diff(t, 2) ** 2 / 2 + c * x.diff(t) ** 2 / 2
    model = pardel.model_from_sympy(L, [x], {c: 4}, name="beam", discretizations=["gauss2", "galerkin_gauss(s=4)"])
    hand = pardel.model(BEAM_LAG)
    assert model.order == 2 and model.dim == 2
    start, end, T, N = [0.0, 1.0], [0.5, -0.5], 2.0, 20
    for discretization in model.discretizations:
        r = pardel.solve(model, q0=start, qN=end, T=T, N=N, discretization=discretization, params={"c": 2.5})
        s = pardel.solve(hand, q0=start, qN=end, T=T, N=N, discretization=discretization, params={"c": 2.5})
        assert r.converged and s.converged
        np.testing.assert_allclose(r.q, s.q, rtol=0, atol=1e-12)
    # galerkin_gauss(s=4), of order 8 in h = 0.1: the positions and velocities of the exact solution.
    assert np.abs(r.q - beam_exact(r.t, 2.5, start, end, T)).max() < 1e-9
    # The order found in L is the order given.
    same = pardel.model_from_sympy(L, [x], {c: 4}, order=2, name="beam", discretizations=model.discretizations)
    assert same.lag_text == model.lag_text


# ---------------------------------------------------------------------------------------------
# What .lag cannot write is refused, naming the argument; the generator's own refusals are
# ModelError as for .lag text.

def refused(L, coords=None, params=None, error=pardel.PardelError, **kwargs):
    with pytest.raises(error) as info:
        pardel.model_from_sympy(L, [x] if coords is None else coords, params, **kwargs)
    message = str(info.value)
    assert message.startswith("pardel.model_from_sympy: "), message
    return message


def test_refusals_name_the_argument_and_the_part():
    k, s = sp.symbols("k s")
    v = x.diff(t)
    assert "L cannot be written as .lag: the function Abs" in refused(v ** 2 / 2 - sp.Abs(x))
    assert "the function gamma" in refused(v ** 2 / 2 - sp.gamma(x))
    assert "the symbol k is neither the time t nor a param" in refused(v ** 2 / 2 - k * x ** 2)
    assert "y(t) is a function that is not among the coordinates (x)" in refused(v ** 2 / 2 - y * x)
    assert "a coordinate must be applied to the time t alone" in refused(v ** 2 / 2 - sp.Function("x")(2 * t))
    assert "other than the time t" in refused(v ** 2 / 2 + sp.Derivative(x, s, evaluate=False))
    assert "only the coordinates' time derivatives" in refused(v ** 2 / 2 + sp.Derivative(x ** 2, t))
    assert "the number I is not a finite real number" in refused(v ** 2 / 2 + sp.I * x)
    assert "the number oo is not a finite real number" in refused(v ** 2 / 2 + sp.oo * x)
    assert "the constant GoldenRatio has no .lag form" in refused(v ** 2 / 2 + sp.GoldenRatio * x)
    assert "Piecewise" in refused(v ** 2 / 2 + sp.Piecewise((x, x > 0), (0, True)))
    assert "clock cannot be written as .lag: the function Abs" in refused(v ** 2 / 2, clock=sp.Abs(v))
    assert "params['k'] cannot be written as .lag" in refused(v ** 2 / 2 - k * x ** 2, params={k: sp.EulerGamma})
    assert "order is 1, but L has a time derivative of order 2" in refused(x.diff(t, 2) ** 2, order=1)


def test_refusals_of_arguments():
    v = x.diff(t)
    L = v ** 2 / 2
    k = sp.Symbol("k")
    assert "L must be a SymPy expression, got str" in refused("x'^2", error=TypeError)
    assert "L must be a SymPy expression (sympy.Expr)" in refused(sp.Eq(v, 1), error=TypeError)
    assert "coords must be a list" in refused(L, coords="x", error=TypeError)
    assert "coords[0] must be a function of the time symbol" in refused(L, coords=[sp.Symbol("x")], error=TypeError)
    assert "coords is empty" in refused(L, coords=[])
    assert "every coordinate must be a function of the same time symbol" in refused(
        L, coords=[x, sp.Function("y")(sp.Symbol("s"))])
    assert "coords[1]: the coordinate 'x' is given twice" in refused(L, coords=[x, x])
    assert "reserved" in refused(sp.Function("sin")(t).diff(t) ** 2, coords=[sp.Function("sin")(t)])
    assert "not an identifier" in refused(sp.Function("x1-")(t).diff(t) ** 2, coords=[sp.Function("x1-")(t)])
    assert "params must be a dict" in refused(L, params=[k], error=TypeError)
    assert "params['k'] must be a real number or a constant SymPy expression" in refused(
        L - k * x, params={k: "1"}, error=TypeError)
    assert "params['k'] must be a real number or a constant" in refused(L - k * x, params={k: True}, error=TypeError)
    assert "params['k'] must be finite" in refused(L - k * x, params={k: float("nan")})
    assert "params['k'] must be a constant" in refused(L - k * x, params={k: sp.Symbol("a")})
    assert "params['k'] must be a finite real number" in refused(L - k * x, params={k: 1 + sp.I})
    assert "params['t']: the name is reserved" in refused(L, params={"t": 1})
    assert "params['x']: the name is also a coordinate's" in refused(L, params={"x": 1})
    assert "order must be an int between 1 and 9, got 0" in refused(L, order=0)
    assert "order must be an int, got float" in refused(L, order=1.0, error=TypeError)
    assert "name must be a letter then letters" in refused(L, name="2bad")
    assert "name must be a str" in refused(L, name=None, error=TypeError)
    assert "discretizations[0] must be a str" in refused(L, discretizations=[1], error=TypeError)
    assert "cost ('time', 'clock') needs a clock" in refused(L, cost=("time", "clock"))
    assert "allow_singular must be True or False" in refused(L, allow_singular=1, error=TypeError)


def test_the_generator_refuses_what_it_refuses_for_lag_text():
    # Linear in x': W = d2L/dx'dx' = 0 everywhere, refused by the regularity check (ModelError),
    # and accepted with a warning when declared degenerate on purpose.
    L = x.diff(t) * x - x ** 2
    with pytest.raises(pardel.ModelError, match="is not regular"):
        pardel.model_from_sympy(L, [x], name="degenerate")
    with pytest.warns(pardel.ModelWarning):
        m = pardel.model_from_sympy(L, [x], name="degenerate", allow_singular=True)
    assert m.lag_text.splitlines()[1] == "# pardel: allow-singular"
    # An unknown discretization: the generator's message.
    with pytest.raises(pardel.ModelError, match="unknown discretization"):
        pardel.model_from_sympy(x.diff(t) ** 2 / 2, [x], name="nodisc", discretizations=["leapfrog"])


def test_a_sympy_model_pickles_as_its_text():
    model = magnetic_sympy()
    again = pickle.loads(pickle.dumps(model))
    assert again.lag_text == model.lag_text and again.spec == model.spec
    assert (again.name, again.coords, again.params) == (model.name, model.coords, model.params)


# ---------------------------------------------------------------------------------------------
# Bundled models written again with SymPy: the time-varying Zermelo problem (clock, cost, t, sqrt)
# and the pendulum with coordinates from sympy.physics.mechanics.dynamicsymbols solve as the
# bundled ones (lagrangians/zermelo_tv.lag, lagrangians/pendulum.lag) do.

def test_zermelo_tv_from_sympy_is_the_bundled_model():
    a = sp.Symbol("a")
    W1, W2 = a * sp.sin(2 * x + y) * sp.cos(t / 2), a * sp.sin(2 * x + y) * sp.sin(t / 2)
    alpha = 1 - (W1 ** 2 + W2 ** 2)
    Wv = W1 * x.diff(t) + W2 * y.diff(t)
    F = sp.sqrt((x.diff(t) ** 2 + y.diff(t) ** 2) / alpha + Wv ** 2 / alpha ** 2) - Wv / alpha
    model = pardel.model_from_sympy(F ** 2, [x, y], {a: sp.Rational(4, 5)}, name="zermelo_tv_sympy", clock=F,
                                    cost=("travel_time", "clock"), discretizations=["trapezoid", "midpoint"])
    bundled = pardel.model("zermelo_tv")
    assert model.has_clock and model.time_dependent and model.params == bundled.params
    for discretization in model.discretizations:
        # The seed's run (scenes/zermelo_tv.toml): the node times are the summed clock.
        problem = dict(q0=[1, 6], qN=[6, 2], T=1, N=50, clock="free_final_time", clock_update_every=100,
                       discretization=discretization)
        r, s = pardel.solve(model, **problem), pardel.solve(bundled, **problem)
        assert r.converged and s.converged
        assert r.cost_name == s.cost_name == "travel_time"
        np.testing.assert_allclose(r.q, s.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(r.t, s.t, rtol=0, atol=1e-12)
        assert r.cost == pytest.approx(s.cost, rel=1e-12)


def test_dynamicsymbols_pendulum_is_the_bundled_model():
    mechanics = pytest.importorskip("sympy.physics.mechanics")
    angle = mechanics.dynamicsymbols("x")
    time = mechanics.dynamicsymbols._t
    g, length = sp.symbols("g l")
    model = pardel.model_from_sympy(angle.diff(time) ** 2 / 2 + g / length * sp.cos(angle), [angle],
                                    {g: 9.81, length: 1}, name="pendulum_sympy",
                                    discretizations=pardel.model("pendulum").discretizations)
    for discretization in model.discretizations:
        problem = dict(q0=[0.3], qN=[-0.5], T=0.8, N=20, discretization=discretization, params={"l": 2})
        r, s = pardel.solve(model, **problem), pardel.solve("pendulum", **problem)
        assert r.converged and s.converged
        np.testing.assert_allclose(r.q, s.q, rtol=0, atol=1e-12)
