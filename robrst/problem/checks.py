"""Problem-file checks beyond single keys: what float64 pole placement can compute.

:mod:`robrst.problem.files` validates every key on its own (:mod:`robrst.base.schema`); this module
checks what keys mean together, before any design starts: the dominant and auxiliary
closed-loop poles, the reference model, the fixed factors of the controller and every
model of the plant family.  One rule for every pole or zero robrst is given or
generates: its magnitude lies within :data:`MAX_RATE` (and, for the poles a design
places, at least :data:`MIN_RATE`) — beyond them products of roots and scaled Sylvester
matrices overflow or underflow in float64.  Every error is a
:class:`~robrst.base.errors.SpecError` naming the file and the key.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.problem.records import AUX_MIN_FACTOR, PoleSpec
from robrst.base.schema import MAX_MAGNITUDE, key_error
from robrst.problem.specs import MAX_RATE, MIN_RATE, MIN_RATE_HZ

if TYPE_CHECKING:
    from pathlib import Path

    from robrst.core.plant import Plant
    from robrst.problem.records import ControllerStructure, Problem, SolverOptions, Specs

__all__ = ["MAX_RATE", "MIN_RATE", "MIN_RATE_HZ", "MAX_ORDER", "check_delay_order", "check_rates", "pole_spec", "check_pairs",
           "check_combinations", "check_generated", "pair_rates"]

MAX_ORDER = 30      # degree of a plant model's denominator (Sylvester matrices < 100 x 100)


def check_rates(path: str | Path, key: tuple, plant: Plant) -> Plant:
    """Refuse a model whose poles or zeros lie beyond :data:`MAX_RATE`, whose coefficients
    exceed ±1e100 or whose order exceeds :data:`MAX_ORDER` (float64 overflows beyond).

    Parameters
    ----------
    path : str or pathlib.Path
        The problem file, named in errors.
    key : tuple of str
        The key path of the model (``("plant",)``, ``("family", "models", "2")``).
    plant : Plant
        The model.

    Returns
    -------
    Plant
        ``plant`` unchanged.

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    if plant.n > MAX_ORDER:
        raise key_error(path, key, f"a model of order {plant.n}; expected at most {MAX_ORDER}"
                        " poles (reduce the model)")
    coefs = np.abs(np.concatenate([plant.A, plant.B]))
    if not np.all(coefs <= MAX_MAGNITUDE):
        raise key_error(path, key, f"a coefficient of {np.max(coefs):.3g} (monic A); expected"
                        f" every coefficient within ±{MAX_MAGNITUDE:g} (rescale time or units)")
    with np.errstate(all="ignore"):
        roots = np.concatenate([np.roots(plant.A), np.roots(plant.B)])
    if roots.size and not np.all(np.abs(roots) <= MAX_RATE):
        worst = np.max(np.abs(roots)) if np.all(np.isfinite(roots)) else np.inf
        raise key_error(path, key, f"a pole or zero at {worst:.3g} rad/s; expected every pole"
                        f" and zero within {MAX_RATE:g} rad/s (rescale time or units)")
    return plant


def pair_rates(wn: float, zeta: float) -> tuple[float, float]:
    """Magnitudes ``(slowest, fastest)`` of the roots of ``s^2 + 2 zeta wn s + wn^2``
    (computed without cancellation for any ``zeta > 0``).

    Parameters
    ----------
    wn : float
        Natural frequency [rad/s].
    zeta : float
        Damping (> 0).

    Returns
    -------
    (float, float)
        [rad/s].

    Examples
    --------
    >>> from robrst.problem.checks import pair_rates
    >>> [round(r, 6) for r in pair_rates(10.0, 1.25)]          # roots -5 and -20
    [5.0, 20.0]
    """
    if zeta <= 1.0:
        return wn, wn
    fast = wn * (zeta + math.sqrt((zeta - 1.0) * (zeta + 1.0)))
    return wn * (wn / fast), fast


def _in_rates(path, key, what, rates):
    lo, hi = min(rates), max(rates)
    if not (MIN_RATE <= lo and hi <= MAX_RATE):
        bad = lo if lo < MIN_RATE else hi
        raise key_error(path, key, f"{what} at {bad:.3g} rad/s; expected every pole robrst"
                        f" places within [{MIN_RATE:g}, {MAX_RATE:g}] rad/s")


def pole_spec(path: str | Path, p: dict | None) -> PoleSpec:
    """The :class:`PoleSpec` of a validated ``[poles]`` table, its poles within the rates.

    Parameters
    ----------
    path : str or pathlib.Path
        The problem file, named in errors.
    p : dict or None
        The validated ``[poles]`` table (``None``: missing).

    Returns
    -------
    PoleSpec

    Raises
    ------
    SpecError
        Naming the file and the key: missing, empty or unpaired dominant roots, poles
        outside [MIN_RATE, MAX_RATE], auxiliary roots unstable or < 10x faster.
    """
    if p is None:
        raise key_error(path, ("poles",), "missing required table [poles]")
    re_, im = p["dominant_roots_re"], p["dominant_roots_im"]
    dom = None
    if im is not None and re_ is None:
        raise key_error(path, ("poles", "dominant_roots_im"), "given without"
                        " 'dominant_roots_re' (the real parts of the same roots)")
    if re_ is not None:
        if not re_:
            raise key_error(path, ("poles", "dominant_roots_re"), "expected at least one root")
        im = im or (0.0,) * len(re_)
        if len(im) != len(re_):
            raise key_error(path, ("poles", "dominant_roots_im"),
                            "must match dominant_roots_re in length")
        dom = tuple(complex(a, b) for a, b in zip(re_, im))
    elif p["wn"] is None or p["zeta"] is None:
        raise key_error(path, ("poles",), "give 'wn' and 'zeta' (or 'dominant_roots_re')")
    spec = PoleSpec(wn=p["wn"], zeta=p["zeta"], dominant_real=p["dominant_real"],
                    dominant_roots=dom, aux_factor=p["aux_factor"], aux_roots=p["aux_roots"])
    if dom is not None:
        rates = [abs(r) for r in dom]
        _in_rates(path, ("poles", "dominant_roots_re"), "a dominant pole", rates)
    else:
        rates = list(pair_rates(p["wn"], p["zeta"]))
        _in_rates(path, ("poles", "zeta"), f"a pole of the dominant pair (wn = {p['wn']:g},"
                  f" zeta = {p['zeta']:g})", rates)
        if p["dominant_real"]:
            rates += [abs(r) for r in p["dominant_real"]]
            _in_rates(path, ("poles", "dominant_real"), "a dominant pole", rates[2:])
    try:
        spec.dominant()
    except SpecError as exc:
        raise key_error(path, ("poles",), str(exc).removeprefix("poles: ")) from None
    _aux(path, spec, max(rates))
    return spec


def _aux(path, spec, fastest):
    if spec.aux_roots is None:
        _in_rates(path, ("poles", "aux_factor"), f"auxiliary poles (aux_factor x the fastest"
                  f" dominant pole, {fastest:.3g} rad/s)", [spec.aux_factor * fastest])
        return
    key = ("poles", "aux_roots")
    aux = np.asarray(spec.aux_roots, float)
    if np.any(aux >= 0):
        raise key_error(path, key, f"auxiliary roots must be stable (< 0), got {aux.tolist()}")
    if aux.size and np.min(np.abs(aux)) < AUX_MIN_FACTOR * fastest * (1 - 1e-12):
        raise key_error(path, key, f"auxiliary poles must be >= {AUX_MIN_FACTOR:g}x faster than"
                        f" the fastest dominant pole ({fastest:.4g} rad/s), got {aux.tolist()}")
    if aux.size:
        _in_rates(path, key, "an auxiliary pole", np.abs(aux).tolist())


def check_pairs(path: str | Path, specs: Specs, solver: SolverOptions) -> None:
    """``[lo, hi]`` pairs in order (``resonance_band_hz``, ``wn_bounds``, ``zeta_bounds``).

    Parameters
    ----------
    path : str or pathlib.Path
        The problem file, named in errors.
    specs : Specs
        The specs.
    solver : SolverOptions
        The solver options.

    Raises
    ------
    SpecError
        A pair that is not ``0 < lo < hi``.
    """
    for tab, rec, k in (("specs", specs, "resonance_band_hz"), ("solver", solver, "wn_bounds"),
                        ("solver", solver, "zeta_bounds")):
        b = getattr(rec, k)
        if b is not None and not b[0] < b[1]:
            raise key_error(path, (tab, k), f"expected [lo, hi] with 0 < lo < hi, got {list(b)}")


def check_combinations(path: str | Path, ctrl: ControllerStructure, specs: Specs) -> None:
    """Keys that go together.

    Parameters
    ----------
    path : str or pathlib.Path
        The problem file, named in errors.
    ctrl : ControllerStructure
        The controller structure.
    specs : Specs
        The specs.

    Raises
    ------
    SpecError
        ``Mu_hf_max`` without ``Mu_hf_above_hz`` (or the reverse), ``roll_off_hz`` and
        ``roll_off_order`` not together, ``T_mode = "reference_model"`` without
        ``reference_wn``.
    """
    if (specs.Mu_hf_max is None) != (specs.Mu_hf_above_hz is None):
        raise key_error(path, ("specs",), "'Mu_hf_max' and 'Mu_hf_above_hz' go together")
    if ctrl.roll_off_order and ctrl.roll_off_hz is None:
        raise key_error(path, ("controller", "roll_off_hz"), "needed with roll_off_order > 0")
    if ctrl.roll_off_hz is not None and not ctrl.roll_off_order:
        raise key_error(path, ("controller", "roll_off_order"), "expected >= 1 with roll_off_hz"
                        " (the corner of a roll-off factor of that order; without it"
                        " roll_off_hz has no effect)")
    if ctrl.T_mode == "reference_model" and ctrl.reference_wn is None:
        raise key_error(path, ("controller", "reference_wn"), "needed with T_mode ="
                        " 'reference_model'")


def _factor_rates(path, key, coefs):
    with np.errstate(all="ignore"):
        roots = np.abs(np.roots(np.asarray(coefs, float)))
    roots = roots[roots != 0]         # the integrator(s) of S_fixed
    if roots.size and not np.all(np.isfinite(roots)):
        roots = np.array([math.inf])
    if roots.size:
        _in_rates(path, key, "a root", roots.tolist())


def check_generated(path: str | Path, problem: Problem) -> None:
    """Every pole the problem generates within the rates: the fixed factors of S and R
    (the roll-off included), the reference model, the family's models and the auxiliary
    poles of the fastest dominant pair ``free_poles`` allows.

    Parameters
    ----------
    path : str or pathlib.Path
        The problem file, named in errors.
    problem : Problem
        The parsed problem.

    Raises
    ------
    SpecError
        Naming the file and the key.
    """
    ctrl = problem.controller
    for k in ("S_fixed", "R_fixed"):
        _factor_rates(path, ("controller", k), getattr(ctrl, k))
    if ctrl.roll_off_order:
        _in_rates(path, ("controller", "roll_off_hz"), "the roll-off corner",
                  [2 * math.pi * ctrl.roll_off_hz])
    if ctrl.reference_wn is not None:
        _in_rates(path, ("controller", "reference_zeta"), "a reference-model pole",
                  pair_rates(ctrl.reference_wn, ctrl.reference_zeta))
    check_delay_order(path, ("specs", "delay_samples"), problem)
    if problem.family.thermal is not None:      # [plant] and explicit models: checked as read
        for m in problem.family.models:
            check_rates(path, ("family", "parametric"), m)


def check_delay_order(path: str | Path, key: tuple | None, problem: Problem,
                      delay_samples: int | None = None) -> None:
    """The sampled loop's plant (order + ``delay_samples``, default the problem's) within
    :data:`MAX_ORDER`: its delay polynomial ``(1 + s/2fs)^k`` overflows float64 beyond.

    Parameters
    ----------
    path : str or pathlib.Path
        The problem file (or the command), named in errors.
    key : tuple of str or None
        The key path named (``None``: the message names the option).
    problem : Problem
        The problem.
    delay_samples : int, optional
        The delay to check (default ``problem.specs.delay_samples``).

    Raises
    ------
    SpecError
        Order plus delay above ``MAX_ORDER``.
    """
    k = problem.specs.delay_samples if delay_samples is None else delay_samples
    n = max(m.n for m in problem.family.models)
    if k and n + k > MAX_ORDER:
        msg = (f"a delay of {k} samples on a plant of order {n}: expected order + delay <="
               f" {MAX_ORDER} (model a long delay by a lower sampling rate)")
        raise key_error(path, key, msg) if key else SpecError(f"{path}: {msg}")
