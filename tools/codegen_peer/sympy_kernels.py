#!/usr/bin/python3
"""An independent SymPy evaluation of a .lag model's discrete Lagrangian and its derivatives.

It reads a .lag v1 file with its own small parser (the expression text, with primes renamed,
goes to sympy's parse_expr), builds the discrete Lagrangian of one discretization from its
definition (docs/discretizations.md), differentiates it with SymPy and evaluates
Ld, D1, D2, D11, D12, D22 in 40-digit arithmetic (mpmath). The output is JSON in the shape of
`pardel kernels`, so the two can be compared (check_kernels.py).

Usage:
  /usr/bin/python3 sympy_kernels.py --model NAME_OR_PATH.lag --disc DISC --h H --t0 T0 --t1 T1 \
      --q0 a,b,... --q1 a,b,... [--param name=value ...]
A bare model name is looked up as lagrangians/NAME.lag in the project.
"""

import argparse
import json
import os
import re
import sys

import mpmath
import sympy
from sympy.integrals.quadrature import gauss_legendre

PROJECT_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

FUNCTIONS = {
    "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "exp": sympy.exp, "log": sympy.log,
    "sqrt": sympy.sqrt, "sinh": sympy.sinh, "cosh": sympy.cosh, "tanh": sympy.tanh,
    "asin": sympy.asin, "acos": sympy.acos, "atan": sympy.atan, "atan2": sympy.atan2,
    "pow": sympy.Pow,
}
FUNCTION_ARITY = {name: (2 if name in ("atan2", "pow") else 1) for name in FUNCTIONS}
KEYWORDS = ("model", "order", "coords", "param", "let", "L", "clock", "cost", "discretizations")
DECIMALS = 40  # digits of the reference arithmetic


class LagError(Exception):
    """A user error in a .lag file or on the command line; the message names file:line:col."""


class LagModel:
    """What a .lag file declares, with L and the clock as SymPy expressions in continuous symbols."""

    def __init__(self):
        self.path = ""
        self.name = None
        self.order = 1
        self.coords = []
        self.params = []          # [(name, default as sympy number)]
        self.param_symbols = []   # Symbol("p[j]") per param, the names used by generated C code
        self.time = sympy.Dummy("t")
        self.jets = []            # jets[i][k]: the k-th derivative of coordinate i
        self.lets = []            # [(Dummy, expression in earlier lets' Dummies and the symbols above)]
        self.lagrangian = None    # L in terms of the let Dummies
        self.clock = None
        self.discretizations = []
        self.cost = None          # (name, "action" | "clock"): what the reported cost is

    def expand(self, expr):
        """expr with every let replaced by its definition (lets are substituted last to first)."""
        for sym, definition in reversed(self.lets):
            expr = expr.xreplace({sym: definition})
        return expr


_NUMBER = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_OPERATORS = set("+-*/^(),")


def _parse_expression(text, where, names, model):
    """Parses one expression; `names` maps identifiers to SymPy objects; `where` = (path, line, col)."""
    path, line, col0 = where
    out = []
    local = {}
    pos = 0
    n = len(text)
    while pos < n:
        ch = text[pos]
        col = col0 + pos
        if ch.isspace():
            out.append(ch)
            pos += 1
            continue
        m = _NUMBER.match(text, pos)
        if m and (ch.isdigit() or ch == "."):
            key = "N%d" % len(local)
            local[key] = sympy.Rational(m.group(0))
            out.append(key)
            pos = m.end()
            continue
        m = _IDENT.match(text, pos)
        if m:
            ident = m.group(0)
            end = m.end()
            primes = 0
            while end < n and text[end] == "'":
                primes += 1
                end += 1
            rest = text[end:].lstrip()
            if ident in FUNCTIONS and primes == 0 and rest.startswith("("):
                key = "F_" + ident
                local[key] = FUNCTIONS[ident]
            elif ident == "pi" and primes == 0 and "pi" not in names:
                key = "C_pi"
                local[key] = sympy.pi
            elif primes > 0:
                if ident not in model.coords:
                    raise LagError("%s:%d:%d: error: only coordinates take primes, '%s' is not a coordinate"
                                   % (path, line, col, ident))
                if primes > model.order:
                    raise LagError("%s:%d:%d: error: '%s%s' exceeds the model's order %d"
                                   % (path, line, col, ident, "'" * primes, model.order))
                key = "V%d_%s" % (primes, ident)
                local[key] = model.jets[model.coords.index(ident)][primes]
            elif ident in names:
                key = "V0_" + ident
                local[key] = names[ident]
            elif ident in FUNCTIONS:
                raise LagError("%s:%d:%d: error: function '%s' needs its arguments in parentheses"
                               % (path, line, col, ident))
            else:
                raise LagError("%s:%d:%d: error: unknown name '%s'" % (path, line, col, ident))
            out.append(key)
            pos = end
            continue
        if ch in _OPERATORS:
            out.append("**" if ch == "^" else ch)
            pos += 1
            continue
        raise LagError("%s:%d:%d: error: unexpected character '%s'" % (path, line, col, ch))
    source = "".join(out)
    if not source.strip():
        raise LagError("%s:%d:%d: error: empty expression" % (path, line, col0))
    try:
        expr = sympy.parse_expr(source, local_dict=local, global_dict={"Integer": sympy.Integer},
                                transformations=(), evaluate=True)
    except Exception as exc:  # SyntaxError, TypeError from a wrong call, ...
        raise LagError("%s:%d:%d: error: cannot parse expression '%s' (%s)"
                       % (path, line, col0, text.strip(), exc.__class__.__name__)) from None
    if not isinstance(expr, sympy.Expr):
        raise LagError("%s:%d:%d: error: '%s' is not a scalar expression" % (path, line, col0, text.strip()))
    return expr


def parse_lag(path):
    """Reads a .lag v1 file into a LagModel; raises LagError with file:line:col on bad input."""
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().split("\n")
    except OSError as exc:
        raise LagError("%s: error: cannot read (%s)" % (path, exc.strerror)) from None
    model = LagModel()
    model.path = path
    names = {}
    seen_coords = False
    for lineno, raw in enumerate(lines, start=1):
        text = raw.split("#", 1)[0].rstrip()
        stripped = text.lstrip()
        if not stripped:
            continue
        indent = len(text) - len(stripped)
        m = _IDENT.match(stripped)
        word = m.group(0) if m else ""
        after = stripped[len(word):]
        col_after = indent + len(word) + 1
        if word == "model":
            ident = after.strip()
            if not _IDENT.fullmatch(ident):
                raise LagError("%s:%d:%d: error: model needs a C identifier" % (path, lineno, col_after + 1))
            model.name = ident
        elif word == "order":
            value = after.strip()
            if not value.isdigit() or int(value) < 1:
                raise LagError("%s:%d:%d: error: order must be an integer >= 1" % (path, lineno, col_after + 1))
            if seen_coords:
                raise LagError("%s:%d:1: error: order must come before coords" % (path, lineno))
            model.order = int(value)
        elif word == "coords":
            if seen_coords:
                raise LagError("%s:%d:1: error: coords declared twice" % (path, lineno))
            coords = after.split()
            if not coords:
                raise LagError("%s:%d:%d: error: coords needs at least one name" % (path, lineno, col_after))
            for c in coords:
                if not _IDENT.fullmatch(c) or c in names or c in FUNCTIONS or c in ("t", "pi"):
                    raise LagError("%s:%d:%d: error: bad or repeated coordinate name '%s'"
                                   % (path, lineno, indent + text[indent:].find(c) + 1, c))
                names[c] = None
            seen_coords = True
            model.coords = coords
            model.jets = [[sympy.Dummy("%s_%d" % (c, k)) for k in range(model.order + 1)] for c in coords]
            for c, jet in zip(coords, model.jets):
                names[c] = jet[0]
            names["t"] = model.time
        elif word in ("param", "let", "L", "clock"):
            if not seen_coords:
                raise LagError("%s:%d:1: error: '%s' before coords" % (path, lineno, word))
            if word in ("param", "let"):
                m2 = re.match(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=", after)
                if not m2:
                    raise LagError("%s:%d:%d: error: expected '%s NAME = ...'" % (path, lineno, col_after, word))
                ident = m2.group(1)
                if ident in names or ident in FUNCTIONS or ident in ("t", "pi"):
                    raise LagError("%s:%d:%d: error: name '%s' already used"
                                   % (path, lineno, col_after + after.find(ident), ident))
                rhs = after[m2.end():]
                rhs_col = col_after + m2.end()
            else:
                m2 = re.match(r"\s*=", after)
                if not m2:
                    raise LagError("%s:%d:%d: error: expected '%s = ...'" % (path, lineno, col_after, word))
                rhs = after[m2.end():]
                rhs_col = col_after + m2.end()
            if word == "param":
                value = _parse_expression(rhs, (path, lineno, rhs_col), {}, model)
                if not value.is_number:
                    raise LagError("%s:%d:%d: error: a param's default must be a number" % (path, lineno, rhs_col))
                sym = sympy.Symbol("p[%d]" % len(model.params), real=True)
                model.params.append((ident, value))
                model.param_symbols.append(sym)
                names[ident] = sym
            elif word == "let":
                sym = sympy.Dummy(ident, real=True)
                model.lets.append((sym, _parse_expression(rhs, (path, lineno, rhs_col), names, model)))
                names[ident] = sym
            elif word == "L":
                if model.lagrangian is not None:
                    raise LagError("%s:%d:1: error: L defined twice" % (path, lineno))
                model.lagrangian = _parse_expression(rhs, (path, lineno, rhs_col), names, model)
            else:
                if model.clock is not None:
                    raise LagError("%s:%d:1: error: clock defined twice" % (path, lineno))
                model.clock = _parse_expression(rhs, (path, lineno, rhs_col), names, model)
        elif word == "cost":
            m = re.fullmatch(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(action|clock)\s*", after)
            if not m:
                raise LagError("%s:%d:%d: error: expected 'cost NAME = action' or 'cost NAME = clock'"
                               % (path, lineno, col_after))
            model.cost = (m.group(1), m.group(2))
        elif word == "discretizations":
            items = re.findall(r"[A-Za-z_][A-Za-z0-9_]*(?:\([^)]*\))?", after)
            if not items:
                raise LagError("%s:%d:%d: error: discretizations needs at least one name" % (path, lineno, col_after))
            model.discretizations.extend(items)
        else:
            raise LagError("%s:%d:%d: error: unknown statement '%s' (expected one of %s)"
                           % (path, lineno, indent + 1, stripped.split()[0], ", ".join(KEYWORDS)))
    if model.name is None:
        raise LagError("%s: error: missing 'model NAME'" % path)
    if not seen_coords:
        raise LagError("%s: error: missing 'coords'" % path)
    if model.lagrangian is None:
        raise LagError("%s: error: missing 'L = ...'" % path)
    return model


# ---------------------------------------------------------------------------------------------
# Discretizations (definitions in docs/discretizations.md)

def lobatto_nodes(points):
    """The Gauss-Lobatto nodes of [-1, 1] (both ends and the roots of P'_(points-1)), ascending, in
    the current mpmath precision."""
    k = points - 1
    inner = []
    for i in range(k - 1, 0, -1):
        x = mpmath.cos(mpmath.pi * i / k)
        x = mpmath.findroot(lambda y: mpmath.diff(lambda u: mpmath.legendre(k, u), y), x)
        inner.append(x)
    return [mpmath.mpf(-1)] + sorted(inner) + [mpmath.mpf(1)]


def _disc_name_and_options(disc):
    m = re.fullmatch(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\((.*)\))?\s*", disc)
    if not m:
        raise LagError("discretization '%s': bad name" % disc)
    options = {}
    if m.group(2):
        for item in m.group(2).split(","):
            key, _, value = item.partition("=")
            try:
                options[key.strip()] = sympy.Rational(value.strip())
            except (TypeError, ValueError):
                raise LagError("discretization '%s': bad option '%s'" % (disc, item.strip())) from None
    return m.group(1), options


class DiscreteLagrangian:
    """Ld(h, t0, t1, q0, q1, p) = h * sum_k w_k L(t_k, jet_k): a quadrature of L over one interval,
    with the jets (values and derivatives of the coordinates at the nodes) linear in q0 and q1.
    Symbols carry the names that generated C code uses: h, t0, t1, q0[i], q1[i], p[j]."""

    def __init__(self, model, disc):
        self.model = model
        self.disc = disc
        n = len(model.coords)
        self.dim = model.order * n
        self.h = sympy.Symbol("h", positive=True)
        self.t0 = sympy.Symbol("t0", real=True)
        self.t1 = sympy.Symbol("t1", real=True)
        self.q0 = [sympy.Symbol("q0[%d]" % i, real=True) for i in range(self.dim)]
        self.q1 = [sympy.Symbol("q1[%d]" % i, real=True) for i in range(self.dim)]
        self.p = list(model.param_symbols)
        self.z = []       # interior values (Galerkin discretizations with S above the order)
        self.z_start = []  # their starting values, linear in q0 and q1
        self.stages = self._stages(disc)

    def _stages(self, disc):
        """[(weight w_k, time t_k, jets[i][k])] of the discretization."""
        name, options = _disc_name_and_options(disc)
        n = len(self.model.coords)
        h, t0, t1, q0, q1 = self.h, self.t0, self.t1, self.q0, self.q1
        order = self.model.order
        half = sympy.Rational(1, 2)
        if order == 1 and not options and name in ("trapezoid", "midpoint"):
            v = [(q1[i] - q0[i]) / h for i in range(n)]
            if name == "trapezoid":
                return [(half, t0, [[q0[i], v[i]] for i in range(n)]),
                        (half, t1, [[q1[i], v[i]] for i in range(n)])]
            return [(1, (t0 + t1) * half, [[(q0[i] + q1[i]) * half, v[i]] for i in range(n)])]
        if order == 2 and name == "trapezoid" and set(options) <= {"alpha"}:
            alpha = options.get("alpha", sympy.Integer(1))
            x0, v0 = q0[:n], q0[n:]
            x1, v1 = q1[:n], q1[n:]
            a0 = [(((1 - 3 * alpha) * v1[i] - (1 + 3 * alpha) * v0[i]) * h + 6 * alpha * (x1[i] - x0[i])) / h**2
                  for i in range(n)]
            a1 = [(((1 + 3 * alpha) * v1[i] - (1 - 3 * alpha) * v0[i]) * h - 6 * alpha * (x1[i] - x0[i])) / h**2
                  for i in range(n)]
            return [(half, t0, [[x0[i], v0[i], a0[i]] for i in range(n)]),
                    (half, t1, [[x1[i], v1[i], a1[i]] for i in range(n)])]
        if order == 2 and name == "gauss2" and not options:
            x0, v0 = q0[:n], q0[n:]
            x1, v1 = q1[:n], q1[n:]
            stages = []
            for tau in (half - sympy.sqrt(3) / 6, half + sympy.sqrt(3) / 6):
                # Cubic Hermite basis on [0, 1] and its first two derivatives in tau.
                b = [2 * tau**3 - 3 * tau**2 + 1, tau**3 - 2 * tau**2 + tau, -2 * tau**3 + 3 * tau**2, tau**3 - tau**2]
                db = [6 * tau**2 - 6 * tau, 3 * tau**2 - 4 * tau + 1, -6 * tau**2 + 6 * tau, 3 * tau**2 - 2 * tau]
                ddb = [12 * tau - 6, 6 * tau - 4, -12 * tau + 6, 6 * tau - 2]
                b, db, ddb = ([sympy.expand(c) for c in basis] for basis in (b, db, ddb))
                jets = []
                for i in range(n):
                    pos = b[0] * x0[i] + b[1] * h * v0[i] + b[2] * x1[i] + b[3] * h * v1[i]
                    vel = (db[0] * x0[i] + db[1] * h * v0[i] + db[2] * x1[i] + db[3] * h * v1[i]) / h
                    acc = (ddb[0] * x0[i] + ddb[1] * h * v0[i] + ddb[2] * x1[i] + ddb[3] * h * v1[i]) / h**2
                    jets.append([pos, vel, acc])
                stages.append((half, t0 + tau * (t1 - t0), jets))
            return stages
        if name == "hermite_gauss" and set(options) <= {"s"}:
            # The Hermite interpolant of degree 2*order - 1 of both nodes' jets, its basis found
            # by solving the end conditions; s-point Gauss-Legendre nodes from SymPy (numbers of
            # 2*DECIMALS digits mapped from [-1, 1] to [0, 1]).
            s = int(options.get("s", order))
            tau = sympy.Symbol("tau")
            coeffs = sympy.symbols("c0:%d" % (2 * order))
            poly = sum(c * tau**k for k, c in enumerate(coeffs))
            basis = []  # basis[end][k]: k-th derivative 1 at end (0: tau = 0, 1: tau = 1)
            for end in (0, 1):
                row = []
                for k in range(order):
                    eqs = [sympy.diff(poly, tau, j).subs(tau, e) - (1 if (e == end and j == k) else 0)
                           for e in (0, 1) for j in range(order)]
                    row.append(sympy.expand(poly.subs(sympy.solve(eqs, coeffs))))
                basis.append(row)
            xs, ws = gauss_legendre(s, 2 * DECIMALS)
            stages = []
            for x, w in zip(xs, ws):
                c = (1 + x) / 2
                jets = []
                for i in range(n):
                    jet = []
                    for j in range(order + 1):
                        value = 0
                        for k in range(order):
                            value += h**(k - j) * (sympy.diff(basis[0][k], tau, j).subs(tau, c) * q0[k * n + i] +
                                                   sympy.diff(basis[1][k], tau, j).subs(tau, c) * q1[k * n + i])
                        jet.append(value)
                    jets.append(jet)
                stages.append((w / 2, t0 + c * (t1 - t0), jets))
            return stages
        if name in ("galerkin_gauss", "galerkin_lobatto") and set(options) == {"s"} and int(options["s"]) >= order:
            return self._galerkin_stages(name, int(options["s"]))
        raise LagError("discretization '%s' is not defined for an order-%d model" % (disc, order))

    def _galerkin_stages(self, name, s):
        """The Galerkin family: the polynomial of degree s + order - 1 through both nodes' jets and
        s - order values per coordinate (the symbols z[j*n + i]) at the inner nodes of the Gauss-Lobatto
        rule with s - order + 2 points, under s Gauss or s + 1 Gauss-Lobatto points. The basis is found
        in mpmath (2*DECIMALS digits) by inverting the matrix of the end and interior conditions."""
        n = len(self.model.coords)
        order = self.model.order
        h, t0, t1, q0, q1 = self.h, self.t0, self.t1, self.q0, self.q1
        m_in = s - order
        degree = s + order - 1
        with mpmath.workdps(2 * DECIMALS):
            fractions = [(1 + x) / 2 for x in lobatto_nodes(m_in + 2)[1:-1]]

            def row(k, at):  # the k-th derivative at `at` of each monomial
                return [mpmath.mpf(0) if e < k else mpmath.factorial(e) / mpmath.factorial(e - k) * mpmath.mpf(at) ** (e - k)
                        for e in range(degree + 1)]
            rows = [row(k, 0) for k in range(order)] + [row(k, 1) for k in range(order)] + [row(0, c) for c in fractions]
            inverse = mpmath.inverse(mpmath.matrix(rows))
            basis = [[inverse[e, col] for e in range(degree + 1)] for col in range(degree + 1)]

            def derivative(coeffs, j, at):
                return sum((mpmath.factorial(e) / mpmath.factorial(e - j) * coeffs[e] * mpmath.mpf(at) ** (e - j)
                            for e in range(j, degree + 1)), mpmath.mpf(0))
            if name == "galerkin_gauss":
                xs, ws = gauss_legendre(s, 2 * DECIMALS)
                nodes = [(1 + mpmath.mpf(str(x))) / 2 for x in xs]
                weights = [mpmath.mpf(str(w)) / 2 for w in ws]
            else:
                xs = lobatto_nodes(s + 1)
                k = s
                nodes = [(1 + x) / 2 for x in xs]
                weights = [1 / (mpmath.mpf(k * (k + 1)) * mpmath.legendre(k, x) ** 2) for x in xs]
            self.z = [sympy.Symbol("z[%d]" % (j * n + i), real=True) for j in range(m_in) for i in range(n)]
            F = lambda v: sympy.Float(mpmath.nstr(v, 2 * DECIMALS), 2 * DECIMALS)
            stages = []
            for c, w in zip(nodes, weights):
                jets = []
                for i in range(n):
                    jet = []
                    for j in range(order + 1):
                        value = 0
                        for k in range(order):
                            value += h**(k - j) * (F(derivative(basis[k], j, c)) * q0[k * n + i] +
                                                   F(derivative(basis[order + k], j, c)) * q1[k * n + i])
                        for jj in range(m_in):
                            value += h**(-j) * F(derivative(basis[2 * order + jj], j, c)) * self.z[jj * n + i]
                        jet.append(value)
                    jets.append(jet)
                stages.append((F(w), t0 + F(c) * (t1 - t0), jets))
            # Starting values: the Hermite interpolant of degree 2 order - 1 of the nodes' jets.
            hermite_rows = [row(k, 0)[:2 * order] for k in range(order)] + [row(k, 1)[:2 * order] for k in range(order)]
            hermite = mpmath.inverse(mpmath.matrix(hermite_rows))
            self.z_start = []
            for c in fractions:
                for i in range(n):
                    value = 0
                    for k in range(order):
                        a = sum((hermite[e, k] * mpmath.mpf(c) ** e for e in range(2 * order)), mpmath.mpf(0))
                        b = sum((hermite[e, order + k] * mpmath.mpf(c) ** e for e in range(2 * order)), mpmath.mpf(0))
                        value += h**k * (F(a) * q0[k * n + i] + F(b) * q1[k * n + i])
                    self.z_start.append(value)
            # z_start is ordered like z (fraction by fraction, coordinate by coordinate).
        return stages

    def _lagrangian_at(self, t, jets):
        repl = {self.model.time: t}
        for jet_symbols, values in zip(self.model.jets, jets):
            repl.update(zip(jet_symbols, values))
        return self.model.expand(self.model.lagrangian).xreplace(repl)

    def action(self):
        """Ld as one SymPy expression (lets expanded)."""
        return self.h * sum(w * self._lagrangian_at(t, jets) for w, t, jets in self.stages)

    def outputs(self):
        """[Ld, D1 (dim), D2 (dim), D11, D12, D22 (dim x dim each, row-major)] by sympy.diff of Ld."""
        if self.z:
            raise LagError("discretization '%s' has interior values: its Ld has no closed form to differentiate "
                           "(ReferenceKernels evaluates it)" % self.disc)
        ld = self.action()
        d1 = [sympy.diff(ld, s) for s in self.q0]
        d2 = [sympy.diff(ld, s) for s in self.q1]
        m = self.dim

        def hessian(grad, wrt, symmetric):
            out = [[None] * m for _ in range(m)]
            for i in range(m):
                for j in range(m):
                    out[i][j] = out[j][i] if symmetric and j < i else sympy.diff(grad[i], wrt[j])
            return [e for row in out for e in row]

        return [ld] + d1 + d2 + hessian(d1, self.q0, True) + hessian(d1, self.q1, False) + hessian(d2, self.q1, True)

    def arguments(self):
        return [self.h, self.t0, self.t1] + self.q0 + self.q1 + self.p


class _Node:
    """One assignment of the model's program (a let, or L) with its symbolic partial derivatives
    with respect to the jet variables z and the earlier lets it uses directly."""

    def __init__(self, expr, z, lets, inputs):
        zs = [s for s in z if expr.has(s)]
        ls = [s for s in lets if expr.has(s)]
        self.z_index = [z.index(s) for s in zs]
        self.let_index = [lets.index(s) for s in ls]
        var = zs + ls
        first = [sympy.diff(expr, v) for v in var]
        second = [[sympy.diff(d, v) for v in var] for d in first]
        flat = [expr] + first + [e for row in second for e in row]
        self.nvar = len(var)
        self.nz = len(zs)
        self.fn = sympy.lambdify(inputs, flat, modules="mpmath")


class ReferenceKernels:
    """Evaluates Ld, D1, D2, D11, D12, D22 in DECIMALS-digit arithmetic.

    L's gradient and Hessian in the jet variables come from forward-mode differentiation of the
    model's program (each let and L differentiated by SymPy, combined by the chain rule); Ld's
    derivatives then follow exactly from the linearity of the jets in (q0, q1):
      grad Ld = h sum_k w_k A_k^T grad L(t_k, jet_k),  hess Ld = h sum_k w_k A_k^T hess L A_k,
    with A_k the (constant in q) Jacobian of jet_k. `DiscreteLagrangian.outputs()` (plain
    sympy.diff of the whole Ld) agrees with this and is used for the slower code-size peer."""

    def __init__(self, model, disc):
        self.model = model
        self.disc = disc
        self.lagrangian = DiscreteLagrangian(model, disc)
        self.dim = self.lagrangian.dim
        dl = self.lagrangian
        z = [s for jet in model.jets for s in jet]
        lets = [s for s, _ in model.lets]
        inputs = [model.time] + list(model.param_symbols) + z + lets
        self._z = z
        self._nodes = [_Node(e, z, lets, inputs) for _, e in model.lets]
        self._nodes.append(_Node(model.lagrangian, z, lets, inputs))
        qs = dl.q0 + dl.z + dl.q1
        self._z_start_fn = sympy.lambdify([dl.h] + dl.q0 + dl.q1, dl.z_start, modules="mpmath") if dl.z else None
        self._stage_fns = []
        for w, t, jets in dl.stages:
            flat_jet = [jets[i][k] for i in range(len(model.coords)) for k in range(model.order + 1)]
            jac = [[sympy.diff(e, s) for s in qs] for e in flat_jet]
            for row in jac:
                for e in row:
                    if any(e.has(s) for s in qs):
                        raise AssertionError("jet of '%s' is not linear in q0, q1" % disc)
            fn = sympy.lambdify([dl.h, dl.t0, dl.t1] + qs, [t, flat_jet, jac], modules="mpmath")
            self._stage_fns.append((w, fn))

    def default_params(self):
        return [float(v) for _, v in self.model.params]

    def _lagrangian_jet(self, t, params, zval):
        """Value, gradient and Hessian of L with respect to z at (t, z)."""
        nz = len(zval)
        letvals, grads, hessians = [], [], []
        for node in self._nodes:
            out = node.fn(t, *params, *zval, *letvals, *([0] * (len(self.model.lets) - len(letvals))))
            value, first = out[0], out[1:1 + node.nvar]
            second = out[1 + node.nvar:]
            nv = node.nvar
            # Total derivatives of each direct variable (jet variable or earlier let) by z.
            dvar = []
            for zi in node.z_index:
                dvar.append(([mpmath.mpf(1) if j == zi else mpmath.mpf(0) for j in range(nz)], None))
            for li in node.let_index:
                dvar.append((grads[li], hessians[li]))
            g = [mpmath.mpf(0)] * nz
            hmat = [[mpmath.mpf(0)] * nz for _ in range(nz)]
            for a in range(nv):
                ga, ha = dvar[a]
                for j in range(nz):
                    if ga[j]:
                        g[j] += first[a] * ga[j]
                if ha is not None:
                    for j in range(nz):
                        for k in range(nz):
                            hmat[j][k] += first[a] * ha[j][k]
                for b in range(nv):
                    fab = second[a * nv + b]
                    if fab == 0:
                        continue
                    gb = dvar[b][0]
                    for j in range(nz):
                        if ga[j]:
                            for k in range(nz):
                                hmat[j][k] += fab * ga[j] * gb[k]
            letvals.append(value)
            grads.append(g)
            hessians.append(hmat)
        return letvals[-1], grads[-1], hessians[-1]

    def _interval(self, hh, tt0, tt1, xv, pv):
        """The action over one interval, its gradient and Hessian in x = [q0, z, q1]."""
        nx = len(xv)
        ld = mpmath.mpf(0)
        grad = [mpmath.mpf(0)] * nx
        hess = [[mpmath.mpf(0)] * nx for _ in range(nx)]
        for w, fn in self._stage_fns:
            t, zval, jac = fn(hh, tt0, tt1, *xv)
            value, g, hz = self._lagrangian_jet(t, pv, zval)
            c = hh * w
            ld += c * value
            nz = len(zval)
            for a in range(nx):
                grad[a] += c * sum(jac[j][a] * g[j] for j in range(nz))
                ha = [sum(jac[j][a] * hz[j][k] for j in range(nz)) for k in range(nz)]
                for b in range(nx):
                    hess[a][b] += c * sum(ha[k] * jac[k][b] for k in range(nz))
        return ld, grad, hess

    def evaluate(self, h, t0, t1, q0, q1, params):
        """Returns the dict {Ld, D1, D2, D11, D12, D22} of floats; raises ValueError if not real.
        With interior values z (Galerkin), Ld = S(z*) where dS/dz = 0, found by Newton's method from
        the starting values, and the second derivatives are the Schur complements."""
        m = self.dim
        if len(q0) != m or len(q1) != m or len(params) != len(self.model.params):
            raise LagError("expected q0, q1 with %d values and %d params" % (m, len(self.model.params)))
        with mpmath.workdps(DECIMALS):
            mp = lambda xs: [mpmath.mpf(repr(float(x))) for x in xs]
            hh, tt0, tt1 = mp([h, t0, t1])
            q0v, q1v, pv = mp(q0), mp(q1), mp(params)
            try:
                zv = list(self._z_start_fn(hh, *q0v, *q1v)) if self._z_start_fn else []
                M = len(zv)
                for _ in range(60 if M else 0):
                    ld, g, H = self._interval(hh, tt0, tt1, q0v + zv + q1v, pv)
                    step = mpmath.lu_solve(mpmath.matrix([[H[m + i][m + j] for j in range(M)] for i in range(M)]),
                                           mpmath.matrix([g[m + i] for i in range(M)]))
                    zv = [zv[i] - step[i] for i in range(M)]
                    if max(abs(step[i]) for i in range(M)) < mpmath.mpf(10) ** (-DECIMALS + 8):
                        break
                ld, gx, hx = self._interval(hh, tt0, tt1, q0v + zv + q1v, pv)
                nodes = list(range(m)) + list(range(m + M, 2 * m + M))
                grad = [gx[a] for a in nodes]
                hess = [[hx[a][b] for b in nodes] for a in nodes]
                if M:
                    hzz = mpmath.matrix([[hx[m + i][m + j] for j in range(M)] for i in range(M)])
                    for col, b in enumerate(nodes):
                        x = mpmath.lu_solve(hzz, mpmath.matrix([hx[m + i][b] for i in range(M)]))
                        for r, a in enumerate(nodes):
                            hess[r][col] -= sum(hx[a][m + i] * x[i] for i in range(M))
            except (ZeroDivisionError, ValueError) as exc:
                raise ValueError("not defined at this point (%s)" % exc) from None
            flat = [ld] + grad + [x for row in hess for x in row]
            out = []
            for v in flat:
                v = mpmath.mpmathify(v)
                if isinstance(v, mpmath.mpc):
                    if abs(v.imag) > mpmath.mpf(10) ** (-DECIMALS + 5) * max(1, abs(v.real)):
                        raise ValueError("not real at this point")
                    v = v.real
                if not mpmath.isfinite(v):
                    raise ValueError("not finite at this point")
                out.append(float(v))
        ld, grad = out[0], out[1:1 + 2 * m]
        hess = [out[1 + 2 * m + a * 2 * m:1 + 2 * m + (a + 1) * 2 * m] for a in range(2 * m)]
        return {"Ld": ld, "D1": grad[:m], "D2": grad[m:],
                "D11": [row[:m] for row in hess[:m]], "D12": [row[m:] for row in hess[:m]],
                "D22": [row[m:] for row in hess[m:]]}


def resolve_model_path(name_or_path):
    if name_or_path.endswith(".lag") or "/" in name_or_path:
        return name_or_path
    return os.path.join(PROJECT_ROOT, "lagrangians", name_or_path + ".lag")


def param_values(model, settings):
    """Defaults overridden by 'name=value' strings; unknown names are user errors."""
    values = [float(v) for _, v in model.params]
    names = [n for n, _ in model.params]
    for item in settings:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or key not in names:
            raise LagError("--param '%s': model '%s' has params: %s" % (item, model.name, ", ".join(names) or "none"))
        try:
            values[names.index(key)] = float(value)
        except ValueError:
            raise LagError("--param '%s': '%s' is not a number" % (item, value)) from None
    return values


def _floats(option, text):
    try:
        return [float(x) for x in text.split(",")] if text.strip() else []
    except ValueError:
        raise LagError("%s '%s': expected comma-separated numbers" % (option, text)) from None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", required=True, help="bundled model name or path to a .lag file")
    parser.add_argument("--disc", required=True, help="discretization, e.g. trapezoid or 'trapezoid(alpha=1)'")
    parser.add_argument("--h", type=float, required=True)
    parser.add_argument("--t0", type=float, default=0.0)
    parser.add_argument("--t1", type=float, default=None, help="defaults to t0 + h")
    parser.add_argument("--q0", required=True)
    parser.add_argument("--q1", required=True)
    parser.add_argument("--param", action="append", default=[], help="name=value, repeatable")
    args = parser.parse_args(argv)
    try:
        model = parse_lag(resolve_model_path(args.model))
        kernels = ReferenceKernels(model, args.disc)
        t1 = args.t0 + args.h if args.t1 is None else args.t1
        result = kernels.evaluate(args.h, args.t0, t1, _floats("--q0", args.q0), _floats("--q1", args.q1),
                                  param_values(model, args.param))
    except LagError as exc:
        print(exc, file=sys.stderr)
        return 2
    except ValueError as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 1
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
