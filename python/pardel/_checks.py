"""The argument checks of pardel's public functions: every public function checks its arguments
here before anything reaches the scene or the compiled core, with Python's exceptions (TypeError
for a wrong type, a ValueError, PardelError, for a bad value) and messages that name the argument
as the caller wrote it: "pardel.solve: N must be an int between 2 and 100000000, got 1e+30"."""
import numbers
import os

import numpy as np

from . import _pardel
from ._pardel import PardelError

_INT_MAX = 2**31 - 1   # int members of pardel::Options (and Problem::N)
_LONG_MAX = 2**63 - 1  # long members (max_iterations, history_every)
# The scene reader's bound of grid.N (app/src/scene_sections.cpp; test_argument_types.py checks
# that the two agree).
_MAX_N = 100000000
# The integer options of pardel::Options and the largest value their C++ type holds; the ranges
# themselves are the runtime's (pardel::option_bound, _pardel.option_bounds).
_INT_OPTIONS = {"max_iterations": _LONG_MAX, "newton_substeps": _INT_MAX, "threads": _INT_MAX,
                "refine_start_N": _INT_MAX, "clock_update_every": _INT_MAX, "history_every": _LONG_MAX,
                "accuracy_max_N": _INT_MAX}
_NUMBER_OPTIONS = ("tol", "rtol", "damping", "refine_factor", "refine_settle", "divergence_factor", "accuracy")
_STRING_OPTIONS = ("discretization", "clock", "method", "linear_solver", "newton_shift", "device",
                   "iterative_refinement")
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


def _check_callback(where, name, value):
    if value is not None and not callable(value):
        raise TypeError("%s: %s must be callable or None, got %s" % (where, name, _kind(value)))


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


def _checked_options(where, options):
    """Keyword options of pardel.solve checked (types, NaN, the runtime's option bounds) as plain
    values; None values kept as None (the core checks every name, then leaves them out), unknown
    names left to the core."""
    arguments = {}
    for name, value in options.items():
        if value is None:
            arguments[name] = None
            continue
        if name in _STRING_OPTIONS:
            value = _check_string(where, name, value)
        elif name in _BOOL_OPTIONS:
            value = _check_bool(where, name, value)
        elif name in _INT_OPTIONS or name in _NUMBER_OPTIONS:
            value = _check_option(where, name, value)
            if name == "accuracy" and value == 0:
                continue  # pardel::Options::accuracy's 0: a fixed grid, the scene without grid.accuracy
        elif name == "t0":
            value = _check_number(where, name, value)
        elif name == "params":
            value = _check_params(where, name, value)
        elif name == "polyline":
            value = _check_array(where, name, value, 2, "a sequence of points (sequences of numbers)").tolist()
            if len(value) < 2:
                raise PardelError("%s: polyline must have at least 2 points, its first and last standing for q0 "
                                  "and qN (replaced by them), got %d" % (where, len(value)))
        elif name == "knots":
            value = _check_knots(where, name, value)
        arguments[name] = value
    return arguments


def _core_call(where, call, *args, keep=()):
    """call(*args) into the compiled core, whose refusals of an argument (the guess's shape, a
    params list's length) do not know which function was called: such a PardelError is raised again,
    of the same class, with `where` in front, as the package's own checks write it. Errors of the
    classes in `keep` (whose messages are the command line's, naming a file) pass unchanged."""
    try:
        return call(*args)
    except PardelError as error:
        message = str(error)
        if message.startswith("pardel") or isinstance(error, keep):
            raise
        raise type(error)("%s: %s" % (where, message)) from None
