"""The documentation (``docs/``): its examples run as written, its links resolve, and the file
references are generated from the schemas the readers validate with.

Every ```` ```python ```` block of a page runs, in order and in one namespace, in a fresh
folder holding ``docs/examples/*`` (so ``load_problem("my_stage.toml")`` works as the page
says); a page's check then tests what its text claims. Blocks written as
```` ```{code-block} python ```` are shown, not run (Dask's ``__main__`` guard). ``.ci/run``
also builds the site with warnings as errors (``sphinx-build -W``).
"""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).parents[2]
DOCS = ROOT / "docs"
PAGES = sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)


def python_blocks(path):
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def run_page(path, folder):
    for f in (DOCS / "examples").iterdir():
        shutil.copy(f, folder / f.name)
    ns = {"__name__": "docs_example"}
    for i, code in enumerate(python_blocks(path)):
        exec(compile(code, f"{path.relative_to(ROOT)} (block {i + 1})", "exec"), ns)  # noqa: S102
    return ns


def setup_ci(folder):
    """The CI recipe's first step: the golden written by ``robrst check --update``."""
    from robrst.base.resources import problems_dir
    from robrst.cli import main

    (folder / "my_problem.toml").write_text((problems_dir() / "paper.toml").read_text())
    assert main(["check", "my_problem.toml", "--golden", "tests/golden/my_problem.toml",
                 "--update", "--quiet"]) == 0


def check_python(ns):
    assert ns["a"].stable and ns["d"].cond < 1e3 and ns["result"].certified
    assert (ns["folder"] / "report.md").is_file()
    assert ns["second"].certified and ns["second"].integral_gain < ns["first"].integral_gain
    # python-control's modulus margin of the sampled loop is robrst's certified Ms
    assert 1 / ns["sm"] == pytest.approx(ns["result"].certificate.worst("Ms_sampled"), rel=1e-6)


def check_diagnose(ns):
    assert ns["diag"].cause == "hysteresis" and ns["diag"].winner.shrink > 0.99
    for k, v in ns["truth"]["params"].items():            # fit_effects: hidden values recovered
        assert ns["est"].params[k] == pytest.approx(v, rel=1e-2), k


def check_identify(ns):
    """Order 3 and the poles of the paper's D(s): s + 651 and s^2 + 42 s + 1.5e7."""
    assert ns["fit"].order == 3 and ns["fit"].heldout_nrmse < 1e-3
    poles = np.sort_complex(ns["fit"].model.poles)
    pair = poles[np.argmax(poles.imag)]
    assert np.min(np.abs(poles.real + 651.0)) < 0.01 * 651.0
    assert abs(pair) ** 2 == pytest.approx(1.5e7, rel=0.01)
    assert -2 * pair.real == pytest.approx(42.0, rel=0.05)


def check_certify(ns):
    assert not ns["cert"].certified and ns["worst"].quantity == "settling_time_s"
    assert set(k for k, r in ns["cert"].ratios().items() if r > 1) == {
        "settling_time_s", "settling_time_s_sampled"}
    assert ns["worst"].value == pytest.approx(0.01036, abs=1e-5)     # "10.36 ms"


def check_export(ns):
    assert ns["exp"].certified and ns["exp"].recommended == "sections_float32"
    assert "robrst_ctrl_step" in ns["header"] and ns["source"]
    assert all(np.isfinite(ns["ctrl"].step(1.0, 0.0)) for _ in range(3))


def check_multi_axis(ns):
    """Certified, and python-control's sampled loop (ZOH plant, Tustin controller) agrees:
    stable, its sigma_max(S) on a dense grid within the certified peak."""
    import control

    res, G = ns["result"], control.ss(ns["G"])
    assert res.certified and res.certificate.worst("sigma_S", "sampled") <= 2.0 * (1 + 1e-3)
    ax, W = res.controller.axes, res.controller.decoupler
    K = control.ss([], [], [], W) * control.ss(control.tf(
        [[list(ax[j].R) if i == j else [0.0] for j in range(2)] for i in range(2)],
        [[list(ax[j].S) if i == j else [1.0] for j in range(2)] for i in range(2)]))
    Gd, Kd = control.c2d(G, 1 / 20e3, "zoh"), control.c2d(K, 1 / 20e3, "tustin")
    S = control.feedback(control.ss([], [], [], np.eye(2), Gd.dt), Gd * Kd)
    assert np.all(np.abs(S.poles()) < 1)
    H = control.frequency_response(S, np.geomspace(1.0, 0.9999 * np.pi * 20e3, 4000)).complex
    grid = np.linalg.svd(np.moveaxis(H, -1, 0), compute_uv=False)[:, 0].max()
    assert grid <= res.certificate.worst("sigma_S", "sampled") * (1 + 1e-6)


CHECKS = {
    "guide/multi-axis.md": check_multi_axis,
    "guide/design.md": lambda ns: ns["result"].certified,
    "guide/poles-and-degrees.md": lambda ns: ns["result"].certified,
    "guide/certify.md": check_certify,
    "guide/export.md": check_export,
    "guide/ci.md": lambda ns: ns["test_margins_did_not_get_worse"]() is None,
    "guide/sweeps.md": lambda ns: ns["mc"].summary["yield"] >= 0.9,
    "guide/twin.md": lambda ns: ns["record"].t.size == 10_000,
    "guide/identify.md": check_identify,
    "guide/diagnose.md": check_diagnose,
    "guide/python.md": check_python,
}
SETUP = {"guide/ci.md": setup_ci}
RUNNABLE = [p for p in PAGES if python_blocks(p)]
# the pages whose examples design with the NLP, identify or diagnose (7-80 s each) run with
# -m slow (.ci/run)
SLOW_PAGES = {"guide/export.md", "guide/python.md", "guide/multi-axis.md",
              "guide/poles-and-degrees.md", "guide/design.md", "guide/identify.md",
              "guide/diagnose.md"}


def test_every_runnable_page_has_a_check():
    assert sorted(str(p.relative_to(DOCS)) for p in RUNNABLE) == sorted(CHECKS)
    assert SLOW_PAGES <= set(CHECKS)


@pytest.mark.parametrize("page", [
    pytest.param(p, id=str(p.relative_to(DOCS)),
                 marks=[pytest.mark.slow] if str(p.relative_to(DOCS)) in SLOW_PAGES else [])
    for p in RUNNABLE])
def test_the_examples_of_a_page_run(page, tmp_path, monkeypatch):
    name = str(page.relative_to(DOCS))
    monkeypatch.chdir(tmp_path)
    if name in SETUP:
        SETUP[name](tmp_path)
    ns = run_page(page, tmp_path)
    assert CHECKS[name](ns) is not False


def test_the_c_snippet_is_the_export_guides():
    """tests/controller/test_export_c.py compiles the guide's C snippet with the exported code."""
    text = (DOCS / "guide" / "export.md").read_text(encoding="utf-8")
    assert "```c\n#include \"ctrl.h\"" in text


LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")


@pytest.mark.parametrize("path", [*PAGES, ROOT / "README.md", ROOT / "CHANGELOG.md",
                                  ROOT / "reports" / "benchmark-history.md"],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_and_images_resolve(path):
    text = path.read_text(encoding="utf-8")
    bad = []
    for target in LINK.findall(text) + re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text):
        if target.startswith(("http://", "https://", "mailto:")):
            continue
        file, _, anchor = target.partition("#")
        if file and not (path.parent / file).exists():
            bad.append(target)
    for m in re.finditer(r"```\{literalinclude\} (\S+)", text):
        if not (path.parent / m.group(1)).exists():
            bad.append(m.group(1))
    assert bad == []


# -- the file references: generated at build time, never copied ---------------------------

SCHEMA_PAGES = {"problem": "reference/problem-files.md", "sweep": "reference/sweep-files.md",
                "twin": "reference/twin-files.md", "scenario": "reference/scenario-files.md"}


def schema_rows(kind):
    """The rows the readers' own schema declarations give (independent of the docs' code)."""
    from robrst.base.schema import markdown_rows
    from robrst.problem.files import schema_markdown
    from robrst.studies.sweep.files import sweep_schema_markdown
    from robrst.studies.user_scenario import SCENARIO_SCHEMA
    from robrst.twin.config import TWIN_SCHEMA

    return {"problem": schema_markdown, "sweep": sweep_schema_markdown,
            "twin": lambda: markdown_rows(TWIN_SCHEMA),
            "scenario": lambda: markdown_rows(SCENARIO_SCHEMA)}[kind]()


@pytest.mark.parametrize("kind", sorted(SCHEMA_PAGES))
def test_each_file_reference_is_generated_from_its_schema(kind):
    """The reference page renders the schema at build time (the ``robrst-schema`` directive of
    ``docs/_ext``), and no page carries a hand-copied row that could go stale (skipped
    without the ``docs`` extra: the extension imports Sphinx; ``.ci/run`` installs it)."""
    import sys

    pytest.importorskip("sphinx")
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        import robrst_docs
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    page = (DOCS / SCHEMA_PAGES[kind]).read_text(encoding="utf-8")
    assert f"```{{robrst-schema}} {kind}\n```" in page
    rows = schema_rows(kind)
    assert robrst_docs.schema_rows(kind) == rows and len(rows) > 10
    for other in PAGES:
        text = other.read_text(encoding="utf-8")
        assert not [r for r in rows if r in text], other


def test_the_references_render_as_tables(tmp_path):
    """Build the reference pages with Sphinx and compare every rendered row with the
    schema's (skipped without the ``docs`` extra; ``.ci/run`` installs it)."""
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    import html

    from sphinx.application import Sphinx

    src = tmp_path / "src"
    (src / "_ext").mkdir(parents=True)
    shutil.copy(DOCS / "_ext" / "robrst_docs.py", src / "_ext")
    (src / "conf.py").write_text(
        "import sys, pathlib\nsys.path.insert(0, str(pathlib.Path(__file__).parent / '_ext'))\n"
        "extensions = ['myst_parser', 'robrst_docs']\nsmartquotes = False\n")
    names = []
    for kind, rel in SCHEMA_PAGES.items():
        text = (DOCS / rel).read_text(encoding="utf-8")
        body = text[text.index("```{robrst-schema}"):]
        (src / f"{kind}.md").write_text(f"# {kind}\n\n{body}")
        names.append(kind)
    (src / "index.md").write_text("# refs\n\n```{toctree}\n" + "\n".join(names) + "\n```\n")
    app = Sphinx(str(src), str(src), str(tmp_path / "out"), str(tmp_path / "doctrees"), "html",
                 status=None, warning=None, freshenv=True, warningiserror=True)
    app.build()
    for kind in names:
        out = (tmp_path / "out" / f"{kind}.html").read_text(encoding="utf-8")
        body = out[out.index("<tbody"):out.index("</tbody>")]
        cells = [[html.unescape(re.sub(r"<[^>]+>", "", c)).strip() for c in
                  re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]
                 for row in re.findall(r"<tr[^>]*>(.*?)</tr>", body, re.S)]
        want = [[re.sub(r"`|\\(?=\|)", "", c).strip() for c in r.strip("|").split(" | ")]
                for r in schema_rows(kind)]
        assert cells == want, kind


# -- the API reference: a few pages by task, every name of the face on exactly one -----------

def test_the_api_reference_is_a_few_task_pages_covering_the_face():
    """At most ten API pages (the index and the task pages); every function and class of
    ``robrst.__all__`` documented on exactly one, by the name users import it with; no
    object documented twice (Sphinx would warn of a duplicate description)."""
    import importlib
    import inspect
    import runpy

    import robrst

    ext = runpy.run_path(str(DOCS / "_ext" / "robrst_docs.py"), run_name="robrst_docs_check") \
        if importlib.util.find_spec("sphinx") else None
    if ext is None:
        pytest.skip("the docs extension imports Sphinx (the docs extra)")
    pages = ext["API_PAGES"]
    assert 1 + len(pages) <= 10
    listed = [n for *_, names in pages for n in names]
    objs = [ext["resolve"](n) for n in listed]
    assert len({id(o) for o in objs}) == len(objs)          # each object once
    face = {f"robrst.{n}" for n in robrst.__all__
            if inspect.isfunction(getattr(robrst, n)) or inspect.isclass(getattr(robrst, n))}
    assert face - set(listed) == set()
    # a subpackage name is never the same object as a face name (it would be shown twice)
    face_ids = {id(getattr(robrst, n.split(".", 1)[1])) for n in face}
    assert not [n for n, o in zip(listed, objs) if n not in face and id(o) in face_ids]


SOURCE_POINTER = re.compile(r"(docs/[A-Za-z0-9_/.-]+\.md)(?:,\s*|\s*\(|\s+)?(?:\"([^\"\n]+)\")?")


def _headings(page):
    return {line.lstrip("#").strip() for line in page.read_text().splitlines()
            if line.startswith("#")}


def test_the_package_points_to_pages_and_sections_that_exist():
    """Every ``docs/...md`` a message, a docstring or a generated file of the package names
    exists, and a quoted section after it is one of that page's headings (the README
    is a front page: the guide's sections live in docs/, and a pointer into a README
    section that moved is a dead end for the user who reads it in a C header)."""
    found = []
    for src in sorted((ROOT / "robrst").rglob("*.py")):
        text = re.sub(r"\s*\n\s*\*?\s*", " ", src.read_text())    # wrapped comments joined
        for m in SOURCE_POINTER.finditer(text):
            page = ROOT / m.group(1)
            assert page.is_file(), (src.name, m.group(1))
            if m.group(2):
                assert m.group(2) in _headings(page), (src.name, m.group(1), m.group(2))
            found.append(m.group(1))
        assert not re.search(r"README(?:'s)?,? \"", text), (src.name, "a README section")
    assert found
