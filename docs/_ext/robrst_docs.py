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

The API reference is generated too, grouped by task (as python-control's function list
is): :data:`API_PAGES` names each page's objects as users import them (``robrst.Plant``,
not ``robrst.core.plant.Plant``); at ``builder-inited`` each page is written to
``api/<page>.rst`` (``autoclass``/``autofunction`` of its names), and ``robrst-face``
renders the table of ``robrst.__all__``.  ``robrst-output`` shows a command's output,
run at build time.  Every function and class of ``robrst.__all__``
is on exactly one page (``tests/project/test_docs.py`` checks it); the modules behind the
face are described in the architecture page.
"""

import contextlib
import importlib
import inspect
import io
import os
import shlex
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


# The API reference: (file, title, what the page is for, names as users import them).
API_PAGES = (
    ("problems", "Problems and specs",
     "A problem file or record in: the plant family, the specs, the solver's options; and "
     "the errors robrst raises on bad input.",
     ["robrst.load_problem", "robrst.parse_problem", "robrst.check_problem", "robrst.Problem",
      "robrst.Specs",
      "robrst.PoleSpec", "robrst.ControllerStructure", "robrst.SolverOptions",
      "robrst.RobrstError", "robrst.SpecError", "robrst.DegreeError", "robrst.CoprimeError",
      "robrst.DataError", "robrst.SolverError", "robrst.InfeasibleError",
      "robrst.OutputError"]),
    ("plants", "Plants, controllers and analysis",
     "Plants and their thermal families, the RST controller, pole placement and the "
     "analysis of one loop.",
     ["robrst.Plant", "robrst.paper_plant", "robrst.PlantFamily", "robrst.parametric_family",
      "robrst.explicit_family", "robrst.ThermalCoefficients", "robrst.sampled_plant",
      "robrst.RSTController", "robrst.pole_placement", "robrst.discretize",
      "robrst.tustin_polynomials", "robrst.closed_loop_control", "robrst.analyze",
      "robrst.peak_gain"]),
    ("design", "Design",
     "The design pipeline: a problem in, a certified design (or the best controller found "
     "and what binds) out.",
     ["robrst.run_problem", "robrst.DesignResult", "robrst.design.analytic_design",
      "robrst.design.with_time_domain", "robrst.Synthesizer"]),
    ("certificate", "Certificates and the controller out",
     "What a certificate proves over the temperature interval, saved designs certified "
     "again, and the digital controller that goes to hardware (sections, C, Python, JSON).",
     ["robrst.certify", "robrst.certify_problem", "robrst.certificate.proof.Certificate",
      "robrst.step_metrics", "robrst.load_design", "robrst.recertify",
      "robrst.digital_controller", "robrst.DigitalController", "robrst.export_controller",
      "robrst.ExportedController"]),
    ("multi-axis", "Multi-axis actuators",
     "Coupled stacks: MIMO plants and families, the decentralised controller with its "
     "decoupler, designed jointly and certified on the largest singular values.",
     ["robrst.load_mimo_problem", "robrst.MimoProblem", "robrst.MimoPlant",
      "robrst.MimoFamily", "robrst.MimoSpecs", "robrst.MimoStructure",
      "robrst.MimoSolverOptions", "robrst.MimoController", "robrst.design_mimo",
      "robrst.MimoDesignResult", "robrst.certify_mimo", "robrst.export_mimo"]),
    ("twin", "Twin and records",
     "The digital twin of the actuator (every effect switchable) and the record format.",
     ["robrst.default_twin", "robrst.load_twin", "robrst.simulate",
      "robrst.twin.TwinConfig", "robrst.twin.SimResult", "robrst.Dataset",
      "robrst.load_dataset", "robrst.save_dataset"]),
    ("identify", "Identification and diagnosis",
     "Linear models from records, and the diagnosis of the gap between the twin and the "
     "bench.",
     ["robrst.identify.identification.identify", "robrst.diagnose.diagnose",
      "robrst.diagnose.Diagnosis"]),
    ("studies", "Sweeps and fleets",
     "Monte Carlo, trade-offs and fleets on Dask.",
     ["robrst.load_sweep", "robrst.Sweep", "robrst.run_sweep", "robrst.SweepResult",
      "robrst.studies.fleet.verify_fleet"]),
    ("testing", "Regression tests and reports",
     "Margin regression tests in your CI, and the reports.",
     ["robrst.assert_margins", "robrst.testing.write_golden", "robrst.testing.compare_golden",
      "robrst.write_design_report", "robrst.write_sweep_report",
      "robrst.write_diagnosis_report"]),
)


def resolve(dotted):
    """The object a dotted name imports (``robrst.Plant``, ``robrst.diagnose.diagnose``)."""
    parts = dotted.split(".")
    for cut in range(len(parts) - 1, 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for p in parts[cut:]:
            obj = getattr(obj, p)
        return obj
    raise ImportError(dotted)


def api_page(title, intro, names):
    """The reStructuredText source of one task page (autodoc is reST-native)."""
    lines = [title, "=" * len(title), "", intro, "", ".. autosummary::", "",
             *(f"   {n}" for n in names), ""]
    for n in names:
        obj = resolve(n)
        if inspect.isclass(obj):
            lines += [f".. autoclass:: {n}", "   :members:", ""]
        else:
            lines += [f".. autofunction:: {n}", ""]
    return "\n".join(lines)


def write_api_pages(app):
    """Write ``api/<page>.rst`` for every task page (only when changed)."""
    out = Path(app.srcdir) / "api"
    out.mkdir(parents=True, exist_ok=True)
    wanted = {f"{f}.rst" for f, *_ in API_PAGES}
    for old in out.glob("*.rst"):          # a page a former table wrote (all are generated)
        if old.name not in wanted:
            old.unlink()
    for fname, title, intro, names in API_PAGES:
        path = out / f"{fname}.rst"
        text = api_page(title, intro, names)
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")


class Pages(SphinxDirective):
    """``{robrst-api-pages}``: the toctree of the task pages."""

    has_content = False

    def run(self):
        text = ["```{toctree}", ":maxdepth: 1", "", *(f for f, *_ in API_PAGES), "```"]
        box = nodes.container(classes=["robrst-api-pages"])
        self.state.nested_parse(StringList(text, "<robrst-api-pages>"), self.content_offset, box)
        return box.children


class Face(SphinxDirective):
    """``{robrst-face}``: a summary table of ``robrst.__all__``, linked to its task page."""

    has_content = False

    def run(self):
        import robrst
        rows = []
        for name in robrst.__all__:
            obj = getattr(robrst, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                rows.append(f"robrst.{name}")
        box = nodes.container(classes=["robrst-face"])
        text = ["```{eval-rst}", ".. autosummary::", "", *(f"   {r}" for r in rows), "```"]
        self.state.nested_parse(StringList(text, "<robrst-face>"), self.content_offset, box)
        return box.children


class Output(SphinxDirective):
    """``{robrst-output} design my_stage.toml``: the command run at build time, its standard
    output shown as a text block (so a shown output cannot go stale).  It runs in
    ``docs/examples`` (``:cwd:`` relative to the docs' source folder); exit codes 0 and 1
    (certified or not) are outputs, 2 (an error) fails the build."""

    required_arguments = 1
    final_argument_whitespace = True
    option_spec = {"cwd": str}

    def run(self):
        from robrst.cli import main

        args = shlex.split(self.arguments[0])
        cwd = Path(self.env.srcdir) / self.options.get("cwd", "examples")
        out, here = io.StringIO(), Path.cwd()
        try:
            os.chdir(cwd)
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
                code = main(args)
        finally:
            os.chdir(here)
        if code not in (0, 1):
            raise self.error(f"robrst {self.arguments[0]} exited {code}")
        block = nodes.literal_block(out.getvalue(), out.getvalue().rstrip("\n"))
        block["language"] = "text"
        return [block]


def setup(app):
    app.add_directive("robrst-output", Output)
    app.add_directive("robrst-schema", SchemaTable)
    app.add_directive("robrst-face", Face)
    app.add_directive("robrst-api-pages", Pages)
    app.connect("builder-inited", write_api_pages)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
