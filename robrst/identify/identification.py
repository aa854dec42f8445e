"""Identification of a continuous-time linear model from records, with order selection.

Pipeline (:func:`identify`)::

    records --group by temperature--> per group: fit records + held-out records
      -> for each candidate order: vector fitting (z-domain) -> output-error residues
         -> held-out NRMSE (simulated: steady state for periodic records, from rest else)
      -> order = the smallest within ORDER_TOL (relative, + 1e-9) of the best held-out NRMSE
      -> final fit on every training record at that order -> continuous time (exact ZOH inverse)

Held-out records: ``validate`` if given (each scored by the model of the training
temperature nearest its own); else the last third of the training records (at least one)
when there are several; else, for a single record, its last period (periodic) or its last
30 % (the model is simulated over the whole record and scored on that part only) — unless
that part has settled (its output varies by less than ``QUIET`` of the record's, e.g. a
single step), when it cannot tell orders apart and the order is chosen on the
whole-record fit.  Records at several temperatures (mean temperature differing by more
than ``TEMP_TOL_K``) give one model per temperature: a temperature family.

Non-periodic records need not start at rest: each one's constant output offset and the
free response of its initial state are estimated with the model (nuisance terms, see
:mod:`robrst.identify._free`), in the fit and in every score (on the fit part of a split
record, on the first ``HELD_HEAD`` of a held-out one).  The estimates are reported per training record
(:attr:`Identified.starts`) and noted when above ``START_NOTE`` of the output's RMS
variation.  A record on which they are not significant (they lower its residual by no
more than noise would, see :func:`robrst.identify._free.record_starts`) is taken to start
at rest with no offset in the final fit: no information is spent on them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.data.dataset import check_sensor
from robrst.base.errors import DataError, SpecError
from robrst.identify._free import fit_free, record_starts
from robrst.identify._thermal import MAX_ORDER as MAX_LAW_ORDER
from robrst.identify._thermal import modal_parameters, polish_fit, thermal_law
from robrst.identify.vf import (fit_data, fit_residues, initial_poles, relative_degree,
                                to_continuous, vector_fit)
from robrst.base.threads import one_blas_thread

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset
    from robrst.identify.modal import DiscreteModel
    from robrst.identify._thermal import ThermalLaw

__all__ = ["identify", "Identified", "OrderScore", "ORDER_TOL", "MAX_ORDER", "MAX_AUTO_ORDER",
           "TEMP_TOL_K", "START_NOTE", "nrmse_of", "simulate_record"]

ORDER_TOL = 0.05        # choose the smallest order within 5 % of the best held-out NRMSE
# the largest model order identified (a complex pair counts two), and the largest order
# --order auto tries (every candidate is a vector fit whose cost grows as order^3; the
# candidates up to 60 take minutes, --max-order 100000 ran for hours)
MAX_ORDER = 200
MAX_AUTO_ORDER = 60
QUIET = 0.05            # a held-out part whose output varies < 5 % of the record's: settled
TEMP_TOL_K = 1.0        # records whose mean temperatures differ less share a model
VF_ITER = 12
MIN_SAMPLES = 50
START_NOTE = 0.01       # offsets / initial transients above 1 % of the output's RMS: noted
HELD_HEAD = 0.2         # a whole held-out record's offset and initial state: from its first 20 %


@dataclass(frozen=True)
class OrderScore:
    """Held-out result of one candidate order.

    Parameters
    ----------
    order : int
        The candidate order.
    train_nrmse : float
        NRMSE on the fit records.
    heldout_nrmse : float
        NRMSE on the held-out records (or parts).
    note : str
        Why the order was not tried or not usable ("" otherwise).
    """

    order: int
    train_nrmse: float
    heldout_nrmse: float
    note: str = ""


@dataclass(frozen=True, eq=False)
class Identified:
    """Result of :func:`identify`: one model per temperature (increasing) and the scores.

    Parameters
    ----------
    models : tuple of ModalModel
        One per temperature group, increasing.
    order : int
        The chosen order.
    feedthrough : bool
        A direct term was fitted.
    fs : float
        Sampling rate of the records [Hz].
    scores : tuple of OrderScore
        Per candidate order (of the order-selection group).
    heldout : tuple of str
        Names of the held-out records (or parts).
    train : tuple of str
        Names of the fit records.
    heldout_nrmse : float
        Held-out NRMSE of the chosen order (selection group).
    starts : tuple of RecordStart
        Per non-periodic training record: its offset and start away from rest.
    notes : tuple of str
        Significant offsets and starts away from rest, in words.
    relative_degree : int
        Continuous numerator degree = order - this (0: feedthrough), the one the data
        support (:func:`robrst.identify.vf.relative_degree`).
    thermal : ThermalLaw or None
        The per-kelvin laws of a family of one input and output at several temperatures
        (:func:`robrst.identify._thermal.thermal_law`).
    u_range_V : tuple of float or None
        The smallest and largest input of the training records [V] (the starting design's
        ``Mu_max`` is stated against it, :func:`robrst.identify.modelfile.starting_design`).

    Attributes
    ----------
    model : ModalModel
        The model of the first (lowest) temperature, or the only one.
    """

    models: tuple            # ModalModel per temperature group
    order: int
    feedthrough: bool
    fs: float
    scores: tuple            # OrderScore per candidate (order selection group)
    heldout: tuple           # names of the held-out records (or parts)
    train: tuple             # names of the fit records
    heldout_nrmse: float     # of the chosen order (selection group)
    starts: tuple = ()       # RecordStart per non-periodic training record
    notes: tuple = ()        # significant offsets and starts away from rest
    relative_degree: int = 1  # continuous numerator degree = order - this (0: feedthrough)
    thermal: ThermalLaw | None = None    # of a SISO family (several temperatures), or None
    u_range_V: tuple | None = None   # (min, max) of the training records' inputs [V]

    @property
    def model(self):
        """The model of the first (lowest) temperature, or the only one."""
        return self.models[0]

    def as_dict(self) -> dict:
        """The JSON of ``robrst identify --json`` (fields are only added).

        Returns
        -------
        dict
            ``order, feedthrough, fs_hz, inputs, outputs, temperatures_C, heldout_nrmse,
            train, heldout, records, notes, orders``.
        """
        return {"order": self.order, "feedthrough": self.feedthrough, "fs_hz": self.fs,
                "inputs": self.model.n_in, "outputs": self.model.n_out,
                "temperatures_C": [m.temperature_C for m in self.models],
                "heldout_nrmse": self.heldout_nrmse, "train": list(self.train),
                "heldout": list(self.heldout), "relative_degree": self.relative_degree,
                "thermal": None if self.thermal is None else self.thermal.as_dict(),
                "records": [r.as_dict() for r in self.starts], "notes": list(self.notes),
                "orders": [{"order": s.order, "train_nrmse": _num(s.train_nrmse),
                            "heldout_nrmse": _num(s.heldout_nrmse), "note": s.note}
                           for s in self.scores]}


def _num(x):
    return float(x) if math.isfinite(x) else None


def _fit_part(sl, n=None):
    """Samples the nuisance terms are estimated on when ``sl`` is scored: those before it
    (a split record's fit part); for a whole held-out record of ``n`` samples its first
    ``HELD_HEAD`` (the initial transient and the offset; estimated on the whole record,
    the free response of a high order's slow poles would absorb what the model misses
    later, e.g. a thermal drift, and make the held-out score favour high orders); else
    the whole record (training)."""
    start = sl.start or 0
    if start > 0:
        return slice(0, start)
    return None if n is None else slice(0, max(int(math.ceil(HELD_HEAD * n)), 1))


def simulate_record(dmodel: DiscreteModel, d: Dataset, free: bool = False,
                    fit: slice | None = None) -> np.ndarray:
    """Simulated outputs ``(N, m)`` of a sampled model on record ``d``.

    Parameters
    ----------
    dmodel : DiscreteModel
        The sampled model.
    d : Dataset
        The record (periodic ones in steady state, the others from rest).
    free : bool
        Estimate a non-periodic record's output offset and initial-state free response by
        least squares and include them.
    fit : slice, optional
        The samples they are estimated on (default: all).

    Returns
    -------
    numpy.ndarray
        ``(N, m)`` [µm].
    """
    periodic = bool(d.period) and d.periods >= 1
    Y = dmodel.response(d.U, periodic=periodic)
    if free and not periodic:
        c, f = fit_free(d.Y - Y, dmodel.zpoles, fit)
        Y = Y + c + f
    return Y


def _energies(dmodel, records, parts=None, free=False, held=False):
    """``(sum ||Y - Yhat||^2, sum ||Y - mean Y||^2)`` over records (``parts``: slices;
    ``held``: held-out records, their nuisance terms from their head, see ``_fit_part``)."""
    num = den = 0.0
    for k, d in enumerate(records):
        sl = parts[k] if parts is not None else slice(None)
        Y = d.Y[sl]
        E = Y - simulate_record(dmodel, d, free, _fit_part(sl, d.n if held else None))[sl]
        num += float(np.sum(E ** 2))
        den += float(np.sum((Y - Y.mean(axis=0)) ** 2))
    return num, den


def nrmse_of(dmodel: DiscreteModel, records: Sequence[Dataset],
             parts: Sequence[slice | None] | None = None, free: bool = False) -> float:
    """Pooled NRMSE ``||Y - Yhat|| / ||Y - mean Y||`` over records and outputs.

    Parameters
    ----------
    dmodel : DiscreteModel
        The sampled model.
    records : sequence of Dataset
        The records scored.
    parts : sequence of slice, optional
        Per record, the samples to score (default: all).
    free : bool
        Include each non-periodic record's estimated offset and initial-state response
        (estimated on the samples before the slice, or on the whole record).

    Returns
    -------
    float
        The NRMSE (``inf`` when the outputs do not vary).
    """
    num, den = _energies(dmodel, records, parts, free)
    return math.sqrt(num / den) if den > 0 else math.inf


def _check(records, what):
    if not records:
        raise DataError(f"identification needs at least one {what} record")
    fs0, k0, m0 = records[0].fs, records[0].n_in, records[0].n_out
    first = records[0].source or "the first record"
    for d in records:
        name = d.source or "record"
        if d.n < MIN_SAMPLES:
            raise DataError(f"{name}: too short ({d.n} samples) for identification")
        if abs(d.fs - fs0) > 1e-6 * fs0:
            raise DataError(f"{name}: sampled at {d.fs:.6g} Hz but {first} at {fs0:.6g} Hz;"
                            " resample to one rate")
        if (d.n_in, d.n_out) != (k0, m0):
            raise DataError(f"{name}: {d.n_in} input(s) and {d.n_out} output(s), but {first}"
                            f" has {k0} and {m0}")
        if np.ptp(d.U, axis=0).max() <= 0:
            raise DataError(f"{name}: the input never changes; nothing to identify from")
        check_sensor(d)
    return fs0


def _same_temperature_columns(records):
    """Refuse training records of which some measured the temperature and some did not:
    the ones without could belong to any model of the family."""
    with_t = [d for d in records if d.temp is not None]
    if with_t and len(with_t) < len(records):
        d = next(d for d in records if d.temp is None)
        raise DataError(f"{d.source or 'record'}: no temp column, but"
                        f" {with_t[0].source or 'another training record'} has one; every"
                        " training record needs a temp column (records at several"
                        " temperatures give a family) or none does")


def _groups(records):
    """Records grouped by mean temperature (None: not measured), increasing."""
    groups = []
    for d in records:
        T = None if d.temp is None else float(np.mean(d.temp))
        for g in groups:
            if (g[0] is None) == (T is None) and (T is None or abs(g[0] - T) < TEMP_TOL_K):
                g[1].append(d)
                break
        else:
            groups.append([T, [d]])
    groups.sort(key=lambda g: -np.inf if g[0] is None else g[0])
    for g in groups:
        if g[0] is not None:
            g[0] = float(np.mean([np.mean(d.temp) for d in g[1]]))
    return groups


def _split(records):
    """(fit records, held-out records, score slices, held-out names) for order selection."""
    if len(records) >= 2:
        h = max(1, len(records) // 3)
        held = records[-h:]
        return records[:-h], held, None, tuple(d.source or "record" for d in held)
    d = records[0]
    name = d.source or "record"
    if d.period and d.periods >= 2:
        cut = (d.periods - 1) * d.period
        fit = replace(d, t=d.t[:cut], u=d.u[:cut], y=d.y[:cut],
                      temp=None if d.temp is None else d.temp[:cut])
        return [fit], [d], [slice(cut, None)], (f"{name} (last period)",)
    cut = int(0.7 * d.n)
    whole = replace(d, period=0)
    if np.std(d.Y[cut:], axis=0).max() < QUIET * np.std(d.Y, axis=0).max():
        # the last 30 % has settled (e.g. one step): it cannot tell orders apart, so every
        # order would score ~1 there; the order is chosen on the whole record instead
        return [whole], [whole], None, (f"none: the last 30 % of {name} carries no"
                                        " excitation; order chosen on the whole-record fit",)
    fit = replace(d, t=d.t[:cut], u=d.u[:cut], y=d.y[:cut],
                  temp=None if d.temp is None else d.temp[:cut], period=0)
    return [fit], [whole], [slice(cut, None)], (f"{name} (last 30 %)",)


def _held_groups(groups, validate, main):
    """``[(group index, records, None)]``: each validation record scored by the model of the
    training group nearest its mean temperature (the main group when either is unknown)."""
    out = {}
    known = [i for i, g in enumerate(groups) if g[0] is not None]
    for d in validate:
        T = None if d.temp is None else float(np.mean(d.temp))
        i = main if T is None or not known else min(known, key=lambda k: abs(groups[k][0] - T))
        out.setdefault(i, []).append(d)
    return [(i, recs, None) for i, recs in sorted(out.items())]


def _fit_order(data, n, feedthrough):
    """Vector fitting at order n; keeps the iterate of lowest output-error cost."""
    poles = initial_poles(n, data.fs, *data.band)
    best, stale = None, 0
    for _ in range(VF_ITER):
        poles = vector_fit(data, poles, n_iter=1, feedthrough=feedthrough)
        dm, cost = fit_residues(data, poles, feedthrough)
        if best is None or cost < best[1] * (1 - 1e-6):
            stale = 0 if best is None or cost < best[1] * (1 - 1e-3) else stale + 1
            best = (dm, cost)
        else:
            stale += 1
        if stale >= 2:      # converged: no real progress for two iterations
            break
    return best[0]


def _candidates(order, max_order, n_lines):
    if order != "auto":
        return [int(order)]
    top = max_order or (40 if n_lines >= 400 else 12)
    return list(range(1, min(top, 12) + 1)) + list(range(14, top + 1, 2))


def identify(train: Sequence[Dataset], validate: Sequence[Dataset] | None = None,
             order: str | int = "auto", max_order: int | None = None, feedthrough: bool = False,
             progress: Callable[[str], None] | None = None) -> Identified:
    """Fit a continuous-time linear model (every output from every input) to records.

    Parameters
    ----------
    train : list of Dataset
        Records to fit (steps, multisines, any input; periodic records are used in
        steady state).  Same sampling rate and channel counts.
    validate : list of Dataset, optional
        Held-out records for the order selection (default: see the module docstring).
    order : "auto" or int
        Number of poles (a complex pair counts two), or ``"auto"``: every order up to
        ``max_order`` scored on held-out records.
    max_order : int, optional
        Largest order tried by ``"auto"`` (default 12; 40 for periodic records with at
        least 400 excited lines; at most :data:`MAX_AUTO_ORDER`); ``order`` at most
        :data:`MAX_ORDER`.
    feedthrough : bool
        Allow a direct term ``D`` (default False: strictly proper, ``y[k]`` depends on
        ``u`` up to ``k - 1``).
    progress : callable, optional
        Called with one line of text per candidate order.

    Returns
    -------
    Identified

    Raises
    ------
    DataError
        For inconsistent or unexcited records (also: training records of which only some
        have a temperature column).
    SpecError
        For a bad order, or when no candidate order gives a usable model (naming the flag
        to lower).
    """
    say = progress or (lambda m: None)
    fs = _check(list(train), "training")
    _same_temperature_columns(list(train))
    if validate:
        _check(list(train) + list(validate), "validation")
    if order != "auto" and (isinstance(order, bool) or not isinstance(order, int)
                            or not 1 <= order <= MAX_ORDER):
        raise SpecError(f"order must be 'auto' or an integer 1..{MAX_ORDER}, got {order!r}")
    if max_order is not None and (isinstance(max_order, bool) or not isinstance(max_order, int)
                                  or not 1 <= max_order <= MAX_AUTO_ORDER):
        raise SpecError(f"max_order must be an integer 1..{MAX_AUTO_ORDER}, got {max_order!r}")
    groups = _groups(list(train))
    main = max(range(len(groups)), key=lambda i: sum(d.n for d in groups[i][1]))
    with one_blas_thread():
        if validate:
            fit_recs = groups[main][1]
            held = _held_groups(groups, list(validate), main)   # each at its own temperature
            held_names = tuple(d.source or "record" for d in validate)
        else:
            fit_recs, recs, parts, held_names = _split(groups[main][1])
            held = [(main, recs, parts)]
        data = {i: fit_data(fit_recs if i == main else groups[i][1], free=True)
                for i in {main} | {i for i, _, _ in held}}
        n_lines = max([z.size for z, *_ in data[main].freq], default=0)
        scores = []
        for n in _candidates(order, max_order, n_lines):
            try:
                dms = {i: _fit_order(data[i], n, feedthrough) for i in data}
                for dm in dms.values():
                    to_continuous(dm)
                tr, note = nrmse_of(dms[main], fit_recs, free=True), ""
                num, den = np.sum([_energies(dms[i], r, sl, True, held=True)
                                   for i, r, sl in held], axis=0)
                ho = math.sqrt(num / den) if den > 0 else math.inf
            except SpecError as exc:
                tr = ho = math.inf
                note = str(exc)
            scores.append(OrderScore(n, tr, ho, note))
            say(f"order {n:>3}: training NRMSE {tr:.4g}, held-out NRMSE {ho:.4g}"
                + (f" ({note})" if note else ""))
        finite = [s for s in scores if math.isfinite(s.heldout_nrmse)]
        if not finite:
            hint = ("; choose a lower --order" if order != "auto" else
                    "; choose a lower --max-order")
            raise SpecError("no candidate order gives a usable model: "
                            + "; ".join(s.note for s in scores[:3]) + hint)
        best = min(s.heldout_nrmse for s in finite)
        chosen = next(s for s in finite if s.heldout_nrmse <= best * (1 + ORDER_TOL) + 1e-9)
        fits, starts = [], []
        for T, recs in groups:
            data = fit_data(recs, free=True)
            dm = _fit_order(data, chosen.order, feedthrough)
            rs = []
            if any(not (d.period and d.periods >= 1) for d in recs):
                rest_data = fit_data(recs)
                rest = _fit_order(rest_data, chosen.order, feedthrough)
                rs = record_starts(dm, recs, rest)
                flags = iter([r.significant for r in rs])
                flags = [False if d.period and d.periods >= 1 else next(flags) for d in recs]
                if not any(flags):
                    dm, data = rest, rest_data
                elif not all(flags):     # refit: the others start at rest
                    data = fit_data(recs, free=flags)
                    dm = _fit_order(data, chosen.order, feedthrough)
            fits.append((T, data, dm))
            starts += rs
        # one relative degree for every model: a family interpolates coefficient by
        # coefficient, and a leading numerator term fitted to the noise is a zero far
        # beyond Nyquist that no problem file can hold
        markov = relative_degree([d for _, d, _ in fits], [dm.zpoles for *_, dm in fits],
                                 feedthrough)
        out, params = [], []
        for T, data, dm in fits:
            if markov:
                dm = fit_residues(data, dm.zpoles, feedthrough, markov=markov)[0]
            label = "identified" if T is None else f"identified_T{T:g}C"
            law_fit = (T is not None and len(fits) > 1 and (data.n_in, data.n_out) == (1, 1)
                       and int(np.sum(np.where(dm.zpoles.imag > 0, 2, 1))) <= MAX_LAW_ORDER)
            if law_fit:         # the thermal law's covariance holds at the optimum
                dm = polish_fit(data, dm, feedthrough, markov)
            out.append(to_continuous(dm, label=label, temperature_C=T))
            if T is not None and len(fits) > 1 and (data.n_in, data.n_out) == (1, 1):
                params.append(modal_parameters(data, dm, T, feedthrough, markov))
        law = thermal_law(params, params[0].temperature_C) if len(params) > 1 else None
    notes = tuple(line for r in starts for line in r.notes(START_NOTE))
    for line in notes:
        say(line)
    say(f"chosen order {chosen.order} (held-out NRMSE {chosen.heldout_nrmse:.4g}),"
        f" relative degree {0 if feedthrough else markov + 1}")
    if law is not None:
        say("temperature family: " + (
            "the thermal law holds: " + ", ".join(
                f"{k} = {getattr(law, k):.4g} ± {law.std[k]:.2g}"
                for k in ("gain_per_K", "resonance_per_K", "damping_per_K"))
            if law.consistent else f"explicit models ({law.note})"))
    us = np.concatenate([np.asarray(d.U, float).ravel() for d in train])
    u_range = (float(np.min(us)), float(np.max(us))) if us.size else None
    return Identified(models=tuple(out), order=chosen.order, feedthrough=feedthrough, fs=fs,
                      u_range_V=u_range,
                      scores=tuple(scores), heldout=held_names,
                      train=tuple(d.source or "record" for d in train),
                      heldout_nrmse=chosen.heldout_nrmse, starts=tuple(starts), notes=notes,
                      relative_degree=0 if feedthrough else markov + 1, thermal=law)
