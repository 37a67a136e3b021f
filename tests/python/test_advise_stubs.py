"""The typed stubs shipped with the package (advise/_advise.pyi) against the extension module
itself: the same public names, the same members of each class, and every function's and method's
parameters with the same names, kinds and defaults-or-not (read by ``inspect`` from the
signatures PyO3 gives)."""

import ast
import inspect
import os

import advise
import advise._advise as ext

STUB = os.path.join(os.path.dirname(advise.__file__), "_advise.pyi")


def stub_tree():
    with open(STUB) as f:
        return ast.parse(f.read())


def public(name):
    return not name.startswith("_") or name in ("__len__", "__bool__", "__enter__", "__exit__")


def params(args):
    """(name, kind, has default) of an ast function's parameters, `self` left out."""
    out = []
    positional = args.posonlyargs + args.args
    defaults = [None] * (len(positional) - len(args.defaults)) + list(args.defaults)
    for a, d in zip(positional, defaults):
        if a.arg in ("self", "cls"):
            continue
        kind = "POSITIONAL_ONLY" if a in args.posonlyargs else "POSITIONAL_OR_KEYWORD"
        out.append((a.arg, kind, d is not None))
    if args.vararg:
        out.append((args.vararg.arg, "VAR_POSITIONAL", False))
    for a, d in zip(args.kwonlyargs, args.kw_defaults):
        out.append((a.arg, "KEYWORD_ONLY", d is not None))
    return out


def runtime_params(obj):
    sig = inspect.signature(obj)
    out = []
    for p in sig.parameters.values():
        if p.name in ("self", "cls"):
            continue
        kind = p.kind.name
        # PyO3 marks `self` positional-only with `/`; the stubs need not repeat it for the rest.
        if kind == "POSITIONAL_ONLY":
            kind = "POSITIONAL_OR_KEYWORD"
        out.append((p.name, kind, p.default is not inspect.Parameter.empty))
    return out


def normalise(ps):
    return [(n, "POSITIONAL_OR_KEYWORD" if k == "POSITIONAL_ONLY" else k, d) for n, k, d in ps]


def stub_classes(tree):
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}

    def members(cls):
        found = {}
        for base in cls.bases:
            if isinstance(base, ast.Name) and base.id in classes:
                found.update(members(classes[base.id]))
        for n in cls.body:
            if isinstance(n, ast.FunctionDef):
                found[n.name] = n
        return found

    return {name: members(c) for name, c in classes.items()}


def test_the_stubs_name_what_the_module_holds():
    tree = stub_tree()
    in_stub = {n.name for n in tree.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))}
    in_stub = {n for n in in_stub if not n.startswith("_")}
    in_module = {n for n in dir(ext) if not n.startswith("_")}
    assert in_stub == in_module, (sorted(in_stub - in_module), sorted(in_module - in_stub))


def test_functions_take_the_parameters_the_stubs_say():
    for n in stub_tree().body:
        if isinstance(n, ast.FunctionDef) and not n.name.startswith("_"):
            assert normalise(params(n.args)) == runtime_params(getattr(ext, n.name)), n.name


def test_classes_have_the_members_and_parameters_the_stubs_say():
    wrong = []
    for name, members in stub_classes(stub_tree()).items():
        if name.startswith("_") or name == "AdviseError":
            continue
        cls = getattr(ext, name)
        runtime = {m for m in dir(cls) if public(m)} - {"__init__", "__new__"}
        stubbed = {m for m in members if public(m)} - {"__init__"}
        if runtime != stubbed:
            wrong.append((name, sorted(stubbed - runtime), sorted(runtime - stubbed)))
            continue
        for m, node in members.items():
            decorators = {d.id for d in node.decorator_list if isinstance(d, ast.Name)}
            if "property" in decorators or not public(m) and m != "__init__":
                continue
            target = cls if m == "__init__" else getattr(cls, m)
            try:
                got = runtime_params(target)
            except (TypeError, ValueError):
                continue  # no signature to read (a slot wrapper)
            if normalise(params(node.args)) != got:
                wrong.append((f"{name}.{m}", normalise(params(node.args)), got))
    assert not wrong, wrong


def test_the_package_stub_re_exports_every_public_name():
    with open(os.path.join(os.path.dirname(advise.__file__), "__init__.pyi")) as f:
        tree = ast.parse(f.read())
    exported = set()
    for n in tree.body:
        if isinstance(n, ast.ImportFrom):
            exported |= {a.asname for a in n.names if a.asname == a.name}
    assert set(advise.__all__) <= exported, sorted(set(advise.__all__) - exported)
    assert all(hasattr(advise, name) for name in advise.__all__)
