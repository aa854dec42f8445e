"""Multi-axis sweeps: the variants of a ``[mimo]`` base problem and their rows.

A sweep whose base problem is a multi-axis file varies

* numbers of that file by key path (``mimo.specs.sigma_S_max``,
  ``mimo.controller.extra_degree``, ``mimo.specs.crosstalk_max``), set in its document,
  which :func:`robrst.problem.mimo_files.parse_mimo` validates again;
* plant factors on every model of the family (:data:`MIMO_PLANT_PARAMS`): ``gain`` scales
  every actuator's gain, ``gain_<k>`` actuator ``k``'s (1-based: the spread between the
  stacks of one mechanism, ``G(s) diag(g)``), ``resonance`` every frequency
  (``G(s / f)``: ``A`` and ``B`` times ``f``).

A design sweep designs each variant (:func:`robrst.design.mimo.design_mimo`, without the
per-axis comparison); an analysis sweep certifies one fixed multi-axis controller (the base
problem's design, or the ``controller`` of a ``robrst design --json`` result of a
multi-axis file) on every variant.  A row holds the certificate's worst figure of every
spec over the checked models (:data:`robrst.problem.mimo.MIMO_SPECS`; ``*_sampled``: the
sampled loop), the smallest tracking bandwidth of an axis, the least integral gain over the
axes (signed) and, for a design, the controller as JSON.
"""

from __future__ import annotations

import copy
import re
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.schema import key_error
from robrst.core.mimo import MimoPlant
from robrst.problem.mimo import MIMO_SPECS
from robrst.problem.mimo_files import parse_mimo
from robrst.synthesis.parametrize import integral_gain

if TYPE_CHECKING:
    from collections.abc import Iterable
    from pathlib import Path

    from robrst.certificate.mimo import MimoCertificate
    from robrst.core.mimo import MimoFamily
    from robrst.core.mimo_loop import MimoController
    from robrst.problem.mimo import MimoProblem
    from robrst.problem.spread import Param

__all__ = ["MIMO_PLANT_PARAMS", "MIMO_COLUMNS", "MIMO_STAT_FIGURES", "MIMO_WORST_KEYS",
           "MIMO_FRONT_FIGURES", "is_mimo_plant_param", "check_mimo_params",
           "transform_mimo_family", "mimo_variant", "mimo_figures", "least_integral_gain"]

#: the plant factors of a multi-axis sweep (``gain_<k>``: actuator ``k``, 1-based)
MIMO_PLANT_PARAMS = ("gain", "gain_<k>", "resonance")
_PLANT = re.compile(r"^(?:gain|resonance|gain_([1-9][0-9]*))$")

_FIGURES = tuple(f for row in MIMO_SPECS for f in (row.figure, f"{row.figure}_sampled"))
#: column -> arrow type of a multi-axis row (the same for every kind)
MIMO_COLUMNS = {
    "status": "string", "message": "string", "certified": "bool_", "stable": "bool_",
    "worst_ratio": "float64", **{f: "float64" for f in _FIGURES},
    "spectral_abscissa": "float64", "bandwidth_hz": "float64", "integral_gain": "float64",
    "violations": "int64", "violation": "string", "seconds": "float64", "cpu_s": "float64",
}
#: the figures ``summary.json`` gives statistics of
MIMO_STAT_FIGURES = (*_FIGURES, "spectral_abscissa", "bandwidth_hz", "integral_gain",
                     "worst_ratio", "seconds", "cpu_s")
#: what a worst variant's record holds
MIMO_WORST_KEYS = ("status", "certified", "worst_ratio", "sigma_S", "sigma_T", "sigma_U",
                   "crosstalk", "bandwidth_hz", "integral_gain", "violation", "message")
#: the figures a trade-off front may use
MIMO_FRONT_FIGURES = ("sigma_S", "sigma_T", "sigma_U", "sigma_Sd", "axis_S", "axis_T",
                      "crosstalk", "bandwidth_hz", "integral_gain", "worst_ratio")


def is_mimo_plant_param(name: str) -> bool:
    """Whether ``name`` is a plant factor of a multi-axis sweep.

    Parameters
    ----------
    name : str

    Returns
    -------
    bool

    Examples
    --------
    >>> from robrst.studies.sweep._mimo import is_mimo_plant_param
    >>> [is_mimo_plant_param(n) for n in ("gain", "gain_2", "gain_0", "damping")]
    [True, True, False, False]
    """
    return bool(_PLANT.match(name))


def check_mimo_params(params: Iterable[Param], family: MimoFamily, path: str | Path) -> None:
    """Refuse a plant factor the family cannot take (``gain_<k>`` past its actuators).

    Parameters
    ----------
    params : iterable of Param
        The sweep's parameters.
    family : MimoFamily
        The base problem's family.
    path : str or pathlib.Path
        The sweep file, named in errors.

    Raises
    ------
    SpecError
        Naming the parameter's key.
    """
    for i, p in enumerate(params):
        m = _PLANT.match(p.name)
        if m and m.group(1) and int(m.group(1)) > family.n_in:
            raise key_error(path, ("param", str(i), "name"), f"{p.name}: the plant has"
                            f" {family.n_in} actuators (gain_1 .. gain_{family.n_in})")
        if m:
            lo = min(p.values) if p.values else p.lo
            unbounded = p.dist == "normal" and lo is None    # a normal draw may go negative
            if unbounded or (lo is not None and lo <= 0):
                raise key_error(path, ("param", str(i)), f"{p.name} is a factor: it must stay"
                                " positive (a normal distribution needs lo > 0)")


def transform_mimo_family(family: MimoFamily, values: dict[str, float]) -> MimoFamily:
    """Every model of ``family`` with the plant factors ``values`` applied.

    Parameters
    ----------
    family : MimoFamily
    values : dict
        ``{factor: value}`` (:data:`MIMO_PLANT_PARAMS`).

    Returns
    -------
    MimoFamily

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoFamily, MimoPlant
    >>> fam = MimoFamily((MimoPlant(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2))),))
    >>> g = transform_mimo_family(fam, {"gain": 2.0, "gain_2": 1.5}).models[0]
    >>> g.dc_gain().diagonal().tolist()
    [2.0, 3.0]
    """
    k = family.n_in
    gains = np.full(k, float(values.get("gain", 1.0)))
    for name, v in values.items():
        m = _PLANT.match(name)
        if m and m.group(1):
            gains[int(m.group(1)) - 1] *= float(v)
    f = float(values.get("resonance", 1.0))
    models = tuple(MimoPlant(f * g.A, f * g.B * gains, g.C, g.D * gains, label=g.label,
                             value=g.value, meta=dict(g.meta)) for g in family.models)
    return replace(family, models=models)


def mimo_variant(base: MimoProblem, doc: dict, path: str | Path,
                 values: dict[str, float], int_keys: Iterable[str] = ()) -> MimoProblem:
    """The problem of one variant of a multi-axis sweep.

    Parameters
    ----------
    base : MimoProblem
        The base problem (reused when no key path changes the document).
    doc : dict
        Its document (``[set]`` applied).
    path : str or pathlib.Path
        The base problem file (named in errors; model files are relative to it).
    values : dict
        ``{parameter name: value}``.
    int_keys : iterable of str
        The key paths that take integers.

    Returns
    -------
    MimoProblem

    Raises
    ------
    SpecError
        A value the problem file's rules refuse.
    """
    ints = set(int_keys)
    keys = {k: v for k, v in values.items() if not _PLANT.match(k)}
    plant = {k: v for k, v in values.items() if _PLANT.match(k)}
    problem = base
    if keys:
        d = copy.deepcopy(doc)
        for name, v in keys.items():
            node = d
            parts = name.split(".")
            for part in parts[:-1]:
                node = node.setdefault(part, {})
            node[parts[-1]] = int(v) if name in ints else float(v)
        problem = parse_mimo(d, path)
    if plant:
        problem = replace(problem, family=transform_mimo_family(problem.family, plant))
    return problem


def least_integral_gain(ctrl: MimoController) -> float:
    """The integral gain of the axis with the least ``|integral gain|`` (signed).

    Parameters
    ----------
    ctrl : MimoController

    Returns
    -------
    float
    """
    return min((integral_gain(c) for c in ctrl.axes), key=abs)


def mimo_figures(cert: MimoCertificate, ctrl: MimoController) -> dict:
    """The row figures of a certified (or not) multi-axis controller.

    Parameters
    ----------
    cert : MimoCertificate
        Its certificate on the variant's family.
    ctrl : MimoController
        The controller.

    Returns
    -------
    dict
        ``certified``, ``stable``, ``worst_ratio`` (``inf`` for a loop unstable on some
        model), the worst value of every figure per loop (``None`` when not computed, or
        for an unstable loop), ``spectral_abscissa``, ``bandwidth_hz`` (the smallest
        tracking bandwidth of an axis on a family member), ``integral_gain``,
        ``violations`` and the worst ``violation``.
    """
    recs = cert.models
    cont = all(r.continuous.stable for r in recs)
    samp = all(r.sampled is None or r.sampled.stable for r in recs)
    ratios = cert.ratios()
    worst = max(ratios.values(), default=0.0)
    viol = max(cert.violations, key=lambda v: v.ratio, default=None)
    if viol is not None and not np.isfinite(viol.ratio):
        worst = np.inf
    row = {"certified": bool(cert.certified), "stable": bool(cont and samp),
           "worst_ratio": worst if cont and samp else np.inf}
    for spec in MIMO_SPECS:
        f = spec.figure
        row[f] = cert.worst(f) if cont else None
        row[f"{f}_sampled"] = cert.worst(f, "sampled") if samp else None
    bws = [b for r in cert.members() for b in (r.continuous.bandwidth_hz or ()) if b is not None]
    row.update(spectral_abscissa=cert.worst("spectral_abscissa"),
               bandwidth_hz=min(bws) if bws and cont else None,
               integral_gain=least_integral_gain(ctrl), violations=len(cert.violations),
               violation=None if viol is None else viol.describe())
    return row
