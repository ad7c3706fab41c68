"""Shared fixtures of the Python module's tests: a model no bundled example resembles (a planar
anisotropic spring, written here as .lag text) and its exact discrete solutions."""
import math
import uuid

import numpy as np
import pytest

SPRING_LAG = """\
# planar anisotropic spring: x'' = -a^2 x, y'' = -b^2 y
model aniso_spring
order 1
coords x y
param a = 1.5
param b = 0.7
L = 1/2*(x'^2 + y'^2) - 1/2*(a^2*x^2 + b^2*y^2)
discretizations trapezoid midpoint
"""


@pytest.fixture(scope="session")
def spring_lag():
    return SPRING_LAG


def discrete_angle(omega, h, discretization):
    """theta with x_k = sin(theta k) solving the DEL recursion of L = x'^2/2 - omega^2 x^2/2:
    trapezoid x_{k+1} + x_{k-1} = (2 - h^2 w^2) x_k, midpoint (1 + h^2 w^2/4)(x_{k+1} + x_{k-1})
    = (2 - h^2 w^2/2) x_k."""
    z = (h * omega) ** 2
    if discretization == "trapezoid":
        return math.acos(1 - z / 2)
    return math.acos((1 - z / 4) / (1 + z / 4))


def exact_discrete(omega, T, N, end, discretization):
    """The nodes of the exact DEL solution from 0 (at t = 0) to `end` (at t = T)."""
    theta = discrete_angle(omega, T / N, discretization)
    k = np.arange(N + 1)
    return end * np.sin(theta * k) / math.sin(theta * N)


@pytest.fixture(scope="session")
def exact():
    return exact_discrete


def chain_lag():
    """.lag text of a ten-coordinate chain with trigonometric couplings, never seen before (a fresh
    comment): its compile (pardel-gen, render, C++ compiler) takes about a second, long enough to
    watch other threads and Ctrl-C meanwhile."""
    names = ["x%d" % i for i in range(10)]
    coupling = " + ".join("cos(%s - %s)*sin(%s*%s)" % (names[i], names[i + 1], names[i], names[(i + 3) % 10])
                          for i in range(9))
    return ("# fresh %s\nmodel python_chain\norder 1\ncoords %s\nparam k = 1.5\n"
            "L = 1/2*(%s) - k*(%s)\ndiscretizations trapezoid midpoint\n"
            % (uuid.uuid4().hex, " ".join(names), " + ".join(n + "'^2" for n in names), coupling))


@pytest.fixture
def fresh_chain_lag():
    return chain_lag
