"""The package's public face: every public name has a docstring that help() shows, every public
function and method is annotated and its annotations resolve, the PEP 561 marker and the stub of
the compiled core lie beside the package, the stub's names and parameters are the compiled
module's, and docs/python.md names every attribute of a Result and a Model."""
import ast
import inspect
import os
import pydoc
import re
import typing

import pytest

import pardel
import pardel.plot
from pardel import _pardel

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def public_callables():
    """(qualified name, function) of every public function and public method or property."""
    found = []
    for name in pardel.__all__:
        obj = getattr(pardel, name)
        if inspect.isfunction(obj):
            found.append(("pardel." + name, obj))
        elif inspect.isclass(obj) and obj.__module__ == "pardel":
            for member, value in vars(obj).items():
                if member.startswith("_") and member != "__init__":
                    continue
                if isinstance(value, property):
                    found.append(("pardel.%s.%s" % (name, member), value.fget))
                elif inspect.isfunction(value):
                    found.append(("pardel.%s.%s" % (name, member), value))
    for name in ("path", "coordinates", "convergence"):
        found.append(("pardel.plot." + name, getattr(pardel.plot, name)))
    return found


def test_every_public_name_has_a_docstring_that_help_shows():
    assert pardel.__doc__ and pardel.plot.__doc__
    for name in pardel.__all__:
        obj = getattr(pardel, name)
        doc = vars(obj).get("__doc__") if inspect.isclass(obj) else obj.__doc__
        assert doc and doc.strip(), "pardel.%s has no docstring of its own" % name
        shown = pydoc.render_doc(obj, renderer=pydoc.plaintext).replace("|", " ")  # a class's lines start with |
        assert " ".join(doc.split()[:6]) in " ".join(shown.split()), name
    for qualified, function in public_callables():
        if function.__name__ == "__init__":
            continue
        assert function.__doc__ and function.__doc__.strip(), "%s has no docstring" % qualified


def test_public_functions_and_methods_are_annotated_and_resolve():
    sympy = pytest.importorskip("sympy")
    axes = pytest.importorskip("matplotlib.axes")
    for qualified, function in public_callables():
        signature = inspect.signature(function)
        for parameter in signature.parameters.values():
            if parameter.name == "self":
                continue
            assert parameter.annotation is not inspect.Parameter.empty, "%s: %s" % (qualified, parameter.name)
        assert signature.return_annotation is not inspect.Signature.empty, qualified
        # Names imported for type checkers alone (typing.TYPE_CHECKING): SymPy, matplotlib's Axes.
        names = dict(function.__globals__, sympy=sympy, Axes=axes.Axes)
        hints = typing.get_type_hints(function, globalns=names)
        assert "return" in hints, qualified


def test_the_marker_and_the_stub_lie_beside_the_package():
    package = os.path.dirname(pardel.__file__)
    assert os.path.isfile(os.path.join(package, "py.typed"))
    assert os.path.dirname(_pardel.__file__) == package
    assert os.path.isfile(os.path.join(package, "_pardel.pyi"))


def stub():
    with open(os.path.join(os.path.dirname(_pardel.__file__), "_pardel.pyi"), encoding="utf-8") as f:
        return ast.parse(f.read())


def compiled_parameters(function):
    """The parameter names of a pybind11 function, from its signature line `f(a: T, b: U) -> R`."""
    first = function.__doc__.strip().splitlines()[0]
    inner = first[first.index("(") + 1:first.rindex(") ->")]
    return re.findall(r"(?:^|, )(\w+):", inner)


def test_the_stub_has_the_compiled_modules_names_and_parameters():
    tree = stub()
    declared = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared[node.name] = node
        elif isinstance(node, ast.AnnAssign):
            declared[node.target.id] = node
    present = {name for name in dir(_pardel) if not name.startswith("_")} | {"__version__"}
    assert set(declared) == present

    for name, node in declared.items():
        obj = getattr(_pardel, name)
        if isinstance(node, ast.FunctionDef):
            assert callable(obj) and not inspect.isclass(obj), name
            assert [a.arg for a in node.args.args] == compiled_parameters(obj), name
        elif isinstance(node, ast.ClassDef):
            assert inspect.isclass(obj), name
            bases = [b.id for b in node.bases]
            for base in bases:  # a stub base is the compiled class's base (same name)
                assert base in [c.__name__ for c in obj.__mro__[1:]], (name, base)
            if issubclass(obj, BaseException):
                assert bases == [obj.__base__.__name__], name
                continue
            methods = {n.name for n in node.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
            assert methods == {m for m in dir(obj) if not m.startswith("_")}, name
            for method in node.body:
                if isinstance(method, ast.FunctionDef) and not method.name.startswith("_") and \
                        not method.decorator_list:
                    assert [a.arg for a in method.args.args][1:] == compiled_parameters(getattr(obj, method.name))[1:]
        else:
            annotation = ast.unparse(node.annotation)
            kind = {"str": str, "int": int}.get(annotation) or (dict if annotation.startswith("Dict") else None)
            assert kind is not None and isinstance(obj, kind), (name, annotation)


def documented_names(heading_text):
    """The `names` of the paragraph of docs/python.md that starts with heading_text."""
    with open(os.path.join(ROOT, "docs", "python.md"), encoding="utf-8") as f:
        text = f.read()
    start = text.index(heading_text)
    paragraph = text[start:text.index("\n\n", start)]
    return set(re.findall(r"`(\w+)(?:\(\w*\))?`", paragraph))


def test_the_documentation_names_every_attribute_of_a_result_and_a_model(spring_lag):
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2, N=10)
    attributes = {name for name in vars(r)} | {name for name in vars(pardel.Result) if not name.startswith("_")}
    missing = attributes - documented_names("The result (`pardel.Result`) has")
    assert not missing, "docs/python.md does not describe Result.%s" % ", ".join(sorted(missing))
    m = pardel.model(spring_lag)
    attributes = {name for name in vars(m) if not name.startswith("_")}
    missing = attributes - documented_names("`pardel.model(spec)` returns a `pardel.Model`")
    assert not missing, "docs/python.md does not describe Model.%s" % ", ".join(sorted(missing))
    # The class annotations list the same attributes as an instance has.
    assert set(typing.get_type_hints(pardel.Result)) == {name for name in vars(r)}
    assert set(typing.get_type_hints(pardel.Model)) == attributes
