"""The architecture as a test: imports point down the layers, never in a cycle.

Layers are folders of the package, bottom to top (docs: "Architecture")::

    base          robrst.base: errors, schema, tomlwrite, fileio, resources, threads
    maths core    robrst.core: poly, lti, plant, thermal, family, rst, peaks (+ private
                  level-set kernels), analysis, sampled, interval
    problem       robrst.problem: specs (the spec table), records, files, checks, documents,
                  spread
    certificate   robrst.certificate: figures, statement, models, proof, steps (+ private
                  step kernels), completion, assessment
    synthesis     robrst.synthesis (synthesis records only: no DesignResult)
    design        robrst.design: achieved, result, contract, candidate, multistart, _single,
                  fleet, _pipeline
    modelling     robrst.data, robrst.twin, robrst.identify, robrst.diagnose
                  (on base + maths core only)
    controller    robrst.controller: digital sections, implementation, export (C, Python)
                  (above design; the twin's amplifier range is its default)
    studies       robrst.studies: the paper's scenarios, sweeps
    presentation  robrst.report, robrst.cli, robrst.testing, the package face

Every ``import`` of a robrst module counts, at module level or inside a function body.
"""

import ast
import functools
from pathlib import Path


PKG = Path(__file__).resolve().parents[2] / "robrst"

LAYERS = {
    "base": ("robrst.base",),
    "maths": ("robrst.core",),
    "problem": ("robrst.problem",),
    "certificate": ("robrst.certificate",),
    "synthesis": ("robrst.synthesis",),
    "design": ("robrst.design",),
    "controller": ("robrst.controller",),
    "modelling": ("robrst.twin", "robrst.data", "robrst.diagnose", "robrst.identify"),
    "studies": ("robrst.studies",),
    "presentation": ("robrst.report", "robrst.cli", "robrst.testing", "robrst.__main__", "robrst"),
}
ORDER = ("base", "maths", "problem", "certificate", "synthesis", "design", "controller")
ALLOWED = {name: set(ORDER[:i + 1]) for i, name in enumerate(ORDER)}
ALLOWED["modelling"] = {"base", "maths", "modelling"}
ALLOWED["controller"] |= {"modelling"}     # the amplifier range of the twin's actuator
ALLOWED["studies"] = set(ORDER) | {"modelling", "studies"}
ALLOWED["presentation"] = set(LAYERS)


def module_name(path):
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in PKG.rglob("*.py")}


def layer_of(mod):
    best = None
    for layer, prefixes in LAYERS.items():
        for pre in prefixes:
            if (mod == pre or mod.startswith(pre + ".")) and (best is None or len(pre) > best[1]):
                best = (layer, len(pre))
    return best[0] if best else None


@functools.cache
def tree_of(mod):
    """The syntax tree of ``mod``, parsed once for every check of the file."""
    return ast.parse(MODULES[mod].read_text(encoding="utf-8"))


@functools.cache
def imports_of(mod):
    """robrst modules imported by ``mod`` (anywhere in the file), with line numbers."""
    tree = tree_of(mod)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] != "robrst":
                continue
            subs = [f"{node.module}.{a.name}" for a in node.names
                    if f"{node.module}.{a.name}" in MODULES]
            if subs:
                out += [(s, node.lineno) for s in subs]
            if len(subs) < len(node.names):
                out.append((node.module, node.lineno))
        elif isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.split(".")[0] == "robrst"]
    return tuple((t, line) for t, line in out if t != mod and not mod.startswith(t + "."))


def test_every_module_has_a_layer():
    assert [m for m in MODULES if layer_of(m) is None] == []


def test_no_import_points_up_a_layer():
    bad = []
    for mod in MODULES:
        src = layer_of(mod)
        for target, line in imports_of(mod):
            dst = layer_of(target)
            if dst not in ALLOWED[src]:
                bad.append(f"{mod}:{line} ({src}) imports {target} ({dst})")
    assert bad == []


def test_no_import_cycle():
    graph = {m: {t for t, _ in imports_of(m) if t in MODULES} for m in MODULES}
    state, cycles = {}, []

    def visit(v, path):
        state[v] = "open"
        for w in graph[v]:
            if state.get(w) == "open":
                cycles.append(" -> ".join(path[path.index(w):] + [w]))
            elif w not in state:
                visit(w, path + [w])
        state[v] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert cycles == []


def test_no_private_name_across_modules():
    bad = []
    for mod in MODULES:
        for node in ast.walk(tree_of(mod)):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                    and node.module.startswith("robrst"):
                bad += [f"{mod} takes {node.module}.{a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    assert bad == []


def test_the_package_root_holds_only_the_face():
    """Every module lives in its layer's folder; the root keeps the face."""
    root = sorted(p.name for p in PKG.glob("*.py"))
    assert root == ["__init__.py", "__main__.py", "testing.py"]


def test_no_synthesis_module_knows_the_design_record():
    """Synthesis modules return synthesis records: none imports the design layer."""
    bad = [f"{mod}:{line} imports {t}" for mod in MODULES if layer_of(mod) == "synthesis"
           for t, line in imports_of(mod) if layer_of(t) == "design"]
    assert bad == []


def test_the_architecture_page_lists_every_module():
    """docs/background/architecture.md's tree names every module of the package."""
    page = (PKG.parent / "docs" / "background" / "architecture.md").read_text(encoding="utf-8")
    tree = page.split("## Every module", 1)[1].split("```", 2)[1]
    listed, stack = set(), []
    for line in tree.splitlines():
        if not line.strip() or line.strip() == "robrst/":
            continue
        name = line.split()[0]
        depth = (len(line) - len(line.lstrip())) // 2 - 1
        stack = stack[:depth]
        if name.endswith("/"):
            stack.append(name[:-1])
            listed.add(".".join(["robrst", *stack]))
        else:
            listed.add(".".join(["robrst", *stack, name[:-3]]))
    assert sorted(set(MODULES) - listed - {"robrst"}) == []
    assert sorted(listed - set(MODULES)) == []


def test_private_modules_stay_in_their_package():
    """A ``_kernel`` module is imported only by modules of its own folder (its package's
    ``__init__`` included: public by re-export)."""
    bad = []
    for mod in MODULES:
        for target, line in imports_of(mod):
            leaf = target.rsplit(".", 1)[-1]
            if leaf.startswith("_") and not leaf.startswith("__") \
                    and target.rsplit(".", 1)[0] not in (mod.rsplit(".", 1)[0], mod):
                bad.append(f"{mod}:{line} imports {target}")
    assert bad == []


def _public_by_use():
    """Public modules (not packages) that nothing outside their folder uses: no other
    folder imports them, the face does not re-export from them, no guide, reference page
    or the README names them."""
    docs = [p for p in (PKG.parent / "docs").rglob("*") if p.suffix in (".md", ".rst", ".py")
            and "_build" not in p.relative_to(PKG.parent / "docs").parts]
    text = "\n".join(p.read_text(encoding="utf-8") for p in docs + [PKG.parent / "README.md"])
    face = (PKG / "__init__.py").read_text(encoding="utf-8")
    used = {t for m in MODULES for t, _ in imports_of(m)
            if t.rsplit(".", 1)[0] not in (m.rsplit(".", 1)[0], m)}
    out = []
    for mod, path in MODULES.items():
        leaf = mod.rsplit(".", 1)[-1]
        if path.name == "__init__.py" or leaf.startswith("_") or mod == "robrst.testing":
            continue
        named = any(f"{mod}{end}" in text for end in (".", "`", " ", ":", ")", ",", "\n")) or \
            str(path.relative_to(PKG.parent)) in text or f'"{mod}"' in face
        if mod not in used and not named:
            out.append(mod)
    return out


def test_modules_are_private_by_default():
    """A module used only inside its own folder (and named by no page) is a ``_kernel``:
    the face is what other layers, the docs and ``import robrst`` use."""
    assert _public_by_use() == []


def test_the_layering_test_can_fail():
    """An upward import is caught: the checker is not vacuous."""
    assert layer_of("robrst.certificate.proof") == "certificate"
    assert "design" not in ALLOWED[layer_of("robrst.synthesis.robust")]
    assert "problem" not in ALLOWED[layer_of("robrst.twin.model")]
