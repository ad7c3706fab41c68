"""The names pardel's annotations give its arguments. typing.get_type_hints resolves them in the
module of the function annotated, which also holds the names they refer to (os, Model, Result)."""
from typing import Any, Callable, Mapping, Sequence, Union

import numpy as np

try:
    from numpy.typing import ArrayLike
except ImportError:  # NumPy before 1.20
    ArrayLike = Any  # type: ignore[misc]

# a model: a bundled model's name, a .lag path, .lag text or a Model;
ModelLike = Union[str, "os.PathLike[str]", "Model"]
# a path;
PathArg = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
# an initial guess: an (M+1) x dim array or a previous Result;
Guess = Union[ArrayLike, "Result", None]
# on_iteration(iteration, N, residual, action): a false return stops the solve;
OnIteration = Callable[[int, int, float, float], Any]
# params: numbers by name, or numbers in declaration order.
Params = Union[Mapping[str, float], Sequence[float], np.ndarray]
