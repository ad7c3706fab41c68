"""pardel.model_from_sympy: a Lagrangian written with SymPy printed as .lag text (the language of
codegen/README.md, "The .lag language"), which the model loader then compiles as any other .lag
text. Only what .lag can say is printed; anything else is refused, naming the argument and the
offending part, before the generator runs."""
import math
import numbers
import re
from collections.abc import Mapping, Sequence

import sympy
from mpmath.libmp import prec_to_dps, to_str
from sympy.core.function import AppliedUndef
from sympy.printing.precedence import precedence
from sympy.printing.str import StrPrinter

# The functions of .lag expressions, by SymPy class (sqrt is a power in SymPy: x**(1/2)).
_FUNCTIONS = {sympy.sin: "sin", sympy.cos: "cos", sympy.tan: "tan", sympy.exp: "exp", sympy.log: "log",
              sympy.sinh: "sinh", sympy.cosh: "cosh", sympy.tanh: "tanh", sympy.asin: "asin",
              sympy.acos: "acos", sympy.atan: "atan", sympy.atan2: "atan2"}
_LAG_FUNCTIONS = "sin cos tan exp log sqrt sinh cosh tanh asin acos atan atan2 pow".split()
# Names .lag reserves: the time, pi and the function names (codegen/README.md).
_RESERVED = {"t", "pi"} | set(_LAG_FUNCTIONS)
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_MODEL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_MAX_ORDER = 9  # the .lag language's largest order


class _Refused(Exception):
    """Something of an expression that .lag cannot write; the message says what."""


class _LagPrinter(StrPrinter):
    """SymPy's str printer with .lag's spelling: '^' for powers, primes for time derivatives of the
    coordinates, the time as t, E as exp(1), a double-precision Float as the shortest decimal that
    reads back the same double (Float(0.1) as 0.1, which .lag reads as exactly 1/10, as a .lag file
    that says 0.1). .lag's operators bind as Python's do (codegen/README.md: '^' binds tighter than
    unary minus and is right-associative), so the parenthesization of the str printer holds."""

    def __init__(self, coords, time_name, params):
        super().__init__({"full_prec": True})
        self.coords = coords          # name -> position
        self.time_name = time_name
        self.params = params          # names

    def emptyPrinter(self, expr):
        raise _Refused("%s (%s) has no .lag form" % (expr, type(expr).__name__))

    def _print_Symbol(self, expr):
        if expr.name == self.time_name:
            return "t"
        if expr.name in self.params:
            return expr.name
        raise _Refused("the symbol %s is neither the time %s nor a param "
                       "(give it a default in params, or substitute a value)" % (expr.name, self.time_name))

    _print_Dummy = _print_Symbol

    def _print_Function(self, expr):
        if isinstance(expr, AppliedUndef):
            name = expr.func.__name__
            if name not in self.coords:
                raise _Refused("%s is a function that is not among the coordinates (%s)" % (
                    expr, ", ".join(self.coords)))
            if len(expr.args) != 1 or not (expr.args[0].is_Symbol and expr.args[0].name == self.time_name):
                raise _Refused("%s: a coordinate must be applied to the time %s alone, as %s(%s)" % (
                    expr, self.time_name, name, self.time_name))
            return name
        lag_name = _FUNCTIONS.get(expr.func)
        if lag_name is None or (expr.func is sympy.log and len(expr.args) != 1):
            raise _Refused("the function %s is not one of .lag's (%s); rewrite it with those (e.g. "
                           "expr.rewrite(sympy.cos))" % (expr.func.__name__, " ".join(_LAG_FUNCTIONS)))
        return "%s(%s)" % (lag_name, ", ".join(self._print(a) for a in expr.args))

    def _print_Derivative(self, expr):
        base = expr.expr
        variables = expr.variable_count
        if not (isinstance(base, AppliedUndef) and base.func.__name__ in self.coords):
            raise _Refused("%s: only the coordinates' time derivatives can be written (call .doit() "
                           "to differentiate other expressions)" % (expr,))
        if len(variables) != 1 or not (variables[0][0].is_Symbol and variables[0][0].name == self.time_name):
            raise _Refused("%s: a derivative with respect to something other than the time %s" % (
                expr, self.time_name))
        self._print_Function(base)  # checks the argument
        return base.func.__name__ + "'" * int(variables[0][1])

    def _print_Pow(self, expr, rational=False):
        prec = precedence(expr)
        if expr.exp is sympy.S.Half:
            return "sqrt(%s)" % self._print(expr.base)
        if expr.is_commutative and -expr.exp is sympy.S.Half:
            return "1/sqrt(%s)" % self._print(expr.base)
        if expr.is_commutative and expr.exp is sympy.S.NegativeOne:
            return "1/%s" % self.parenthesize(expr.base, prec, strict=False)
        return "%s^%s" % (self.parenthesize(expr.base, prec, strict=False),
                          self.parenthesize(expr.exp, prec, strict=False))

    def _print_Float(self, expr):
        if not expr.is_finite:
            raise _Refused("the number %s is not finite" % expr)
        if expr._prec <= 53:
            text = repr(float(expr))  # the shortest decimal that reads back as this double
        else:
            text = to_str(expr._mpf_, prec_to_dps(expr._prec))  # its decimal digits, as str() shows them
        return text

    def _print_Exp1(self, expr):
        return "exp(1)"

    def _print_Pi(self, expr):
        return "pi"

    def _print_Integer(self, expr):
        return str(expr.p)

    def _print_Rational(self, expr):
        return "%d/%d" % (expr.p, expr.q) if expr.q != 1 else str(expr.p)


def _check(printer, expr):
    """Raises _Refused for the first part of `expr` that .lag cannot write. Only sums, products,
    powers, finite real numbers, pi, E, the time, params, coordinates, their time derivatives and
    .lag's functions pass: the str printer would write many other things in Python's spelling."""
    if isinstance(expr, (sympy.Derivative, AppliedUndef)):
        printer._print(expr)  # checks the coordinate, its argument and the variable
        return
    if isinstance(expr, sympy.Symbol):
        printer._print_Symbol(expr)
        return
    if isinstance(expr, sympy.Number):
        if not (expr.is_real and expr.is_finite):
            raise _Refused("the number %s is not a finite real number" % (expr,))
        return
    if expr is sympy.S.Pi or expr is sympy.S.Exp1:
        return
    if isinstance(expr, sympy.NumberSymbol):
        raise _Refused("the constant %s has no .lag form (only pi and E do; evaluate it with .evalf() or "
                       "rewrite it)" % (expr,))
    if expr is sympy.S.ImaginaryUnit or expr is sympy.S.ComplexInfinity:
        raise _Refused("the number %s is not a finite real number" % (expr,))
    if isinstance(expr, sympy.Function):
        if expr.func not in _FUNCTIONS or (expr.func is sympy.log and len(expr.args) != 1):
            raise _Refused("the function %s is not one of .lag's (%s); rewrite it with those (e.g. "
                           "expr.rewrite(sympy.cos))" % (expr.func.__name__, " ".join(_LAG_FUNCTIONS)))
    elif not isinstance(expr, (sympy.Add, sympy.Mul, sympy.Pow)):
        raise _Refused("%s (%s) has no .lag form" % (_shown(expr), type(expr).__name__))
    for arg in expr.args:
        _check(printer, arg)


def _derivative_orders(expr, time_name):
    """The largest time-derivative order of a coordinate in expr (0: none)."""
    highest = 0
    for node in sympy.preorder_traversal(expr):
        if isinstance(node, sympy.Derivative):
            counts = node.variable_count
            if len(counts) == 1 and counts[0][0].is_Symbol and counts[0][0].name == time_name:
                highest = max(highest, int(counts[0][1]))
    return highest


def _shown(value):
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def lag_text(where, L, coords, params, order, name, discretizations, clock, cost, allow_singular):
    """The .lag text of the model; raises TypeError / ValueError (PardelError) naming the argument."""
    from . import PardelError  # the package's ValueError

    # L and clock: SymPy expressions (numbers too).
    def expression(arg, value):
        if isinstance(value, bool) or not isinstance(value, (sympy.Basic, numbers.Real)):
            raise TypeError("%s: %s must be a SymPy expression, got %s %s" % (
                where, arg, type(value).__name__, _shown(value)))
        value = sympy.sympify(value)
        if not isinstance(value, sympy.Expr):
            raise TypeError("%s: %s must be a SymPy expression (sympy.Expr), got %s %s" % (
                where, arg, type(value).__name__, _shown(value)))
        return value

    L = expression("L", L)

    # coords: functions of one time symbol, x(t), as sympy.Function("x")(t) or dynamicsymbols make.
    if isinstance(coords, AppliedUndef):
        coords = [coords]
    if isinstance(coords, (str, bytes, sympy.Basic)) or not isinstance(coords, Sequence):
        raise TypeError("%s: coords must be a list of coordinates, functions of the time such as "
                        "sympy.Function('x')(t), got %s %s" % (where, type(coords).__name__, _shown(coords)))
    if not coords:
        raise PardelError("%s: coords is empty; a model needs at least one coordinate" % where)
    time = None
    names = []
    for i, c in enumerate(coords):
        if not isinstance(c, AppliedUndef) or len(c.args) != 1 or not c.args[0].is_Symbol:
            raise TypeError("%s: coords[%d] must be a function of the time symbol, such as "
                            "sympy.Function('x')(t), got %s %s" % (where, i, type(c).__name__, _shown(c)))
        if time is None:
            time = c.args[0]
        elif c.args[0].name != time.name:
            raise PardelError("%s: coords[%d] is a function of %s, coords[0] of %s; every coordinate must be a "
                              "function of the same time symbol" % (where, i, c.args[0], time))
        cname = c.func.__name__
        if not _IDENTIFIER.match(cname) or len(cname) > 64:
            raise PardelError("%s: coords[%d]: the name %r is not an identifier of at most 64 letters, digits "
                              "and '_' (not starting with a digit)" % (where, i, cname))
        if cname in _RESERVED:
            raise PardelError("%s: coords[%d]: the name %r is reserved in .lag (t, pi and the function names)"
                              % (where, i, cname))
        if cname in names:
            raise PardelError("%s: coords[%d]: the coordinate %r is given twice" % (where, i, cname))
        names.append(cname)

    # params: {Symbol or name: default}; the default a real number or a constant SymPy expression.
    if params is None:
        params = {}
    if not isinstance(params, Mapping):
        raise TypeError("%s: params must be a dict {symbol or name: default}, got %s %s" % (
            where, type(params).__name__, _shown(params)))
    param_values = {}
    for key, default in params.items():
        if isinstance(key, sympy.Symbol):
            pname = key.name
        elif isinstance(key, str):
            pname = key
        else:
            raise TypeError("%s: params: the keys must be SymPy symbols or names (str), got %s %s" % (
                where, type(key).__name__, _shown(key)))
        item = "params[%r]" % pname
        if not _IDENTIFIER.match(pname) or len(pname) > 64:
            raise PardelError("%s: %s: the name is not an identifier of at most 64 letters, digits and '_' "
                              "(not starting with a digit)" % (where, item))
        if pname in _RESERVED or pname == time.name:
            raise PardelError("%s: %s: the name is reserved (the time %s, pi and the function names)" % (
                where, item, time.name if time.name == "t" else time.name + ", t"))
        if pname in names:
            raise PardelError("%s: %s: the name is also a coordinate's" % (where, item))
        if pname in param_values:
            raise PardelError("%s: %s is given twice" % (where, item))
        if isinstance(default, bool) or not isinstance(default, (numbers.Real, sympy.Basic)):
            raise TypeError("%s: %s must be a real number or a constant SymPy expression, got %s %s" % (
                where, item, type(default).__name__, _shown(default)))
        if isinstance(default, numbers.Real) and not isinstance(default, sympy.Basic):
            if not math.isfinite(float(default)):
                raise PardelError("%s: %s must be finite, got %s" % (where, item, _shown(default)))
            integral = isinstance(default, numbers.Integral)
            default = sympy.Integer(int(default)) if integral else sympy.Float(float(default))
        if not isinstance(default, sympy.Expr) or default.free_symbols or default.has(AppliedUndef):
            raise PardelError("%s: %s must be a constant (a number, pi, ...), got %s" % (where, item, _shown(default)))
        value = complex(sympy.N(default, 20))
        if value.imag != 0 or not math.isfinite(value.real):
            raise PardelError("%s: %s must be a finite real number, got %s" % (where, item, _shown(default)))
        param_values[pname] = default

    printer = _LagPrinter({n: i for i, n in enumerate(names)}, time.name, set(param_values))

    def printed(arg, expr):
        try:
            _check(printer, expr)
            return printer.doprint(expr)
        except _Refused as refused:
            raise PardelError("%s: %s cannot be written as .lag: %s" % (where, arg, refused)) from None

    # order: the highest derivative in L and clock unless given.
    clock = None if clock is None else expression("clock", clock)
    found = max(_derivative_orders(L, time.name), 0 if clock is None else _derivative_orders(clock, time.name))
    if order is None:
        order = max(found, 1)
    else:
        if isinstance(order, bool) or not isinstance(order, numbers.Integral):
            raise TypeError("%s: order must be an int, got %s %s" % (where, type(order).__name__, _shown(order)))
        order = int(order)
        if not 1 <= order <= _MAX_ORDER:
            raise PardelError("%s: order must be an int between 1 and %d, got %d" % (where, _MAX_ORDER, order))
        if found > order:
            raise PardelError("%s: order is %d, but L%s has a time derivative of order %d" % (
                where, order, "" if clock is None else " or clock", found))

    if not isinstance(name, str):
        raise TypeError("%s: name must be a str, got %s %s" % (where, type(name).__name__, _shown(name)))
    if not _MODEL_NAME.match(name) or len(name) > 48:
        raise PardelError("%s: name must be a letter then letters, digits and '_' (at most 48), got %r" % (where, name))

    if discretizations is not None:
        if isinstance(discretizations, str):
            discretizations = discretizations.split()
        if isinstance(discretizations, bytes) or not isinstance(discretizations, Sequence) or not discretizations:
            raise TypeError("%s: discretizations must be a non-empty list of names such as 'midpoint' or "
                            "'galerkin_gauss(s=4)', got %s" % (where, _shown(discretizations)))
        for i, d in enumerate(discretizations):
            if not isinstance(d, str):
                raise TypeError("%s: discretizations[%d] must be a str, got %s %s" % (
                    where, i, type(d).__name__, _shown(d)))
            if not re.match(r"[A-Za-z0-9_]+(\([^()\s#]*\))?\Z", d.replace(" ", "")):
                raise PardelError("%s: discretizations[%d]: %r is not a discretization's name such as "
                                  "'midpoint' or 'galerkin_gauss(s=4)'" % (where, i, d))

    if cost is not None:
        if not (isinstance(cost, (list, tuple)) and len(cost) == 2 and all(isinstance(c, str) for c in cost)):
            raise TypeError("%s: cost must be a pair (name, 'action' or 'clock'), got %s" % (where, _shown(cost)))
        if not _IDENTIFIER.match(cost[0]):
            raise PardelError("%s: cost: the name %r is not an identifier" % (where, cost[0]))
        if cost[1] not in ("action", "clock"):
            raise PardelError("%s: cost: the kind must be 'action' or 'clock', got %r" % (where, cost[1]))
        if cost[1] == "clock" and clock is None:
            raise PardelError("%s: cost ('%s', 'clock') needs a clock" % (where, cost[0]))
    if not isinstance(allow_singular, bool):
        raise TypeError("%s: allow_singular must be True or False, got %s" % (where, _shown(allow_singular)))

    lines = ["# written by pardel.model_from_sympy"]
    if allow_singular:
        lines.append("# pardel: allow-singular")
    lines += ["model " + name, "order %d" % order, "coords " + " ".join(names)]
    for pname, default in param_values.items():
        lines.append("param %s = %s" % (pname, printed("%s[%r]" % ("params", pname), default)))
    lines.append("L = " + printed("L", L))
    if clock is not None:
        lines.append("clock = " + printed("clock", clock))
    if cost is not None:
        lines.append("cost %s = %s" % tuple(cost))
    if discretizations is not None:
        lines.append("discretizations " + " ".join(d.replace(" ", "") for d in discretizations))
    return "\n".join(lines) + "\n"
