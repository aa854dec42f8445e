"""Time-domain specs of a reference step, computed exactly from the closed-loop polynomials.

For a reference step the output is ``Tr = B T / Delta`` and the control voltage
``A T / Delta`` (:func:`robrst.core.rst.closed_loop`).  Their step responses are computed
from the scaled realisation of :mod:`robrst.core.lti` by its exact zero-order-hold
discretisation (a step input *is* held): exact at every time point, no ODE solver.
The time grid follows the closed-loop modes: it runs until every mode has decayed by
``e**-16`` and, in each stretch of time, holds at least ``POINTS_PER_RAD`` points per
radian of the fastest mode still alive, so every oscillation is resolved; states are
propagated by repeated doubling (``x[k + m] = Phi**m x[k] + S_m``), a handful of
matrix products for tens of thousands of points.  Between grid points the figures are
proved, not sampled (:mod:`robrst.certificate._stepbound`): a bound of ``|y''|`` from output energies
(observability Gramians) bounds the response on every interval, and every interval
that could hold a larger value or a later exit from the 2 % band is cut and evaluated
exactly until decided; the figures are upper bounds (never early, never low), and one
that could not be decided is flagged (a failed spec of kind ``"unresolved"``).
The loops of a certificate are computed together (:func:`check_many`), each stage one
stacked computation for all the loops of one degree (:mod:`robrst.certificate._stepgrid`, the kernel).

The sampled loop (``fs``) is a loop in the bilinear variable (:mod:`robrst.core.sampled`);
mapping its realisation back with ``z = (1 + s/2fs)/(1 - s/2fs)`` gives the
discrete closed loop, whose step response at the sampling instants is computed the
same way (what the controller sees).

:func:`check` (one loop) and :func:`check_many` (the loops of one controller) are the
certificate's hooks; :func:`step_metrics` is the public computation.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import lti, poly
from robrst.certificate._stepbound import MAX_MORE, SETTLING_BAND, StepBounds
from robrst.certificate._stepgrid import DECAY, StepResponses

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.plant import Plant
    from robrst.core.rst import ClosedLoop, RSTController
    from robrst.problem.records import Specs

__all__ = ["StepMetrics", "step_metrics", "step_metrics_many", "check", "check_many", "KEYS",
           "SETTLING_BAND"]

KEYS = ("overshoot_pct", "settling_time_s", "step_u_peak_V")
RETRIES = 2      # longer grids for a response whose tail left a figure undecided


@dataclass(frozen=True)
class StepMetrics:
    """Step response of ``N/D``: final value, peak (value, time), overshoot [%],
    2 % settling time [s], and the largest ``|y|`` (for the control voltage).

    Peak, overshoot, settling time and largest ``|y|`` are proved upper bounds
    (:mod:`robrst.certificate._stepbound`).

    Parameters
    ----------
    final : float
        The final value ``N(0)/D(0)``.
    peak : float
        The largest value of the response.
    peak_time_s : float
        When it is reached [s].
    overshoot_pct : float
        ``100 (peak - final) / |final|`` (0 without overshoot) [%].
    settling_time_s : float
        The last time the response is outside 2 % of the final value [s].
    max_abs : float
        The largest ``|y|``.
    resolved : bool
        False when one of the figures could not be decided between grid points and is
        only the conservative bound.
    """

    final: float
    peak: float
    peak_time_s: float
    overshoot_pct: float
    settling_time_s: float
    max_abs: float
    resolved: bool = True


def _overshoot_pct(peak, final):
    """Overshoot [%] of a response whose largest value in the direction of ``final`` is
    ``peak`` (``inf`` for a zero final value)."""
    return 100.0 * max(0.0, (peak - abs(final)) / abs(final)) if final != 0 else np.inf


def _responses(Ns, Ds, fs, folds=None):
    """The step responses of loops of one degree: per loop, its trimmed numerators ``Ns[k]``
    over its trimmed ``Ds[k]`` (one realisation per loop; its modes live ``folds[k]``
    e-folds on its grid), and the factors from their time units to seconds."""
    scs = [poly.Scaling.natural(D) for D in Ds]
    w0 = np.array([sc.w0 for sc in scs])
    A, B, C, d = lti.companion_outputs_many(Ns, Ds, scs)
    if fs is None:
        return StepBounds(StepResponses(A, B, C, d, folds=folds)), 1.0 / w0
    return (StepBounds(StepResponses(A, B, C, d, w0 / fs, folds=folds)),
            np.full(len(Ds), 1.0 / fs))


def _figures(Ns, Ds, fs, figures):
    """``figures(bounds, to_s, ks)`` of loops of one degree (a list, one entry per loop of
    ``ks``), the loops whose response after the grid left a figure undecided computed again
    on longer grids (:attr:`robrst.certificate._stepbound.StepBounds.more`: the e-folds
    each needs, at most ``MAX_MORE`` beyond ``DECAY``; ``RETRIES`` times)."""
    K = len(Ds)
    out, folds, todo = [None] * K, np.full(K, DECAY), list(range(K))
    for attempt in range(RETRIES + 1):
        b, to_s = _responses([Ns[k] for k in todo], [Ds[k] for k in todo], fs, folds[todo])
        for k, res in zip(todo, figures(b, to_s, todo)):
            out[k] = res
        more = dict(zip(todo, b.more.tolist()))
        todo = [k for k in todo if more[k] > 0 and folds[k] < DECAY + MAX_MORE]
        if not todo or attempt == RETRIES:
            break
        for k in todo:
            folds[k] = min(folds[k] + more[k], DECAY + MAX_MORE)
    return out


def _by_degree(Ds):
    """Indices of the loops grouped by the degree of their denominator."""
    groups = defaultdict(list)
    for k, D in enumerate(Ds):
        groups[len(D)].append(k)
    return groups.values()


def step_metrics(N: ArrayLike, D: ArrayLike, fs: float | None = None) -> StepMetrics:
    """Exact step response figures of ``N(s)/D(s)`` (``D`` Hurwitz).

    Parameters
    ----------
    N, D : array_like
        Numerator and denominator in s, ``deg N <= deg D``.
    fs : float, optional
        Sample rate [Hz]: ``N/D`` is then a loop in the bilinear variable of
        :mod:`robrst.core.sampled` and the response is the discrete one at the samples.

    Returns
    -------
    StepMetrics
        Times in seconds.

    Examples
    --------
    >>> m = step_metrics([1.0], [1.0, 1.0, 1.0])     # wn = 1 rad/s, zeta = 0.5
    >>> round(m.overshoot_pct, 3), round(m.peak_time_s, 3)
    (16.303, 3.628)
    """
    return step_metrics_many([N], D, fs)[0]


def step_metrics_many(Ns: Sequence[ArrayLike], D: ArrayLike,
                      fs: float | None = None) -> list[StepMetrics]:
    """:func:`step_metrics` of several numerators over one denominator, sharing one
    realisation and one propagation of its states.

    Parameters
    ----------
    Ns : sequence of array_like
        Numerators in s, each of degree at most ``deg D``.
    D : array_like
        The common denominator (Hurwitz).
    fs : float, optional
        Sample rate [Hz] of a loop in the bilinear variable.

    Returns
    -------
    list of StepMetrics
    """
    Ns, D = [poly.trim(N) for N in Ns], poly.trim(D)

    def figures(b, to_s, ks):
        to_s = float(to_s[0])
        out = []
        for row, N in enumerate(Ns):
            final = float(N[-1] / D[-1])
            sgn = 1.0 if final >= 0 else -1.0
            (peak, tp, _, ok_hi), (low, _, _, ok_lo) = b.extremes([(row, sgn), (row, -sgn)])
            settle, _, ok_s = b.settling(row, [final])
            peak, low = float(peak[0]), float(low[0])
            out.append(StepMetrics(final=final, peak=sgn * peak,
                                   peak_time_s=float(tp[0]) * to_s,
                                   overshoot_pct=_overshoot_pct(peak, final),
                                   settling_time_s=float(settle[0]) * to_s,
                                   max_abs=max(abs(peak), abs(low)),
                                   resolved=bool(ok_hi[0] and ok_lo[0] and ok_s[0])))
        return [out]

    return _figures([Ns], [D], fs, figures)[0]


def check(plant: Plant, ctrl: RSTController, cl: ClosedLoop, specs: Specs, rtol: float,
          fs: float | None = None) -> tuple[dict, list[tuple]]:
    """Time-domain figures and failed specs of one closed loop (the certificate's hook).

    Parameters
    ----------
    plant : Plant
        The (possibly sampled-loop) plant.
    ctrl : RSTController
        The controller.
    cl : ClosedLoop
        :func:`robrst.core.rst.closed_loop` of ``plant`` and ``ctrl``.
    specs : Specs
        The time-domain bounds.
    rtol : float
        Relative tolerance on the bounds.
    fs : float, optional
        Sample rate of a sampled-loop plant.

    Returns
    -------
    record : dict
        ``overshoot_pct``, ``settling_time_s`` and ``step_u_peak_V`` (the largest
        ``|u|`` for a reference step of ``specs.step_um``), proved upper bounds.
    failed : list of (quantity, value, bound, kind)
        ``kind`` is ``"exceeds"``, or ``"unresolved"`` when the figure could not be
        decided between grid points and the bound lies between what was found and the
        conservative value (``quantity`` then says so).
    """
    return check_many([plant], ctrl, [cl], specs, rtol, fs)[0]


def check_many(plants: Sequence[Plant], ctrl: RSTController, cls: Sequence[ClosedLoop], specs: Specs,
               rtol: float, fs: float | None = None) -> list[tuple[dict, list[tuple]]]:
    """:func:`check` of several closed loops of one controller, computed together.

    The loops of one closed-loop degree share every stage of the computation (stacked
    realisations, eigenvalues, steps and propagations); each loop's figures are those
    :func:`check` gives it alone.

    Parameters
    ----------
    plants : sequence of Plant
        The (possibly sampled-loop) plants, all continuous or all sampled at ``fs``.
    ctrl : RSTController
        The controller.
    cls : sequence of ClosedLoop
        :func:`robrst.core.rst.closed_loop` of each plant and ``ctrl``.
    specs : Specs
        The time-domain bounds.
    rtol : float
        Relative tolerance on the bounds.
    fs : float, optional
        Sample rate of sampled-loop plants.

    Returns
    -------
    list of (dict, list)
        Per loop, :func:`check`'s ``(record, failed)``.
    """
    Ns = [[poly.trim(cl.nums["Tr"]), poly.trim(poly.pmul(p.A, ctrl.T))]
          for p, cl in zip(plants, cls)]
    Ds = [poly.trim(cl.Delta) for cl in cls]
    out = [None] * len(Ds)
    def figures(b, to_s, ks, Ns, Ds):
        # one realisation for y and u; only the figures checked: y's peak and settling
        # time, the largest |u| (ks: the loops of Ns, Ds computed)
        final = np.array([Ns[k][0][-1] / Ds[k][-1] for k in ks])
        (peak, _, peak_lo, ok_p), (u_max, _, u_found, ok_u) = b.extremes(
            [(0, np.where(final >= 0, 1.0, -1.0)), (1, 0.0)])
        settle, settle_lo, ok_s = b.settling(0, final)
        res = []
        for i in range(len(ks)):
            rec = {"overshoot_pct": _overshoot_pct(float(peak[i]), float(final[i])),
                   "settling_time_s": float(settle[i] * to_s[i]),
                   "step_u_peak_V": float(u_max[i]) * specs.step_um}
            found = {"overshoot_pct": (_overshoot_pct(float(peak_lo[i]), float(final[i])),
                                       ok_p[i]),
                     "settling_time_s": (float(settle_lo[i] * to_s[i]), ok_s[i]),
                     "step_u_peak_V": (float(u_found[i]) * specs.step_um, ok_u[i])}
            res.append((rec, _failed(rec, found, specs, rtol)))
        return res

    for ks in _by_degree(Ds):
        gN, gD = [Ns[k] for k in ks], [Ds[k] for k in ks]
        done = _figures(gN, gD, fs, lambda b, to_s, js: figures(b, to_s, js, gN, gD))
        for k, res in zip(ks, done):
            out[k] = res
    return out


def _failed(rec, found, specs, rtol):
    """The time-domain specs that ``rec`` fails: ``[(quantity, value, bound, kind), ...]``;
    ``found`` holds per figure the value found (a lower bound) and whether it was
    resolved."""
    failed = []
    for key, bound, atol in (("overshoot_pct", specs.overshoot_max_pct, 1e-6),
                             ("settling_time_s", specs.settling_time_max_s, 0.0),
                             ("step_u_peak_V", specs.step_u_max_V, 0.0)):
        if bound is None or not rec[key] > bound * (1 + rtol) + atol:
            continue
        low, resolved = found[key]
        if resolved or low > bound * (1 + rtol) + atol:
            failed.append((key, rec[key], bound, "exceeds"))
        else:
            why = (f"{key} not resolved between grid points (found {low:.6g}, proved"
                   f" <= {rec[key]:.6g})")
            failed.append((why, rec[key], bound, "unresolved"))
    return failed
