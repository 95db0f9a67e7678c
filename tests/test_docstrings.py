"""Every public name of bayescal has a numpydoc docstring (issue 19): a summary, the sections
its kind calls for (a function: Parameters and Returns; a class: Parameters or Attributes; a
public method: Parameters when it takes any, Returns unless it returns None; a property: a
summary), and the Examples sections run as doctests."""

import ast
import dataclasses
import doctest
import inspect
import itertools
import textwrap

import pytest
from numpydoc.docscrape import NumpyDocString

import bayescal


def _public_members(cls) -> dict:
    """The class's own public methods and properties (not those inherited from a base)."""
    members = {}
    for name, attribute in vars(cls).items():
        if name.startswith("_"):
            continue
        wrapped = isinstance(attribute, (staticmethod, classmethod))
        raw = attribute.__func__ if wrapped else attribute
        if isinstance(raw, property) or inspect.isfunction(raw):
            members[name] = raw
    return members


def _fields(cls) -> list[str]:
    """The public fields of a dataclass or equinox Module (its constructor's parameters)."""
    if not dataclasses.is_dataclass(cls):
        return []
    return [field.name for field in dataclasses.fields(cls) if not field.name.startswith("_")]


def _attribute_docstrings(cls) -> set[str]:
    """Fields documented by a string right after them in the class body (PEP 257's attribute
    docstrings, which the API page renders)."""
    body = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0].body
    return {
        statement.target.id
        for statement, following in itertools.pairwise(body)
        if isinstance(statement, ast.AnnAssign)
        and isinstance(statement.target, ast.Name)
        and isinstance(following, ast.Expr)
        and isinstance(following.value, ast.Constant)
        and isinstance(following.value.value, str)
    }


def _missing_sections(obj, kind: str) -> list[str]:
    text = inspect.getdoc(obj) if kind != "property" else inspect.cleandoc(obj.__doc__ or "")
    if not text:
        return ["docstring"]
    parsed = NumpyDocString(text)
    missing = [] if parsed["Summary"] else ["summary"]
    if kind == "class" and not issubclass(obj, BaseException):
        listed = {
            name
            for item in (*parsed["Parameters"], *parsed["Attributes"])
            for name in item.name.replace(" ", "").split(",")
        }
        undocumented = set(_fields(obj)) - listed - _attribute_docstrings(obj)
        if undocumented:
            missing.append(f"Parameters/Attributes for {sorted(undocumented)}")
    elif kind in ("function", "method"):
        signature = inspect.signature(obj)
        takes = [name for name in signature.parameters if name not in ("self", "cls")]
        if takes and not parsed["Parameters"]:
            missing.append("Parameters")
        if signature.return_annotation not in (None, "None") and not (
            parsed["Returns"] or parsed["Yields"]
        ):
            missing.append("Returns")
    return missing


def _documented_objects():
    for name in bayescal.__all__:
        obj = getattr(bayescal, name)
        if inspect.isclass(obj):
            yield name, obj, "class"
            if issubclass(obj, BaseException):  # a summary says when it is raised
                continue
            for member, raw in _public_members(obj).items():
                kind = "property" if isinstance(raw, property) else "method"
                yield f"{name}.{member}", raw, kind
        else:
            yield name, obj, "function"


def test_every_public_name_has_a_numpydoc_docstring():
    lacking = {
        name: missing
        for name, obj, kind in _documented_objects()
        if (missing := _missing_sections(obj, kind))
    }
    assert not lacking, "\n".join(f"{name}: lacks {', '.join(m)}" for name, m in lacking.items())


def _doctests():
    finder = doctest.DocTestFinder(exclude_empty=True)
    for name in bayescal.__all__:
        for test in finder.find(getattr(bayescal, name), name, globs={}):
            if any(not example.options.get(doctest.SKIP) for example in test.examples):
                yield test


@pytest.mark.parametrize("test", list(_doctests()), ids=lambda test: test.name)
def test_examples_run(test, tmp_path, monkeypatch):
    """Each Examples section, run as doctest runs it (in a scratch working directory)."""
    monkeypatch.chdir(tmp_path)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report = []
    runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
