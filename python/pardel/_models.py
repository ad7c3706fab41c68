"""pardel's models: the folder of compiled models (lag_cache_dir) and the checks that it is this
user's alone, the loader's spec of a model argument (a .lag text written to the cache), Model, and
the functions that make one (model, model_from_sympy) or list the bundled ones (models)."""
from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import stat
import tempfile
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from . import _pardel
from ._checks import _kind
from ._pardel import ModelError
from ._types import ModelLike

if TYPE_CHECKING:
    import sympy  # model_from_sympy's annotations (SymPy is imported by that function alone)


def lag_cache_dir() -> str:
    """The folder of compiled models (the model loader's): $PARDEL_CACHE_DIR, else
    $XDG_CACHE_HOME/pardel, else $HOME/.cache/pardel; with none of them set, a private folder of
    this process (tempfile.mkdtemp, removed at exit), so nothing is reused between processes."""
    global _process_cache
    if os.environ.get("PARDEL_CACHE_DIR"):
        return os.environ["PARDEL_CACHE_DIR"]
    if os.environ.get("XDG_CACHE_HOME"):
        return os.path.join(os.environ["XDG_CACHE_HOME"], "pardel")
    if os.environ.get("HOME"):
        return os.path.join(os.environ["HOME"], ".cache", "pardel")
    if _process_cache is None:
        folder = tempfile.mkdtemp(prefix="pardel-cache-")
        atexit.register(shutil.rmtree, folder, True)
        _process_cache = folder
    return _process_cache


_process_cache: Optional[str] = None


def _private_folder(path):
    """Creates the cache folder `path` (mode 0700) if missing and checks that it is this user's
    alone: not a symbolic link, owned by this user, writable by no one else (as the model loader
    checks the cache). Raises ModelError naming the path and the reason otherwise."""
    path = path.rstrip("/") or "/"
    parent = os.path.dirname(path)
    if parent:
        os.makedirs(parent, exist_ok=True)
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    st = os.lstat(path)
    why = None
    if stat.S_ISLNK(st.st_mode):
        why = "a symbolic link"
    elif not stat.S_ISDIR(st.st_mode):
        why = "not a folder"
    elif st.st_uid != os.geteuid():
        why = "owned by user %d, not by this user (%d)" % (st.st_uid, os.geteuid())
    elif st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        why = "writable by %s (mode %04o)" % (
            "its group and by others" if st.st_mode & stat.S_IWGRP and st.st_mode & stat.S_IWOTH
            else "its group" if st.st_mode & stat.S_IWGRP else "others", stat.S_IMODE(st.st_mode))
    if why:
        raise ModelError("refusing the model cache folder %s: it is %s; a model cache must be a folder "
                         "of this user's that no one else can write (chmod 700 it, or set "
                         "PARDEL_CACHE_DIR to another folder)" % (path, why))
    return path


def _lag_text_file(text):
    """Writes .lag text to <cache>/lag-text/<hash>.lag and returns the path. The file is written
    afresh on every call (privately, mode 0600, flushed, then renamed over the old one), so a file
    edited since an earlier call is replaced, never compiled."""
    data = text.encode("utf-8")
    digest = hashlib.sha256(data).hexdigest()[:16]
    folder = _private_folder(os.path.join(_private_folder(lag_cache_dir()), "lag-text"))
    path = os.path.join(folder, digest + ".lag")
    fd, tmp = tempfile.mkstemp(prefix=digest + ".lag.tmp.", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _model_spec(spec, where="pardel.model", argument="spec"):
    """The loader's spec for a model given as a Model, a bundled name, a .lag path or .lag text
    (a string with a line break); `where` names the calling function in a refusal."""
    if isinstance(spec, Model):
        return spec.spec
    if isinstance(spec, os.PathLike):
        spec = os.fspath(spec)
    if not isinstance(spec, str):
        raise TypeError("%s: %s: a name, a .lag path, .lag text or a pardel.Model was expected, got %s" % (
            where, argument, _kind(spec)))
    if "\n" in spec:
        return _lag_text_file(spec)
    if spec.endswith(".lag") or "/" in spec:
        return os.path.abspath(spec)
    return spec


def _check_model(where, name, spec):
    """A model argument: a bundled name, a .lag path, .lag text (str or os.PathLike) or a Model."""
    if not isinstance(spec, (str, os.PathLike, Model)):
        raise TypeError("%s: %s must be a bundled model's name, a .lag path, .lag text or a pardel.Model, got %s"
                        % (where, name, _kind(spec)))


class Model:
    """A compiled model: name, coords, order, ncoords (len(coords)), dim (ncoords x order: the values
    of a node), params (name -> default, in declaration order), discretizations, has_clock (whether
    it declares a clock), time_dependent (whether L or the clock uses t), source (the .lag file it
    was generated from, as the generator recorded it) and spec (what the loader loaded: the name,
    the absolute path, or the cache file of the text).

    lag_text is the .lag text it was built from (for .lag text and pardel.model_from_sympy; None for
    a bundled name or a .lag path). A Model pickles as what it was built from (the name, the absolute
    path or the text), and unpickling loads it again (compiling it, or finding it in the cache,
    in the process that unpickles: a path is read again there)."""

    name: str
    coords: List[str]
    order: int
    ncoords: int
    dim: int
    params: Dict[str, float]
    discretizations: List[str]
    has_clock: bool
    time_dependent: bool
    source: str
    spec: str
    lag_text: Optional[str]

    def __init__(self, spec: ModelLike) -> None:
        self._load("pardel.model", spec)

    def _load(self, where, spec):
        """Loads `spec`; `where` names the calling function in the refusal of a name that is no
        bundled model's (the generator's FILE:LINE:COL messages name the file instead)."""
        _check_model(where, "spec", spec)
        if isinstance(spec, Model):
            self.lag_text = spec.lag_text
        elif isinstance(spec, str) and "\n" in spec:
            self.lag_text = spec
        else:
            self.lag_text = None
        self.spec = _model_spec(spec)
        try:
            self._handle = _pardel.load_model(os.fsencode(self.spec))  # a path's bytes, also when not UTF-8
        except ModelError as error:
            if self.spec.endswith(".lag") or "/" in self.spec:
                raise
            raise ModelError("%s: %s" % (where, error)) from None
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

    def __repr__(self) -> str:
        return "pardel.Model(%r: coords %s, order %d, params %s, discretizations %s)" % (
            self.name, self.coords, self.order, self.params, self.discretizations)

    def __reduce__(self) -> Tuple[Any, Tuple[str]]:
        # What it was built from; the compiled handle is this process's alone.
        return (Model, (self.spec if self.lag_text is None else self.lag_text,))


def _model_of(where, spec):
    """The Model of a model argument of `where` (a Model as it is), refusals naming `where`."""
    if isinstance(spec, Model):
        return spec
    made = Model.__new__(Model)
    made._load(where, spec)
    return made


def model(spec: ModelLike) -> Model:
    """The model of a bundled name, a .lag path, or .lag text (compiled on first use, cached in
    lag_cache_dir())."""
    return Model(spec)


def model_from_sympy(L: sympy.Expr, coords: Union[Sequence[sympy.Expr], sympy.Expr],
                     params: Optional[Mapping[Union[sympy.Symbol, str], Union[float, sympy.Expr]]] = None, *,
                     order: Optional[int] = None, name: str = "sympy_model",
                     discretizations: Optional[Sequence[str]] = None, clock: Optional[sympy.Expr] = None,
                     cost: Optional[Tuple[str, str]] = None, allow_singular: bool = False) -> Model:
    """A model from a Lagrangian written with SymPy: L is printed as .lag text (Model.lag_text) and
    compiled as pardel.model compiles .lag text, so its kernels are those of the same model written
    by hand.

    L: a SymPy expression in the coordinates, their time derivatives, the time and the params.
    coords: the coordinates, functions of one time symbol: sympy.Function("x")(t) (or
    sympy.physics.mechanics.dynamicsymbols("x")); derivatives are x.diff(t), x.diff(t, 2), ...
    (x', x'' in .lag), and the time symbol elsewhere in L is .lag's t. params: a dict {symbol or
    name: default} in declaration order, the default a real number or a constant SymPy expression
    (sympy.pi / 4); a symbol of L whose name is a param's is that param. order: the highest
    derivative L may use (default: the highest in L, at least 1). name: the model's name.
    discretizations: a list of names ("midpoint", "galerkin_gauss(s=4)"; docs/discretizations.md),
    None for the generator's default. clock: dt/ds (a SymPy expression, as L). cost: (name,
    "action" or "clock"). allow_singular: True writes "# pardel: allow-singular".

    Raises TypeError for an argument of the wrong type and PardelError (a ValueError) for what .lag
    cannot write (a function other than .lag's, a symbol that is neither the time nor a param, a
    function that is not a coordinate, a complex or infinite number), each naming the argument;
    pardel.ModelError when the generator refuses the model (one that is not regular, say).
    """
    from . import _sympy  # SymPy is needed for this function alone
    return Model(_sympy.lag_text("pardel.model_from_sympy", L, coords, params, order, name, discretizations,
                                 clock, cost, allow_singular))


def models() -> List[str]:
    """The names of the bundled models."""
    return list(_pardel.bundled_models())
