"""Every example in a docstring is run or checked, so that none can rot.

`>>>` examples run as doctests. The other examples, indented code in a docstring (the robot with
a camera, a training run: too slow or needing hardware to run here), are checked: each parses as
Python (or is not Python at all: TOML, a shell line), each `from oxbot... import` names what
exists, and each call of an oxbot function or class it imported binds to its signature (the
right positional count and keyword names)."""

import ast
import doctest
import importlib
import inspect
import pkgutil
import re
import textwrap

import pytest

import oxbot

MODULES = ["oxbot", *sorted(m.name for m in pkgutil.walk_packages(oxbot.__path__, "oxbot."))]


def docstrings(module):
    """(where, docstring) of the module and of its own classes and functions."""
    tree = ast.parse(inspect.getsource(module))
    found = [(module.__name__, ast.get_docstring(tree, clean=True))]
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            found.append((f"{module.__name__}.{node.name}", ast.get_docstring(node, clean=True)))
    return [(where, doc) for where, doc in found if doc]


def examples(doc):
    """The indented blocks of a docstring that are not `>>>` examples."""
    blocks = re.findall(r"(?:^(?: {4}.*|)\n)*^ {4}\S.*(?:\n(?: {4}.*|))*", doc, re.M)
    return [textwrap.dedent(b).strip("\n") for b in blocks if ">>>" not in b]


def python_of(block):
    """The block's Python syntax tree, or None when it is no Python (TOML, shell, prose)."""
    try:
        tree = ast.parse(block)
    except SyntaxError:
        return None
    has_code = any(
        isinstance(n, ast.Import | ast.ImportFrom | ast.Call | ast.Assign | ast.With)
        for n in ast.walk(tree)
    )
    return tree if has_code else None


def names_in_scope(tree, module):
    """name -> object: the names of the docstring's own module (an example may call them
    unimported), then the oxbot objects the example's own imports bring."""
    names = dict(vars(module))
    for node in ast.walk(tree):  # the example's own variables are no longer the module's
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.pop(node.id, None)
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("oxbot"):
            module = importlib.import_module(node.module)
            for alias in node.names:
                names[alias.asname or alias.name] = getattr(module, alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("oxbot"):
                    names[alias.asname or alias.name] = importlib.import_module(alias.name)
    return names


def callee(node, names):
    """The oxbot function or class a call names, or None."""
    if isinstance(node.func, ast.Name):
        return names.get(node.func.id)
    if isinstance(node.func, ast.Attribute) and isinstance(node.func.value, ast.Name):
        base = names.get(node.func.value.id)
        if inspect.ismodule(base):
            return getattr(base, node.func.attr)
    return None


CASES = [
    pytest.param(name, block, id=f"{where}:{k}")
    for name in MODULES
    for where, doc in docstrings(importlib.import_module(name))
    for k, block in enumerate(examples(doc))
]


@pytest.mark.parametrize(("where", "block"), CASES)
def test_a_docstring_example_names_what_exists_and_calls_it_as_defined(where, block):
    tree = python_of(block)
    if tree is None:
        return  # TOML, a shell line, a table: nothing to call
    names = names_in_scope(tree, importlib.import_module(where))  # a name gone fails here
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call) or any(isinstance(a, ast.Starred) for a in node.args):
            continue
        target = callee(node, names)
        if target is None or not callable(target):
            continue
        try:
            signature = inspect.signature(target)
        except (TypeError, ValueError):
            continue
        keywords = {k.arg: None for k in node.keywords if k.arg is not None}
        if any(k.arg is None for k in node.keywords):
            continue  # **kwargs in the example: nothing to check
        try:
            signature.bind(*[None] * len(node.args), **keywords)
        except TypeError as exc:
            pytest.fail(f"{where}: {ast.unparse(node)} does not fit {target.__name__}: {exc}")


def test_every_doctest_in_the_package_passes():
    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    ran = 0
    for name in MODULES:
        for test in finder.find(importlib.import_module(name)):
            if test.examples:
                ran += len(test.examples)
                runner.run(test)
    failed, _ = runner.summarize(verbose=False)
    assert failed == 0 and ran > 0
