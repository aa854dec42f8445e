"""A saved design (``robrst design --json``) read back as a design result, without designing.

The JSON of a design is an artefact: besides the controller and its certificate it carries
the problem document and the versions it was made with (its ``artefact`` object,
:func:`robrst.design.artefact_record`).  :func:`load_design` rebuilds the
:class:`~robrst.design.DesignResult` from it — the problem by
:func:`robrst.problem.files.parse_problem`, the controller from ``R, S, T`` exactly (JSON
floats round-trip) — and never runs a synthesis: every command that takes a problem file
(``export``, ``check``, ``report``, ``simulate``, ``certify``) takes a saved design and uses
*that* controller.

The certificate is computed again on load (:func:`robrst.certificate.proof.certify_problem`
on the saved controller: a check, not a design; 0.13 s for ``paper_robust``), so the
loaded result's proof is this robrst's own; :func:`load_design` reports whether its
verdict is the saved one.  :func:`recertify` does the same on another problem (another
family, a drawn actuator, an identified model): ``robrst certify``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robrst.base.errors import SpecError
from robrst.base.fileio import read_utf8
from robrst.certificate.proof import certify_problem
from robrst.core.analysis import analyze_many
from robrst.core.rst import RSTController
from robrst.design import ARTEFACT_FORMAT, AnalyticCheck, Comparison, DesignResult
from robrst.problem.files import FAMILY_TABLES, parse_problem

__all__ = ["load_design", "read_design", "is_design_file", "design_from_dict", "recertify",
           "saved_feedback",
           "merge_problem", "StoredRecord"]

MAX_BYTES = 200_000_000     # a saved design is a few hundred kB; refuse to read more


@dataclass(frozen=True, eq=False)
class StoredRecord:
    """A record of the saved design kept as it was written (the solver's rounds, the
    2-DOF reference path): :meth:`as_dict` and :meth:`solver_dict` give it back.

    Attributes
    ----------
    data : dict
        The JSON object as saved.
    """

    data: dict

    def as_dict(self) -> dict:
        """The record as saved.

        Returns
        -------
        dict
        """
        return dict(self.data)

    def solver_dict(self) -> dict:
        """The record as saved (the ``solver`` object of a design's JSON).

        Returns
        -------
        dict
        """
        return dict(self.data)


def is_design_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a saved design.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
        True for a file named ``*.json`` (whatever it holds: every command reads it as
        JSON, and :func:`read_design` names what is wrong with it, "not valid JSON" for a
        truncated file), and for a JSON object with a ``controller`` and a ``certificate``
        under another name (maybe of an older robrst: :func:`read_design` says so).
        Problem files are TOML; any other file is left to the problem reader.
    """
    p = Path(path)
    try:
        if not p.is_file():
            return False
        if p.suffix.lower() == ".json":
            return True
        if p.stat().st_size > MAX_BYTES:
            return False
        with open(p, "rb") as fh:
            if not fh.read(4096).lstrip().startswith(b"{"):
                return False
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and {"controller", "certificate"} <= doc.keys()


def read_design(path: str | os.PathLike) -> dict:
    """The JSON object of a saved design (errors name the file).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict
        The object ``robrst design --json`` printed.

    Raises
    ------
    SpecError
        Not readable, not JSON, not a design of ``robrst design --json`` (or its report's
        ``result.json``), or one written before designs carried their problem.
    """
    path = Path(path)
    if path.is_file() and path.stat().st_size > MAX_BYTES:
        raise SpecError(f"{path}: {path.stat().st_size} bytes; a saved design is far smaller")
    text = read_utf8(path, "saved design", "JSON", SpecError)
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise SpecError(f"{path}: not valid JSON ({exc}); expected the output of robrst"
                        " design --json") from None
    if not isinstance(doc, dict) or not {"controller", "problem", "certificate"} <= doc.keys():
        raise SpecError(f"{path}: not a saved design (expected the JSON object of robrst"
                        " design --json, with 'problem', 'controller' and 'certificate')")
    art = doc.get("artefact")
    if not isinstance(art, dict):
        raise SpecError(f"{path}: a design saved before designs carried their problem (no"
                        " 'artefact' record); design it again with this robrst")
    if art.get("format") != ARTEFACT_FORMAT:
        raise SpecError(f"{path}: [artefact.format] expected {ARTEFACT_FORMAT!r}, got"
                        f" {art.get('format')!r}")
    if not isinstance(art.get("problem_document"), dict):
        raise SpecError(f"{path}: [artefact.problem_document] missing: the design's problem"
                        f" could not be saved ({art.get('note', 'no reason given')})")
    return doc


def _controller(path, d):
    try:
        return RSTController(*(np.asarray(d[k], float) for k in "RST"))
    except (KeyError, TypeError, ValueError, SpecError) as exc:
        raise SpecError(f"{path}: [controller] expected R, S, T as lists of numbers ({exc})"
                        ) from None


def saved_feedback(path: str | os.PathLike) -> RSTController:
    """The feedback law of a saved design (no certificate computed): its controller as
    saved, and for a 2-DOF design (``tracking``) its ``R`` and ``S`` divided by the
    reference model's denominator, their common factor (``T = R``).

    Parameters
    ----------
    path : str or Path
        The JSON of ``robrst design --json`` (or a report's ``result.json``).

    Returns
    -------
    RSTController

    Raises
    ------
    SpecError
        Naming the file: not a saved design, its ``controller`` not ``R``, ``S``, ``T``
        lists of numbers, or its ``tracking.reference_den`` not a factor of both.
    """
    doc = read_design(path)
    ctrl = doc["controller"]
    c = _controller(path, ctrl if isinstance(ctrl, dict) else {})
    trk = doc.get("tracking")
    if not isinstance(trk, dict) or trk.get("reference_den") is None:
        return c
    try:
        den = np.asarray(trk["reference_den"], float)
        (R, rr), (S, rs) = np.polydiv(c.R, den), np.polydiv(c.S, den)
    except (TypeError, ValueError) as exc:
        raise SpecError(f"{path}: [tracking] reference_den expected a list of numbers"
                        f" ({exc})") from None
    if np.max(np.abs(rr), initial=0.0) > 1e-6 * np.max(np.abs(c.R)) or \
            np.max(np.abs(rs), initial=0.0) > 1e-6 * np.max(np.abs(c.S)):
        raise SpecError(f"{path}: [tracking] reference_den does not divide the controller's"
                        " R and S (expected their common factor)")
    return RSTController(R, S, R)


def design_from_dict(doc: dict, path: str = "<design>", problem: object = None,
                     progress: Callable[[str], None] | None = None) -> DesignResult:
    """The :class:`~robrst.design.DesignResult` of a saved design's JSON object.

    Parameters
    ----------
    doc : dict
        The object :func:`read_design` returns.
    path : str
        Named in errors; the problem's path (its ``compare_with`` is not used: no
        comparison is run again).
    problem : Problem, optional
        Certify the saved controller on this problem instead of the saved one.
    progress : callable, optional
        Called with one line: whether the certificate's verdict is the saved one.

    Returns
    -------
    DesignResult
        The saved controller, a certificate computed now on ``problem`` (default: the saved
        problem), the analyses of every family model and the limits
        (:func:`robrst.synthesis.limits.design_limits`) and, certified, the tolerance
        (:func:`robrst.design.tolerance.spread_tolerance`); the saved solver record, starts,
        analytic check, comparison and 2-DOF path as they were written.  On another
        ``problem`` only the 2-DOF path is kept (it is the controller's); the solver record
        says where the controller was designed, and there are no starts, analytic check or
        comparison (they belong to the saved problem).

    Raises
    ------
    SpecError
        Naming ``path``: the controller is not ``R``, ``S``, ``T`` lists of numbers or
        overflows the closed loop, ``target_char_poly`` is not a list of finite numbers.
    """
    say = progress or (lambda msg: None)
    ctrl = _controller(path, doc["controller"])
    saved = problem is None
    if saved:
        problem = parse_problem(doc["artefact"]["problem_document"], str(path), compare=False)
    try:
        cert = certify_problem(problem, ctrl)
    except SpecError as exc:           # the saved controller, not the problem, is at fault
        raise SpecError(f"{path}: [controller] {exc}") from None
    if saved:
        was = bool(doc.get("certified"))
        say(f"re-certified the saved controller: {'certified' if cert.certified else 'not certified'}"
            + (" (as saved)" if cert.certified == was else
               f" (saved: {'certified' if was else 'not certified'}; robrst"
               f" {doc['artefact'].get('versions', {}).get('robrst')} made it)"))
    from robrst.certificate.assessment import assess
    from robrst.design.tolerance import spread_tolerance
    from robrst.problem.records import with_defaults
    from robrst.synthesis.limits import design_limits

    ac, comp = doc.get("analytic_check"), doc.get("comparison")
    tcp = doc.get("target_char_poly")
    try:
        tcp = None if tcp is None else np.asarray(tcp, float)
    except (TypeError, ValueError):
        tcp = np.zeros((0, 0))
    if tcp is not None and (tcp.ndim != 1 or not tcp.size or not np.all(np.isfinite(tcp))):
        raise SpecError(f"{path}: [target_char_poly] expected a list of finite numbers"
                        " (or null)")
    bound, verdict = design_limits(problem, ctrl, cert, cert.certified)   # as the analyses
    solver = dict(doc.get("solver") or {"name": "saved"})
    if not saved:        # the synthesis record and the starts belong to the saved problem
        solver = {"name": "saved", "objective": problem.solver.objective,
                  "designed_on": str(doc.get("problem")),
                  "notes": [f"the controller of the saved design {path}, designed on problem"
                            f" {doc.get('problem')!r} and certified here on {problem.name!r}"
                            " without designing: that design's solver record and starts"
                            " are not this problem's and are not repeated"]}
    return DesignResult(
        problem=problem, method=str(doc.get("method", "saved")), controller=ctrl,
        target_char_poly=tcp,
        analyses=analyze_many(problem.family.models, ctrl), certificate=cert,
        synthesis=StoredRecord(solver),
        analytic_check=None if not saved or ac is None else AnalyticCheck(**ac),
        comparison=None if not saved or comp is None else Comparison(
            rows=comp["rows"], table=comp["table"], range_C=tuple(problem.family.range_C)),
        tracking=None if doc.get("tracking") is None else StoredRecord(doc["tracking"]),
        assessment=assess(problem, ctrl),     # computed again, as the analyses
        starts=None if not saved or doc.get("starts") is None else StoredRecord(doc["starts"]),
        objective_bound=bound, feasibility=verdict,
        tolerance=spread_tolerance(with_defaults(problem), ctrl)       # as the analyses
        if cert.certified and problem.spread is None else None)


def load_design(path: str | os.PathLike,
                progress: Callable[[str], None] | None = None) -> DesignResult:
    """Read a saved design (``robrst design PROBLEM --json > DESIGN.json``) without designing.

    Parameters
    ----------
    path : str or Path
        The JSON of ``robrst design --json`` (or a report's ``result.json``).
    progress : callable, optional
        Called with one line: the verdict of the certificate computed on load, and whether
        it is the saved one.

    Returns
    -------
    DesignResult
        Its controller is the saved one, bit for bit; its certificate is computed again on
        the saved problem (:func:`robrst.certificate.proof.certify_problem`).

    Raises
    ------
    SpecError
        Naming the file: not a saved design, or one of an older robrst without its problem.

    Examples
    --------
    >>> import json, tempfile, pathlib
    >>> from robrst import load_design, load_problem, run_problem
    >>> result = run_problem(load_problem("paper"))
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "design.json"
    >>> _ = path.write_text(json.dumps(result.as_dict()))
    >>> again = load_design(path)
    >>> again.certified, bool((again.controller.R == result.controller.R).all())
    (True, True)
    """
    return design_from_dict(read_design(path), str(path), progress=progress)


def merge_problem(doc: dict, other: dict, family_only: bool = False) -> dict:
    """A saved design's problem document with ``other``'s tables (a problem document).

    Parameters
    ----------
    doc : dict
        The saved design's problem document.
    other : dict
        Another problem document (or a model file's).
    family_only : bool
        Take only ``other``'s plant family.

    Returns
    -------
    dict
        ``other``'s plant family (``[plant]``, ``[family]``; a model file's ``[model]`` is
        one) replaces the design's as a whole; without ``family_only`` every other table
        ``other`` states replaces the design's too (its specs, poles, solver).

    Raises
    ------
    SpecError
        ``other`` states no plant.
    """
    out = {k: v for k, v in doc.items() if k not in FAMILY_TABLES}
    fam = {k: v for k, v in other.items() if k in FAMILY_TABLES + ("model",)}
    if not fam:
        raise SpecError("the other problem states no plant ([plant], [family] or [model])")
    if not family_only:
        out.update({k: v for k, v in other.items() if k not in fam})
    if "model" in fam:
        out = {k: v for k, v in out.items() if k not in ("plant", "family")}
    out.update(fam)
    return out


def recertify(design: str | os.PathLike | dict, problem_doc: dict | None = None,
              path: str = "<problem>", family_only: bool = False,
              progress: Callable[[str], None] | None = None,
              name: str | None = None) -> DesignResult:
    """Certify a saved design's controller on another problem, without designing.

    Parameters
    ----------
    design : str, Path or dict
        A saved design (file or its JSON object).
    problem_doc : dict, optional
        The other problem's document (a problem file or a model file of ``robrst
        identify``, parsed); default the saved problem.
    path : str
        Where ``problem_doc`` came from (named in errors).
    family_only : bool
        Take only its plant family; keep the design's specs, poles and solver.
    progress : callable, optional
    name : str, optional
        Where ``design`` came from when it is a JSON object (named in errors).

    Returns
    -------
    DesignResult
        The saved controller with the certificate of ``problem_doc`` merged over the
        saved problem (:func:`merge_problem`).
    """
    doc = read_design(design) if not isinstance(design, dict) else design
    name = str(design) if not isinstance(design, dict) else (name or "<design>")
    if problem_doc is None:
        return design_from_dict(doc, name, progress=progress)
    merged = merge_problem(doc["artefact"]["problem_document"], problem_doc, family_only)
    merged.setdefault("problem", {})
    merged["problem"] = {**merged["problem"], "name": Path(str(path)).stem}
    problem = parse_problem(merged, str(path), compare=False)
    return design_from_dict(doc, name, problem=problem, progress=progress)
