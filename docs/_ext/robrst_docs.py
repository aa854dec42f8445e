"""Sphinx extension of robrst's documentation: file references generated from the schemas.

``robrst-schema`` renders the reference of a file format as a table at build time, from the
declarations the readers validate with (so the reference cannot drift from the code)::

    ```{robrst-schema} problem
    ```

Kinds: ``problem`` (:func:`robrst.problem.files.schema_markdown`), ``sweep``
(:func:`robrst.studies.sweep.files.sweep_schema_markdown`), ``twin``
(:data:`robrst.twin.config.TWIN_SCHEMA`) and ``scenario``
(:func:`robrst.studies.user_scenario.scenario_schema_markdown`) and ``mimo``
(:func:`robrst.problem.mimo_files.mimo_schema_markdown`).

The API reference is generated too: at ``builder-inited`` one page per public module is
written to ``api/generated/`` (reST: ``automodule``, then ``autoclass``/``autofunction`` of the functions and classes its
``__all__`` defines, and a table of the names it re-exports), and ``robrst-face`` renders
the table of ``robrst.__all__``.  "Public" is what ``tests/project/test_docstrings.py``
checks: every module whose dotted path has no part starting with ``_``.
"""

import importlib
import inspect
import pkgutil
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective

HEADER = ["| table | key | type | required | default | meaning |",
          "|---|---|---|---|---|---|"]


def schema_rows(kind):
    """The Markdown rows of one file format's reference (without the header)."""
    if kind == "problem":
        from robrst.problem.files import schema_markdown
        return schema_markdown()
    if kind == "sweep":
        from robrst.studies.sweep.files import sweep_schema_markdown
        return sweep_schema_markdown()
    if kind == "twin":
        from robrst.base.schema import markdown_rows
        from robrst.twin.config import TWIN_SCHEMA
        return markdown_rows(TWIN_SCHEMA)
    if kind == "scenario":
        from robrst.studies.user_scenario import scenario_schema_markdown
        return scenario_schema_markdown()
    if kind == "mimo":
        from robrst.problem.mimo_files import mimo_schema_markdown
        return mimo_schema_markdown()
    raise ValueError(f"unknown schema {kind!r}: expected problem, sweep, twin, scenario or"
                     " mimo")


class SchemaTable(SphinxDirective):
    """``{robrst-schema} KIND``: the reference table of a file format, generated."""

    required_arguments = 1
    has_content = False

    def run(self):
        rows = HEADER + schema_rows(self.arguments[0])
        box = nodes.container(classes=["robrst-schema"])
        self.state.nested_parse(StringList(rows, f"<robrst-schema {self.arguments[0]}>"),
                                self.content_offset, box)
        return box.children


def public_modules():
    """Dotted names of robrst's public modules (no part starts with ``_``), sorted."""
    import robrst
    names = ["robrst"]
    for info in pkgutil.walk_packages(robrst.__path__, "robrst."):
        parts = info.name.split(".")
        if any(p.startswith("_") for p in parts[1:]) or info.name.startswith("robrst.problems"):
            continue
        names.append(info.name)
    return sorted(names)


def _callables(module):
    """``(defined here, re-exported)``: the functions and classes of ``module.__all__``."""
    own, other = [], []
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name)
        if not (inspect.isfunction(obj) or inspect.isclass(obj)):
            continue
        (own if obj.__module__ == module.__name__ else other).append((name, obj))
    return own, other


LAYER_ORDER = ("robrst.base", "robrst.core", "robrst.problem", "robrst.certificate",
               "robrst.synthesis", "robrst.design", "robrst.controller", "robrst.data",
               "robrst.twin", "robrst.identify", "robrst.diagnose", "robrst.studies",
               "robrst.report", "robrst.cli", "robrst.testing", "robrst")


def layer_key(name):
    """Sort key: the layer (bottom first, as the architecture page lists them), then the name."""
    for i, pre in enumerate(LAYER_ORDER):
        if name == pre or name.startswith(pre + "."):
            return (i, name)
    return (len(LAYER_ORDER), name)


def module_page(name):
    """The reStructuredText source of one module's API page (autodoc is reST-native)."""
    module = importlib.import_module(name)
    own, other = _callables(module)
    lines = [name, "=" * len(name), "", f".. automodule:: {name}", "   :no-members:", ""]
    if own:
        lines += [".. autosummary::", "", *(f"   {n}" for n, _ in own), ""]
        for n, obj in own:
            if inspect.isclass(obj):
                lines += [f".. autoclass:: {name}.{n}", "   :members:", ""]
            else:
                lines += [f".. autofunction:: {name}.{n}", ""]
    if other:
        lines += ["Re-exported here:", "",
                  *(f"* :py:obj:`{n} <{obj.__module__}.{obj.__qualname__}>`" for n, obj in other),
                  ""]
    return "\n".join(lines)


def write_api_pages(app):
    """Write ``api/generated/<module>.api.rst`` for every public module (only when changed)."""
    out = Path(app.srcdir) / "api" / "generated"
    out.mkdir(parents=True, exist_ok=True)
    wanted = {f"{m}.api.rst": module_page(m) for m in public_modules()}
    for old in out.iterdir():
        if old.name not in wanted:
            old.unlink()
    for fname, text in wanted.items():
        path = out / fname
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")


class Modules(SphinxDirective):
    """``{robrst-modules}``: the toctree of the generated module pages, bottom layer first."""

    has_content = False

    def run(self):
        names = sorted(public_modules(), key=layer_key)
        text = ["```{toctree}", ":maxdepth: 1", "", *(f"generated/{m}.api" for m in names), "```"]
        box = nodes.container(classes=["robrst-modules"])
        self.state.nested_parse(StringList(text, "<robrst-modules>"), self.content_offset, box)
        return box.children


class Face(SphinxDirective):
    """``{robrst-face}``: a summary table of ``robrst.__all__``, linked to where each is defined."""

    has_content = False

    def run(self):
        import robrst
        rows = []
        for name in robrst.__all__:
            obj = getattr(robrst, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                rows.append(f"{obj.__module__}.{obj.__qualname__}")
        box = nodes.container(classes=["robrst-face"])
        text = ["```{eval-rst}", ".. autosummary::", "", *(f"   {r}" for r in rows), "```"]
        self.state.nested_parse(StringList(text, "<robrst-face>"), self.content_offset, box)
        return box.children


def setup(app):
    app.add_directive("robrst-schema", SchemaTable)
    app.add_directive("robrst-face", Face)
    app.add_directive("robrst-modules", Modules)
    app.connect("builder-inited", write_api_pages)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
