"""The certificate completed by the time-domain specs of a controller's reference path.

A certificate's frequency-domain records depend on the feedback ``R/S`` only; a
two-degree-of-freedom controller (:mod:`robrst.synthesis.tracking`) keeps them, and
:func:`with_time_domain` adds the reference-step figures
(:mod:`robrst.certificate.steps`) of every model the certificate checked (family, sweep
and refinement points, both loops).  :func:`first_tracked` picks, among reference paths
offered in order, the first whose loops meet the time-domain specs on every one of them.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from typing import TYPE_CHECKING

from robrst.certificate import steps as timespec
from robrst.certificate.figures import StepFigures
from robrst.certificate.models import BOUNDED
from robrst.certificate.proof import ACTUATOR, Violation, actuator_of
from robrst.certificate.statement import Bound
from robrst.core.analysis import spectral_abscissa_many
from robrst.core.rst import closed_loop

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.certificate.proof import Certificate
    from robrst.core.rst import RSTController
    from robrst.problem.records import Problem

__all__ = ["with_time_domain", "first_tracked"]


def with_time_domain(problem: Problem, cert: Certificate, ctrl: RSTController,
                     factor: ArrayLike | None = None) -> Certificate:
    """``cert`` (of the feedback ``R/S``) completed by the time-domain specs of ``ctrl``.

    The frequency-domain records of a certificate depend on ``R/S`` only, so a
    controller whose reference path changed (:mod:`robrst.synthesis.tracking`) keeps
    them; the reference-step figures (:mod:`robrst.certificate.steps`) are computed on every
    model of the certificate (family and sweep, and the sampled loop) and added.
    Spectral abscissae include the roots the new controller adds (its reference filter):
    those of ``factor`` when given (a polynomial that ``ctrl``'s ``R`` and ``S`` have
    beyond the certificate's controller, so every closed-loop polynomial gained exactly
    it), else those of each new closed-loop polynomial.

    Parameters
    ----------
    problem : Problem
        The problem.
    cert : Certificate
        The feedback's certificate.
    ctrl : RSTController
        The controller with its reference path.
    factor : array_like, optional
        The common factor of ``R`` and ``S`` the reference path added.

    Returns
    -------
    Certificate
    """
    sp = problem.specs
    recs = list(cert.models)
    fams = problem.families      # a record of a further actuator names it (certify_families)
    acts = [rec.actuator or actuator_of(rec.label)[0] for rec in recs]
    models = [fams[k].at(rec.temperature_C) for k, rec in zip(acts, recs)]
    labels = [m.label if not k else f"{ACTUATOR}{k}/{m.label}" for m, k in zip(models, acts)]
    kinds = [(models, None, "continuous")]
    if sp.sampled:
        kinds.append(([fams[k].sampled(m, sp.sample_rate_hz, sp.delay_samples)
                       for k, m in zip(acts, models)], sp.sample_rate_hz, "sampled"))
    found = [[] for _ in recs]            # per model, the failed specs of each loop
    added = None if factor is None else spectral_abscissa_many([factor])[0][0]
    for plants, fs, loop in kinds:        # every model's loop of one kind at once
        cls = [closed_loop(plant, ctrl) for plant in plants]
        sas = [added] * len(recs) if factor is not None else [
            sa for sa, _ in spectral_abscissa_many([cl.Delta for cl in cls])]
        figs = [rec.loop(loop) for rec in recs]
        figs = [replace(f, spectral_abscissa=max(f.spectral_abscissa, sa))
                for f, sa in zip(figs, sas)]
        if sp.time_domain:
            ks = [k for k, f in enumerate(figs) if f.stable]
            checked = timespec.check_many([plants[k] for k in ks], ctrl, [cls[k] for k in ks],
                                          sp, cert.rtol, fs)
            for k, (t_rec, failed) in zip(ks, checked):
                figs[k] = replace(figs[k], step=StepFigures(**t_rec))
                found[k] += [Violation(labels[k], models[k].temperature_C, q, v, b, None,
                                       loop, kind) for q, v, b, kind in failed]
        recs = [replace(rec, **{loop: f}) for rec, f in zip(recs, figs)]
    if sp.time_domain:   # figures the certificate did not have are published after it
        recs = [rec if rec.steps_checked_after or old.continuous.step is not None
                or (old.sampled is not None and old.sampled.step is not None)
                else replace(rec, steps_checked_after=True)
                for rec, old in zip(recs, cert.models)]
    viols = list(cert.violations) + [v for f in found for v in f]
    given = {key: getattr(sp, attr) for key, attr in BOUNDED if getattr(sp, attr) is not None}
    bounds = tuple(replace(b, value=given.pop(b.figure)) if b.figure in given else b
                   for b in cert.bounds) + tuple(Bound(k, v) for k, v in given.items())
    return replace(cert, certified=not viols, models=tuple(recs), violations=tuple(viols),
                   interval=replace(cert.interval, time_domain="checked points"), bounds=bounds)


def first_tracked(problem: Problem, ctrl: RSTController, cert: Certificate,
                  candidates: Iterable) -> tuple:
    """The first reference path of ``candidates`` whose loops on every model of ``cert``
    are stable and meet the time-domain specs (else the first one), with ``cert``
    completed by its time-domain figures (:func:`with_time_domain`).

    Parameters
    ----------
    problem : Problem
        The problem (its specs and families).
    ctrl : RSTController
        The feedback ``R/S`` that ``cert`` certifies.
    cert : Certificate
        Its certificate.
    candidates : iterable of (RSTController, Tracking)
        The 2-DOF controllers of ``ctrl`` in order of preference, each with the record of
        its reference path (whose ``Am_ref`` is the factor it adds to ``R`` and ``S``;
        :func:`robrst.synthesis.tracking.tracking_candidates`).

    Returns
    -------
    (RSTController, Tracking, Certificate)
    """
    first = None
    for out, trk in candidates:
        done = with_time_domain(problem, cert, out, factor=trk.Am_ref)
        first = first or (out, trk, done)
        stable = all(r.stable for r in done.models)
        if not problem.specs.time_domain or (
                stable and len(done.violations) == len(cert.violations)):
            return out, trk, done
    return first
