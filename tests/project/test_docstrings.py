"""Docstrings as a contract: the public face of robrst carries numpydoc sections and type hints.

**The public face** is

* every name in ``robrst.__all__``, and
* every name in the ``__all__`` of every public module — a module of the ``robrst`` package
  whose dotted path has no part starting with ``_`` (``robrst.core._levelset`` is private;
  ``robrst.problems`` is a data package without code),

that is a function or a class defined in robrst; and the public methods of those classes
(functions, static and class methods defined in the class body whose names do not start
with ``_``; properties are attributes, not checked here).

**The rules** (numpydoc; python-control's ``docstrings_test.py`` checks its functions the
same way), for every function, method and class of the public face:

1. a docstring with a summary line;
2. a **Parameters** section listing exactly the signature's parameters: none missing, none
   that does not exist (``self`` and ``cls`` excepted; ``*args`` and ``**kwargs`` by those
   names). A class documents its constructor's parameters — a dataclass's fields, or those
   of an ``__init__`` it defines — in **Parameters** or **Attributes**; Attributes may also
   name the class's properties and other attributes. A class that defines no constructor
   of its own (an exception class) has none to document;
3. a **Returns** (or **Yields**) section unless the return annotation is ``None``;
4. a **Raises** section naming every exception class the body raises itself
   (``raise Name(...)``, for a class also in its ``__init__`` and ``__post_init__``; a bare
   re-raise or an exception held in a variable is not counted, nor what callees raise);
5. type hints: every parameter annotated (``self``/``cls`` excepted) and the return
   annotated (a class's constructor excepted: a dataclass's fields are annotated by
   definition).

Every public module that is not a package ``__init__`` also defines ``__all__``.

The test runs per layer; its failure message lists every offending name with what is
wrong, one per line (``robrst.core.poly.trim: Parameters missing ['tol']``).
"""

import ast
import dataclasses
import importlib
import inspect
import pkgutil
import re
import textwrap

import pytest

import robrst

LAYERS = ("base", "core", "data", "controller", "identify", "report", "cli", "testing",
          "studies", "problem", "certificate", "synthesis", "design", "twin", "diagnose",
          "face")
SECTIONS = ("Parameters", "Other Parameters", "Returns", "Yields", "Receives", "Raises",
            "Warns", "Warnings", "See Also", "Notes", "References", "Examples", "Attributes",
            "Methods")


def public_modules():
    names = ["robrst"]
    for info in pkgutil.walk_packages(robrst.__path__, "robrst."):
        parts = info.name.split(".")
        if any(p.startswith("_") for p in parts[1:]) or parts[1] == "problems":
            continue
        names.append(info.name)
    return names


def layer_of(module_name):
    parts = module_name.split(".")
    return parts[1] if len(parts) > 1 else "face"


def face():
    """``{id(obj): (qualified name, obj)}`` of every public function and class, and the
    modules without ``__all__``."""
    found, missing_all = {}, []
    for name in public_modules():
        module = importlib.import_module(name)
        exported = getattr(module, "__all__", None)
        if exported is None:
            if not hasattr(module, "__path__"):
                missing_all.append(name)
            continue
        for attr in exported:
            obj = getattr(module, attr)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and \
                    getattr(obj, "__module__", "").startswith("robrst"):
                found.setdefault(id(obj), (f"{obj.__module__}.{obj.__qualname__}", obj))
    return found, missing_all


def sections(doc):
    """``{section: [lines]}`` of a numpydoc docstring (``inspect.getdoc``: dedented)."""
    out, current = {}, None
    lines = doc.splitlines()
    for i, line in enumerate(lines):
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() in SECTIONS and re.fullmatch(r"\s*-{3,}\s*", nxt):
            current = line.strip()
            out[current] = []
        elif current is not None and not re.fullmatch(r"\s*-{3,}\s*", line):
            out[current].append(line)
    return out


def entries(lines):
    """The names of a Parameters/Attributes section: unindented lines, ``a, b : type``."""
    names = []
    for line in lines:
        if line and not line[0].isspace():
            head = line.split(" : ", 1)[0].split(":", 1)[0] if " : " in line or \
                line.rstrip().endswith(":") else line
            names += [n.strip() for n in head.split(",") if n.strip()]
    return names


def raised_names(func):
    """Exception classes ``func`` raises in its own body (not in nested functions)."""
    try:
        src = textwrap.dedent(inspect.getsource(func))
    except (OSError, TypeError):
        return set()
    tree = ast.parse(src)
    fn = next((n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))),
              None)
    if fn is None:
        return set()
    out, stack = set(), list(fn.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
            continue
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            name = exc.attr if isinstance(exc, ast.Attribute) else getattr(exc, "id", None)
            if name and name[0].isupper():
                out.add(name)
        stack.extend(ast.iter_child_nodes(node))
    return out


def documented_raises(lines):
    names = set()
    for line in lines:
        if line and not line[0].isspace():
            names |= {n.strip().rsplit(".", 1)[-1] for n in re.split(r"[,\s]+", line)
                      if n.strip()}
    return names


def signature_params(obj, skip_first):
    sig = inspect.signature(obj)
    params = list(sig.parameters.values())
    if skip_first and params and params[0].name in ("self", "cls"):
        params = params[1:]
    return sig, params


def param_label(p):
    return {inspect.Parameter.VAR_POSITIONAL: f"*{p.name}",
            inspect.Parameter.VAR_KEYWORD: f"**{p.name}"}.get(p.kind, p.name)


def check_callable(name, func, is_method):
    problems = []
    func = inspect.unwrap(func)
    doc = inspect.getdoc(func) if func.__doc__ else None
    if not doc or not doc.strip():
        return [f"{name}: no docstring"]
    secs = sections(doc)
    sig, params = signature_params(func, is_method)
    labels = [param_label(p) for p in params]
    documented = entries(secs.get("Parameters", [])) + entries(secs.get("Other Parameters", []))
    documented = [d.lstrip("\\") for d in documented]
    missing = [p for p in labels if p not in documented and p.lstrip("*") not in documented]
    extra = [d for d in documented if d not in labels and f"*{d}" not in labels
             and f"**{d}" not in labels]
    if missing:
        problems.append(f"{name}: Parameters missing {missing}")
    if extra:
        problems.append(f"{name}: Parameters documents names not in the signature {extra}")
    ret = sig.return_annotation
    if ret is not None and ret != "None" and not ({"Returns", "Yields"} & set(secs)):
        problems.append(f"{name}: no Returns section")
    raised = raised_names(func)
    undocumented = sorted(raised - documented_raises(secs.get("Raises", [])))
    if undocumented:
        problems.append(f"{name}: Raises does not name {undocumented}")
    unannotated = [p.name for p in params if p.annotation is inspect.Parameter.empty]
    if unannotated:
        problems.append(f"{name}: parameters without type hints {unannotated}")
    if ret is inspect.Signature.empty:
        problems.append(f"{name}: no return annotation")
    return problems


def instance_attributes(cls):
    """Names the class's own ``__init__`` assigns as ``self.name = ...``."""
    init = cls.__dict__.get("__init__")
    if not inspect.isfunction(init):
        return set()
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(init)))
    except (OSError, TypeError):
        return set()
    return {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)
            and isinstance(n.ctx, ast.Store) and getattr(n.value, "id", None) == "self"}


def own_constructor(cls):
    """The constructor parameters a class must document ([] when it defines none)."""
    if dataclasses.is_dataclass(cls):
        return [f.name for f in dataclasses.fields(cls) if f.init]
    init = cls.__dict__.get("__init__")
    if init is None or not inspect.isfunction(init):
        return []
    _, params = signature_params(init, True)
    return [param_label(p) for p in params]


def check_class(name, cls):
    problems = []
    doc = cls.__doc__
    auto = dataclasses.is_dataclass(cls) and doc and doc.startswith(cls.__name__ + "(")
    if not doc or not doc.strip() or auto:
        return [f"{name}: no docstring"]
    secs = sections(inspect.getdoc(cls))
    params = own_constructor(cls)
    in_params = entries(secs.get("Parameters", []))
    in_attrs = entries(secs.get("Attributes", []))
    missing = [p for p in params if p not in in_params + in_attrs
               and p.lstrip("*") not in in_params + in_attrs]
    if missing:
        problems.append(f"{name}: constructor parameters not in Parameters/Attributes {missing}")
    extra = [d for d in in_params if d not in params and f"*{d}" not in params
             and f"**{d}" not in params]
    known = set(params) | {k for k in dir(cls) if not k.startswith("_")}
    if dataclasses.is_dataclass(cls):
        known |= {f.name for f in dataclasses.fields(cls)}          # init=False fields too
    known |= instance_attributes(cls)
    extra += [d for d in in_attrs if d not in known]
    if extra:
        problems.append(f"{name}: documents names that do not exist {extra}")
    raised = set()
    for hook in ("__init__", "__post_init__"):
        if inspect.isfunction(cls.__dict__.get(hook)):
            raised |= raised_names(cls.__dict__[hook])
    undocumented = sorted(raised - documented_raises(secs.get("Raises", [])))
    if undocumented:
        problems.append(f"{name}: Raises does not name {undocumented}")
    init = cls.__dict__.get("__init__")
    if inspect.isfunction(init) and not dataclasses.is_dataclass(cls):
        _, ps = signature_params(init, True)
        unannotated = [p.name for p in ps if p.annotation is inspect.Parameter.empty]
        if unannotated:
            problems.append(f"{name}: constructor parameters without type hints {unannotated}")
    for attr, value in cls.__dict__.items():
        if attr.startswith("_"):
            continue
        if isinstance(value, (staticmethod, classmethod)):
            problems += check_callable(f"{name}.{attr}", value.__func__,
                                       isinstance(value, classmethod))
        elif inspect.isfunction(value):
            problems += check_callable(f"{name}.{attr}", value, True)
    return problems


def problems_of(layer):
    found, missing_all = face()
    out = [f"{m}: public module without __all__" for m in missing_all if layer_of(m) == layer]
    for name, obj in sorted(found.values(), key=lambda item: item[0]):
        if layer_of(obj.__module__) != layer:
            continue
        out += check_class(name, obj) if inspect.isclass(obj) else check_callable(name, obj,
                                                                                  False)
    return out


@pytest.mark.parametrize("layer", LAYERS)
def test_the_public_face_has_numpydoc_sections_and_type_hints(layer):
    problems = problems_of(layer)
    assert not problems, (f"{len(problems)} problems in the public face of layer {layer!r}"
                          " (see this module's docstring for the rules):\n"
                          + "\n".join(problems))


def test_every_layer_is_checked():
    assert {layer_of(m) for m in public_modules()} <= set(LAYERS)


def test_the_checker_can_fail():
    """A function whose docstring misses a parameter, documents a ghost, lacks Returns and
    Raises and hints is caught on every count; a complete one passes."""
    def bad(x, y=1):
        """Summary.

        Parameters
        ----------
        x : float
            An x.
        z : int
            Not a parameter.
        """
        raise ValueError(x + y)

    def good(x: float, *args: int, **kw: str) -> float:
        """Summary.

        Parameters
        ----------
        x : float
            An x.
        *args : int
            More.
        **kw : str
            Options.

        Returns
        -------
        float
            ``x``.

        Raises
        ------
        ValueError
            When ``x`` is negative.
        """
        if x < 0:
            raise ValueError(x)
        return x

    got = "\n".join(check_callable("bad", bad, False))
    for text in ("missing ['y']", "not in the signature ['z']", "no Returns", "['ValueError']",
                 "without type hints ['x', 'y']", "no return annotation"):
        assert text in got
    assert check_callable("good", good, False) == []
