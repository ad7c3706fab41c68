"""Matplotlib pictures of a pardel.Result: the path in the plane of the first two coordinates, each
coordinate against t, and the convergence history. Each function draws into `ax` when given (else
a new figure from matplotlib.pyplot, which works under the Agg backend) and returns the axes.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Optional

import numpy as np

# Imported at run time (not for type checkers alone) so that typing.get_type_hints resolves the
# functions' `result: Result` from this module's globals.
from ._results import Result

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def _check_result(where, result):
    """A pardel.Result, else TypeError naming the argument (as the package's own checks)."""
    if not isinstance(result, Result):
        shown = "None" if result is None else "%s %.60r" % (type(result).__name__, result)
        raise TypeError("%s: result must be a pardel.Result, got %s" % (where, shown))


def _axes(where, ax):
    """ax when given (a matplotlib Axes, else TypeError naming it), else the axes of a new figure."""
    if ax is not None:
        from matplotlib.axes import Axes

        if not isinstance(ax, Axes):
            shown = "%s %.60r" % (type(ax).__name__, ax)
            raise TypeError("%s: ax must be a matplotlib Axes or None, got %s" % (where, shown))
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=(6, 5))
    return ax


def path(result: Result, ax: Optional[Axes] = None, label: Optional[str] = None) -> Axes:
    """The path (first coordinate against the second) with its end points marked."""
    _check_result("pardel.plot.path", result)
    if len(result.coords) < 2:
        from . import PardelError

        raise PardelError("pardel.plot.path: result: the model has one coordinate; use pardel.plot.coordinates")
    ax = _axes("pardel.plot.path", ax)
    x, y = result.q[:, 0], result.q[:, 1]
    ax.plot(x, y, "-", lw=1.5, label=label or "%s (%s)" % (result.model, result.status))
    ax.plot([x[0]], [y[0]], "o", color="tab:green")
    ax.plot([x[-1]], [y[-1]], "s", color="tab:red")
    ax.set_xlabel(result.coords[0])
    ax.set_ylabel(result.coords[1])
    ax.set_aspect("equal", adjustable="datalim")
    cost = "%s = %.6g" % (result.cost_name.replace("_", " "), result.cost) if result.cost is not None else \
        "%s not finite" % result.cost_name
    ax.set_title("%s, N = %d: %s" % (result.model, result.N, cost))
    ax.legend(loc="best", fontsize="small")
    return ax


def coordinates(result: Result, ax: Optional[Axes] = None) -> Axes:
    """Each coordinate against the node times."""
    _check_result("pardel.plot.coordinates", result)
    ax = _axes("pardel.plot.coordinates", ax)
    for i, name in enumerate(result.coords):
        ax.plot(result.t, result.q[:, i], "-", lw=1.2, label=name)
    ax.set_xlabel("t")
    ax.set_title("%s: coordinates (%s)" % (result.model, result.status))
    ax.legend(loc="best", fontsize="small")
    return ax


def convergence(result: Result, ax: Optional[Axes] = None) -> Axes:
    """The DEL residual (infinity norm) of each recorded iteration, on a log scale."""
    _check_result("pardel.plot.convergence", result)
    ax = _axes("pardel.plot.convergence", ax)
    h = result.history
    residual = np.asarray(h["residual"], dtype=float)
    positive = residual > 0
    ax.semilogy(np.asarray(h["iteration"])[positive], residual[positive], ".-", lw=1)
    ax.set_xlabel("iteration")
    ax.set_ylabel("DEL residual")
    ax.set_title("%s: %s after %d iterations" % (result.model, result.status, result.iterations))
    ax.grid(True, which="both", alpha=0.3)
    return ax
