"""The driver's preparation of a sweep: base problem, controller, fleet files, variants.

Everything a worker needs is gathered here once, in the process that runs the sweep, into a
:class:`~robrst.studies.sweep._evaluate.SweepContext`; every input that can be wrong (the base
problem, ``[set]``, the result file, the fleet folder, plant factors the base model cannot
take) is checked here, so a bad sweep is one clear error before any work starts.  The
fingerprint identifies the sweep's results: the validated sweep, the bytes of every input
file, the coefficients of a controller designed for the sweep and the robrst version.
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
from collections.abc import Iterable
from dataclasses import asdict, fields, is_dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robrst import __version__
from robrst.base.errors import RobrstError, SolverError, SpecError
from robrst.base.fileio import MAX_TOML_BYTES, read_utf8
from robrst.core.mimo_loop import MimoController
from robrst.core.rst import RSTController
from robrst.base.schema import Field, key_error, load_toml, validate
from robrst.problem.files import parse_problem
from robrst.studies.sweep._evaluate import SweepContext
from robrst.studies.sweep._mimo import check_mimo_params
from robrst.studies.sweep._model import apply_overrides, check_plant_params
from robrst.studies.sweep._variants import variant_table

if TYPE_CHECKING:
    from robrst.studies.sweep.files import Sweep
    from robrst.studies.sweep._variants import VariantTable

__all__ = ["prepare", "read_controller", "read_mimo_controller", "fingerprint",
           "member_document"]

_RST = {k: Field("numbers", None, f"{k} coefficients, highest power first", required=True)
        for k in "RST"}


def read_controller(path: str | Path) -> RSTController:
    """The RST controller of a result file (``robrst design --json``, ``result.json``).

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file.

    Returns
    -------
    RSTController

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    d = _result(path)
    if "controller" not in d:
        raise key_error(path, ("controller",), "missing: expected the JSON of robrst design"
                        " --json with controller{R, S, T}")
    c = validate(path, d["controller"], _RST, ("controller",))
    for k in "RST":
        if not c[k]:
            raise key_error(path, ("controller", k), "expected at least one coefficient"
                            " (highest power first), got []")
    try:
        return RSTController(*(c[k] for k in "RST"))
    except (SpecError, ValueError) as exc:
        raise key_error(path, ("controller",), str(exc)) from None


def read_mimo_controller(path: str | Path) -> MimoController:
    """The multi-axis controller of a result file (``robrst design FILE --json`` of a
    ``[mimo]`` problem).

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file.

    Returns
    -------
    MimoController

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    d = _result(path)
    if d.get("kind") != "mimo" or "controller" not in d:
        raise key_error(path, ("controller",), "expected the JSON of robrst design --json on"
                        " a multi-axis problem (kind = \"mimo\", controller{axes, decoupler})")
    try:
        return MimoController.from_dict(d["controller"])
    except (SpecError, ValueError) as exc:
        raise key_error(path, ("controller",), str(exc)) from None


def _result(path):
    """The JSON object of a result file (an error naming the file otherwise)."""
    text = read_utf8(Path(path), "result file", "JSON", SpecError, limit=MAX_TOML_BYTES)
    try:
        d = json.loads(text)
    except ValueError as exc:
        raise SpecError(f"{path}: invalid JSON ({exc})") from None
    if not isinstance(d, dict):
        raise SpecError(f"{path}: expected a JSON object (the output of robrst design --json)")
    return d


def _no_compare(doc):
    """A sweep never runs the analytic comparison of ``compare_with``."""
    doc = copy.deepcopy(doc)
    if isinstance(doc.get("solver"), dict):
        doc["solver"].pop("compare_with", None)
    return doc


def _parse(sweep, doc):
    """The base problem of ``doc``: a multi-axis or a single-axis problem file's."""
    if sweep.mimo:
        from robrst.problem.mimo_files import parse_mimo

        return parse_mimo(doc, sweep.problem)
    return parse_problem(doc, sweep.problem)


def _base(sweep):
    original = _no_compare(load_toml(sweep.problem, "problem file"))
    doc = apply_overrides(original, sweep.overrides)
    try:
        base = _parse(sweep, doc)
    except SpecError as exc:
        if not sweep.overrides:
            raise
        raise SpecError(f"{sweep.path}: [set] makes the base problem invalid: {exc}") from None
    return original, doc, base


def _controller(sweep, original):
    if sweep.controller == "design":
        try:
            if sweep.mimo:
                from robrst.design.mimo import design_mimo

                return design_mimo(_parse(sweep, original), compare=False).controller
            from robrst.design import run_problem

            return run_problem(parse_problem(original, sweep.problem)).controller
        except RobrstError as exc:
            raise SolverError(f"{sweep.path}: the design of the base problem failed, so there"
                              f" is no controller to analyse: {exc}") from None
    read = read_mimo_controller if sweep.mimo else read_controller
    try:
        return read(Path(sweep.path).parent / sweep.controller)
    except SpecError as exc:
        raise key_error(sweep.path, ("analysis", "controller"), str(exc)) from None


def _fleet(sweep):
    """``(members, files, broken)``: per name matching the pattern ``(path, document or
    None, error or None)``; the readable files (fingerprinted); the names that are no file
    (a folder, a broken link), each an ``invalid`` row naming it."""
    folder = Path(sweep.path).parent / sweep.folder
    if not folder.is_dir():
        raise key_error(sweep.path, ("fleet", "folder"), f"{folder} is not a folder")
    names = sorted(folder.glob(sweep.pattern))
    if not names:
        raise key_error(sweep.path, ("fleet", "folder"),
                        f"no file matching {sweep.pattern!r} in {folder}")
    out = []
    for p in names:
        try:
            out.append((str(p), member_document(p), None))
        except SpecError as exc:     # recorded as that member's row
            out.append((str(p), None, str(exc)))
    files = [p for p in names if p.is_file()]
    return tuple(out), files, [p.name for p in names if not p.is_file()]


def member_document(path: Path) -> dict:
    """The problem document of a fleet member: a problem file, or a model file of
    ``robrst identify --modal`` with one input and one output (its ``[[model.at]]`` become
    ``[plant]`` and, for several temperatures, an explicit ``[family]``, as ``robrst
    identify`` writes a problem file).  ``[solver] compare_with`` is dropped.

    Parameters
    ----------
    path : pathlib.Path
        The member file.

    Returns
    -------
    dict
        A problem document.

    Raises
    ------
    SpecError
        Naming the file: not a file, a broken link, bad TOML, a model file of several
        inputs or outputs.
    """
    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise SpecError(f"{path}: broken symbolic link (to {os.readlink(path)}); expected a"
                        " problem or model file")
    doc = load_toml(path, "problem or model file")
    if "model" in doc:
        doc = _modal_document(path, doc)
    return _no_compare(doc)


def _modal_document(path, data):
    from robrst.base.modelformat import read_model_table
    from robrst.problem.files import model_document

    table = read_model_table(path, data, design_tables=True)
    if (table.inputs, table.outputs) != (1, 1):
        raise SpecError(f"{path}: [model] a model file of {table.inputs} inputs and"
                        f" {table.outputs} outputs; a fleet member needs one input and one"
                        " output (robrst identify --channel I,J writes the problem file of"
                        " one channel)")
    return model_document(path, data)


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


def fingerprint(sweep: Sweep, files: Iterable[str | Path], names: Iterable[str] = (),
                controller: RSTController | MimoController | None = None) -> str:
    """SHA-256 of the validated sweep (floats to 12 digits), the input files' bytes,
    ``names`` (a fleet's members that are no file), the coefficients of a controller the
    sweep designed and the robrst version.

    Parameters
    ----------
    sweep : Sweep
        The validated sweep.
    files : iterable of str or pathlib.Path
        The files its results depend on (sweep, base problem, result file, members).
    names : iterable of str
        Further names (broken fleet members).
    controller : RSTController or MimoController, optional
        An analysis's controller designed from the base problem (``controller =
        "design"``): a design that changes with the code (same files, same version) gives
        other results, so a folder of the earlier design is not resumed.

    Returns
    -------
    str
        The hex digest; a folder computed from another fingerprint is not resumed.
    """
    d = asdict(sweep)
    # "mimo" follows from the base problem's bytes (hashed below): the fingerprints of the
    # sweeps made before it was a field stay the same
    for k in ("path", "description", "problem", "worst", "mimo"):
        d.pop(k)
    h = hashlib.sha256(json.dumps(_stable(d), sort_keys=True, default=str).encode())
    for f in files:
        h.update(Path(f).read_bytes())
    for name in names:
        h.update(name.encode())
    if controller is not None:
        _hash_numbers(h, controller)
    h.update(__version__.encode())
    return h.hexdigest()


def _hash_numbers(h, obj) -> None:
    """Feed ``h`` every number and name of a controller record (its fields, sequences and
    arrays, in order; the exact bits of every coefficient)."""
    if is_dataclass(obj):
        for f in fields(obj):
            _hash_numbers(h, getattr(obj, f.name))
    elif isinstance(obj, (tuple, list)):
        h.update(b"(%d" % len(obj))
        for x in obj:
            _hash_numbers(h, x)
    elif obj is None:
        h.update(b"None")
    elif isinstance(obj, str):
        h.update(obj.encode())
    else:
        h.update(np.asarray(obj, float).tobytes())


def prepare(sweep: Sweep) -> tuple[SweepContext, VariantTable]:
    """The context and the variant table of ``sweep``.

    Parameters
    ----------
    sweep : Sweep
        The validated sweep.

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
    fleet, labels, broken = (), (), ()
    if sweep.problem:
        original, doc, base = _base(sweep)
        if sweep.mimo:
            check_mimo_params(sweep.params, base.family, sweep.path)
        else:
            check_plant_params(sweep.params, base.family, sweep.path)
    if sweep.kind == "analysis":
        if sweep.controller != "design":
            files.append(Path(sweep.path).parent / sweep.controller)
        controller = _controller(sweep, original)
    if sweep.kind == "fleet":
        fleet, paths, broken = _fleet(sweep)
        files += paths
        labels = tuple(Path(label).name for label, _, _ in fleet)
    table = variant_table(sweep, labels)
    ctx = SweepContext(sweep=sweep, names=table.names, base=base, doc=doc,
                       controller=controller, fleet=fleet)
    designed = controller if sweep.kind == "analysis" and sweep.controller == "design" else None
    return replace(ctx, fingerprint=fingerprint(sweep, files, broken, designed)), table
