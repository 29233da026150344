"""The type stubs (volcomp/_volcomp.pyi) describe the compiled module as it
is: every public name, and every function's and method's parameters by
name, kind and default."""

import ast
import inspect
import pathlib

import volcomp

STUB = pathlib.Path(__file__).resolve().parents[1] / "python" / "volcomp" / "_volcomp.pyi"


def stub_defs():
    tree = ast.parse(STUB.read_text())
    funcs, classes = {}, {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            funcs[node.name] = node
        elif isinstance(node, ast.ClassDef):
            classes[node.name] = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
    return funcs, classes


def params(node, skip_self):
    a = node.args
    pos = [p.arg for p in a.args]
    if skip_self and pos and pos[0] == "self":
        pos = pos[1:]
    return pos, [p.arg for p in a.kwonlyargs]


def kw_defaults(node):
    """Keyword-only parameters with their defaults (literals)."""
    a = node.args
    return {p.arg: ast.literal_eval(d) if d is not None else inspect.Parameter.empty for p, d in zip(a.kwonlyargs, a.kw_defaults)}


def runtime_params(f):
    sig = inspect.signature(f)
    if any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values()):
        # **options: the library's options, checked against the stubs by
        # test_the_librarys_options_are_in_the_stubs_with_their_defaults.
        return None
    pos = [p.name for p in sig.parameters.values() if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    kw = [p.name for p in sig.parameters.values() if p.kind == p.KEYWORD_ONLY]
    return pos, kw


def test_every_public_name_has_a_stub():
    funcs, classes = stub_defs()
    text = STUB.read_text()
    for name in volcomp.__all__:
        if name == "__version__":
            assert "__version__: str" in text
            continue
        assert name in funcs or name in classes, name


def test_function_parameters_match():
    funcs, classes = stub_defs()
    for name, node in funcs.items():
        rt = runtime_params(getattr(volcomp, name))
        assert rt is None or rt == params(node, False), name
    for cname, methods in classes.items():
        cls = getattr(volcomp, cname)
        for mname, node in methods.items():
            member = inspect.getattr_static(cls, mname)
            if isinstance(member, (staticmethod,)) or type(member).__name__ == "builtin_function_or_method":
                f = getattr(cls, mname)
                skip = False
            elif callable(member) and not isinstance(member, property) and type(member).__name__ != "getset_descriptor":
                f = getattr(cls, mname)
                skip = True
            else:
                continue  # properties and attributes
            try:
                rt = runtime_params(f)
            except (TypeError, ValueError):
                continue
            if rt is None:
                continue
            if skip and rt[0] and rt[0][0] == "self":
                rt = (rt[0][1:], rt[1])
            assert rt == params(node, True), f"{cname}.{mname}"


def test_the_librarys_options_are_in_the_stubs_with_their_defaults():
    """compensate, simulate and moves take the library's options (the CLI's
    flags are built from the same table): the stubs list each, with its
    default. A new option of the library fails here until its stub line is
    written (the expected line is in the message)."""
    funcs, classes = stub_defs()
    jobs = {job: funcs[job] for job in ("compensate", "simulate", "moves", "mirror", "thermal_fit", "straightness_fit", "export")}
    jobs["thermal_predict"] = classes["ThermalModel"]["predict"]
    for job, node in jobs.items():
        stub = kw_defaults(node)
        own = {p.arg for p in node.args.args}
        for o in volcomp._volcomp._options(job):
            if o["name"] in own:
                continue
            line = f"    {o['name']}: {o['type']} = {o['default']!r},"
            assert o["name"] in stub, f"{job}: add to the stub: {line}"
            assert stub[o["name"]] == o["default"], f"{job}: {line}"
