"""The driver's preparation of a sweep: base problem, controller, fleet files, variants.

Everything a worker needs is gathered here once, in the process that runs the sweep, into a
:class:`~robrst.sweep.evaluate.SweepContext`; every input that can be wrong (the base
problem, ``[set]``, the result file, the fleet folder, plant factors the base model cannot
take) is checked here, so a bad sweep is one clear error before any work starts.  The
fingerprint identifies the sweep's results: the validated sweep, the bytes of every input
file and the robrst version.
"""

import copy
import hashlib
import json
from dataclasses import asdict, replace
from pathlib import Path

from robrst import __version__
from robrst.errors import RobrstError, SolverError, SpecError
from robrst.rst import RSTController
from robrst.schema import Field, key_error, load_toml, validate
from robrst.spec import parse_problem
from robrst.sweep.evaluate import SweepContext
from robrst.sweep.model import apply_overrides, check_plant_params
from robrst.sweep.variants import variant_table

__all__ = ["prepare", "read_controller", "fingerprint"]

_RST = {k: Field("numbers", None, f"{k} coefficients, highest power first", required=True)
        for k in "RST"}


def read_controller(path):
    """The RST controller of a result file (``robrst design --json``, ``result.json``).

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SpecError(f"{path}: result file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: cannot read the result file ({exc})") from None
    except ValueError as exc:
        raise SpecError(f"{path}: invalid JSON ({exc})") from None
    if not isinstance(d, dict) or "controller" not in d:
        raise key_error(path, ("controller",), "missing: expected the JSON of robrst design"
                        " --json with controller{R, S, T}")
    c = validate(path, d["controller"], _RST, ("controller",))
    try:
        return RSTController(*(c[k] for k in "RST"))
    except SpecError as exc:
        raise key_error(path, ("controller",), str(exc)) from None


def _no_compare(doc):
    """A sweep never runs the analytic comparison of ``compare_with``."""
    doc = copy.deepcopy(doc)
    if isinstance(doc.get("solver"), dict):
        doc["solver"].pop("compare_with", None)
    return doc


def _base(sweep):
    original = _no_compare(load_toml(sweep.problem, "problem file"))
    doc = apply_overrides(original, sweep.overrides)
    try:
        base = parse_problem(doc, sweep.problem)
    except SpecError as exc:
        if not sweep.overrides:
            raise
        raise SpecError(f"{sweep.path}: [set] makes the base problem invalid: {exc}") from None
    return original, doc, base


def _controller(sweep, original):
    if sweep.controller == "design":
        from robrst.design import run_problem

        try:
            return run_problem(parse_problem(original, sweep.problem)).controller
        except RobrstError as exc:
            raise SolverError(f"{sweep.path}: the design of the base problem failed, so there"
                              f" is no controller to analyse: {exc}") from None
    try:
        return read_controller(Path(sweep.path).parent / sweep.controller)
    except SpecError as exc:
        raise key_error(sweep.path, ("analysis", "controller"), str(exc)) from None


def _fleet(sweep):
    folder = Path(sweep.path).parent / sweep.folder
    if not folder.is_dir():
        raise key_error(sweep.path, ("fleet", "folder"), f"{folder} is not a folder")
    files = sorted(p for p in folder.glob(sweep.pattern) if p.is_file())
    if not files:
        raise key_error(sweep.path, ("fleet", "folder"),
                        f"no file matching {sweep.pattern!r} in {folder}")
    out = []
    for p in files:
        try:
            out.append((str(p), load_toml(p, "problem file"), None))
        except SpecError as exc:     # recorded as that member's row
            out.append((str(p), None, str(exc)))
    return tuple(out), files


def _stable(x):
    """``x`` with every float rounded to 12 significant digits: derived values (a grid's
    geometric points) may differ in the last bits between numpy versions."""
    if isinstance(x, float):
        return float(f"{x:.12g}")
    if isinstance(x, dict):
        return {k: _stable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_stable(v) for v in x]
    return x


def fingerprint(sweep, files):
    """SHA-256 of the validated sweep (floats to 12 digits), the input files' bytes and
    the robrst version."""
    d = asdict(sweep)
    for k in ("path", "description", "problem", "worst"):
        d.pop(k)
    h = hashlib.sha256(json.dumps(_stable(d), sort_keys=True, default=str).encode())
    for f in files:
        h.update(Path(f).read_bytes())
    h.update(__version__.encode())
    return h.hexdigest()


def prepare(sweep):
    """The context and the variant table of ``sweep``.

    Returns
    -------
    (SweepContext, VariantTable)

    Raises
    ------
    SpecError
        A bad base problem, ``[set]``, result file, fleet folder or parameter.
    """
    files = [f for f in (sweep.path, sweep.problem) if f and Path(f).is_file()]
    original = doc = base = controller = None
    fleet, labels = (), ()
    if sweep.problem:
        original, doc, base = _base(sweep)
        check_plant_params(sweep.params, base.family, sweep.path)
    if sweep.kind == "analysis":
        if sweep.controller != "design":
            files.append(Path(sweep.path).parent / sweep.controller)
        controller = _controller(sweep, original)
    if sweep.kind == "fleet":
        fleet, paths = _fleet(sweep)
        files += paths
        labels = tuple(Path(label).name for label, _, _ in fleet)
    table = variant_table(sweep, labels)
    ctx = SweepContext(sweep=sweep, names=table.names, base=base, doc=doc,
                       controller=controller, fleet=fleet)
    return replace(ctx, fingerprint=fingerprint(sweep, files)), table
