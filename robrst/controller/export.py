"""The exported digital controller: the sections, the direct form and the certificate.

:func:`export_controller` takes a design, discretises its controller at the sampling
rate (Tustin, :mod:`robrst.controller.digital`), certifies *exactly this* sampled loop (ZOH plant,
the Tustin controller, the computation delay; :func:`robrst.certificate.proof.certify_problem`
with the sampled specs) and measures what float64 and float32 implementations cost
(:mod:`robrst.controller.implementation`).  The writers (JSON, C, Python) only format this record.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst import __version__
from robrst.certificate.figures import figure_key
from robrst.certificate.proof import Certificate, certify_problem
from robrst.design import DesignResult
from robrst.controller.digital import DigitalController, digital_controller
from robrst.base.errors import SpecError
from robrst.controller.implementation import (RealisationFigures, implementation_report,
                                              sampled_loop)

if TYPE_CHECKING:
    from robrst.problem.records import Problem

__all__ = ["ExportedController", "export_controller", "sampling", "check_u_range", "LAW",
           "default_u_range", "MAX_LISTED"]

LAW = "S(q^-1) u(t) = T(q^-1) yr(t) - R(q^-1) y(t)"
STEP = ("w_k = H_k x_k + J_k [w_{k-1}, yr, y] (k = 1..m, inner to outer, w_0 = 0);"
        " u = w_m + feedthrough . [yr, y]; us = min(max(u, u_min), u_max);"
        " x_k += F_k x_k + G_k [w_{k-1}, yr, y] + L_k (us - u); output us")
# a float32 implementation is recommended when it keeps the guarantee with room to spare
F32_MU_MAX, F32_STEP_MAX = 1e-3, 1e-4
MAX_LISTED = 20      # violations spelled out in the JSON (all are counted)


def default_u_range() -> tuple[float, float]:
    """The amplifier range of the paper's actuator (the twin's ``[saturation]``: 0..150 V).

    Returns
    -------
    (float, float)
        ``(u_min, u_max)`` [V].
    """
    from robrst.twin.config import default_twin

    sat = default_twin().effects["saturation"]
    return float(sat["u_min"]), float(sat["u_max"])


@dataclass(frozen=True, eq=False)
class ExportedController:
    """A digital controller ready for a target, with the certificate of its sampled loop.

    Parameters
    ----------
    problem : str
        The problem's name.
    digital : DigitalController
        The sections and ``R_z, S_z, T_z``.
    delay_samples : int
        Computation delay of the certified sampled loop [samples].
    certificate : Certificate
        The certificate of the problem with the sampled loop at
        ``digital.sample_rate_hz`` and ``delay_samples``.
    spectral_radius : float
        The largest closed-loop pole modulus over the certified models.
    implementation : tuple of RealisationFigures
        The float64/float32 figures of
        :func:`robrst.controller.implementation.implementation_report`.
    u_range : (float, float)
        The amplifier range [V] the written code saturates to.

    Attributes
    ----------
    certified : bool
        The sampled loop is certified.
    recommended : str or None
        The realisation and precision to run: ``"sections_float32"`` when float32 keeps
        the guarantee with ``mu <= 1e-3`` and a step error ``<= 1e-4``, else
        ``"sections_float64"`` when that keeps it, else ``None``.
    """

    problem: str
    digital: DigitalController
    delay_samples: int
    certificate: Certificate
    spectral_radius: float
    implementation: tuple[RealisationFigures, ...]
    u_range: tuple[float, float]

    @property
    def certified(self):
        return bool(self.certificate.certified)

    @property
    def recommended(self):
        """The realisation and precision to run (docs/guide/export.md, "Which realisation
        to run")."""
        f32, f64 = self.realisation("sections", "float32"), self.realisation("sections", "float64")
        if (f32.stable_guaranteed and f32.mu_y <= F32_MU_MAX
                and (f32.step_error_y is None or f32.step_error_y <= F32_STEP_MAX)):
            return f32.key
        return f64.key if f64.stable_guaranteed else None

    def realisation(self, form: str, precision: str) -> RealisationFigures:
        """The figures of one realisation in one precision.

        Parameters
        ----------
        form : {"sections", "direct_form"}
            The realisation.
        precision : {"float64", "float32"}
            The precision.

        Returns
        -------
        RealisationFigures
        """
        return next(r for r in self.implementation
                    if (r.form, r.precision) == (form, precision))

    def certificate_dict(self) -> dict:
        """The ``certificate`` object of the JSON (worst case over the certified models).

        Returns
        -------
        dict
            ``certified, Ms_sampled, Mt_sampled, Mu_sampled, spectral_radius, n_models,
            n_violations, violations`` (at most 20 described) and the family members'
            ``models``.
        """
        c = self.certificate
        worst = {k: c.worst(k, "sampled") for k in ("Ms", "Mt", "Mu")}
        members = [m for m in c.models if m.family_member is not False]
        return {"certified": self.certified,
                "Ms_sampled": worst["Ms"], "Mt_sampled": worst["Mt"], "Mu_sampled": worst["Mu"],
                "spectral_radius": self.spectral_radius,
                # the same loop's slowest decay as python-control's discrete poles give it
                # (ln|z| / dt); the certificate's spectral_abscissa_sampled is its w-plane value
                "spectral_abscissa_sampled_z": (
                    float(self.digital.sample_rate_hz * np.log(self.spectral_radius))
                    if self.spectral_radius > 0 else None),
                "n_models": len(c.models),
                "n_violations": len(c.violations),
                "violations": [v.describe() for v in c.violations[:MAX_LISTED]],
                "models": [_sampled_row(m) for m in members]}

    def implementation_dict(self) -> dict:
        """Implementation figures, with the bounds on the implemented loop's peaks.

        Returns
        -------
        dict
            ``recommended`` and, per realisation and precision, the figures of
            :func:`~robrst.controller.implementation.implementation_report` plus
            ``Ms_sampled_bound = Ms/(1 - mu)`` and ``Mt_sampled_bound = (Mt + mu)/(1 - mu)``
            (``None`` without the guarantee).
        """
        ms, mt = (self.certificate.worst(k, "sampled") for k in ("Ms", "Mt"))
        out = {"recommended": self.recommended}
        for r in self.implementation:
            ok = r.stable_guaranteed
            out[r.key] = {**r.as_dict(), "Ms_sampled_bound": ms / (1 - r.mu_y) if ok else None,
                          "Mt_sampled_bound": (mt + r.mu_y) / (1 - r.mu_y) if ok else None}
        return out

    def as_dict(self) -> dict:
        """The JSON of ``robrst export --format json`` (fields are only added).

        Returns
        -------
        dict
            The export contract: the law, ``R_z, S_z, T_z``, the sections, anti-windup,
            certificate, implementation and the controller in s.
        """
        dc = self.digital
        return {
            "problem": self.problem,
            "robrst_version": __version__,
            "sample_rate_hz": dc.sample_rate_hz,
            "delay_samples": self.delay_samples,
            "discretisation": "tustin",
            "law": LAW,
            "R_z": dc.R_z.tolist(), "S_z": dc.S_z.tolist(), "T_z": dc.T_z.tolist(),
            "realisation": "sections_delta_form",
            "step": STEP,
            "sections": [s.as_dict() for s in dc.sections],
            "feedthrough": dc.D.tolist(),
            "n_states": dc.n_states,
            "anti_windup": {"u_min": self.u_range[0], "u_max": self.u_range[1],
                            "method": dc.aw_method,
                            "poles_z": [[float(z.real), float(z.imag)] for z in dc.aw_poles_z]},
            "certificate": self.certificate_dict(),
            "implementation": self.implementation_dict(),
            "controller_s": dc.ctrl.as_dict(),
        }


def check_u_range(u_range: tuple[float, float] | None) -> tuple[float, float]:
    """``(u_min, u_max)`` [V]: ``u_range`` validated, or :func:`default_u_range`.

    Parameters
    ----------
    u_range : (float, float) or None
        The amplifier range (``(-inf, inf)``: no saturation); ``None`` for the paper's.

    Returns
    -------
    (float, float)

    Raises
    ------
    SpecError
        Unless ``u_min < u_max`` (no NaN; an infinite end only on its own side).
    """
    if u_range is None:
        return default_u_range()
    lo, hi = (float(u) for u in u_range)
    if np.isnan(lo) or np.isnan(hi) or not lo < hi or lo == np.inf or hi == -np.inf:
        raise SpecError(f"--u-range: amplifier range must be [u_min, u_max] with u_min < u_max,"
                        f" got [{lo}, {hi}]")
    return lo, hi


def sampling(problem: Problem, sample_rate_hz: float | None = None,
             delay_samples: int | None = None) -> tuple[float, int]:
    """The sampling rate and delay of the export: the arguments, else the problem's specs.

    Parameters
    ----------
    problem : Problem
        The design problem.
    sample_rate_hz : float, optional
        Overrides ``specs.sample_rate_hz`` [Hz].
    delay_samples : int, optional
        Overrides ``specs.delay_samples``.

    Returns
    -------
    (float, int)
        The rate [Hz] and the delay [samples].

    Raises
    ------
    SpecError
        Neither names a rate, or a rate/delay is out of range.
    """
    sp = problem.specs
    fs = sp.sample_rate_hz if sample_rate_hz is None else sample_rate_hz
    k = sp.delay_samples if delay_samples is None else delay_samples
    if fs is None:
        raise SpecError(f"problem {problem.name!r} names no sampling rate"
                        " (specs.sample_rate_hz): give one (--fs HZ)")
    fs = float(fs)
    if not (np.isfinite(fs) and 0 < fs <= 1e9):
        raise SpecError(f"--fs / specs.sample_rate_hz: sampling rate must be a number in"
                        f" (0, 1e9] Hz, got {fs}")
    if int(k) != k or not 0 <= k <= 1000:
        raise SpecError(f"--delay-samples / specs.delay_samples: must be a whole number in"
                        f" 0..1000, got {k}")
    return fs, int(k)


def _sampled_row(rec):
    """A model's row of the export's certificate: its sampled loop's stability and peaks."""
    sl = rec.sampled
    row = {"label": rec.label, "temperature_C": rec.temperature_C}
    for name in ("stable", "Ms", "Mt", "Mu"):
        row[figure_key(name, "sampled")] = None if sl is None else getattr(sl, name)
    return row


def _certified_models(problem, cert):
    """The plants behind the certificate's records: family members, then the sweep."""
    fam = problem.family
    members = {m.temperature_C: m for m in fam.models}
    return [members.get(r.temperature_C) or fam.at(r.temperature_C) for r in cert.models]


def export_controller(result: DesignResult, sample_rate_hz: float | None = None,
                      delay_samples: int | None = None,
                      u_range: tuple[float, float] | None = None) -> ExportedController:
    """The digital controller of ``result`` and the certificate of its sampled loop.

    Parameters
    ----------
    result : DesignResult
        A design (:func:`robrst.run_problem`).
    sample_rate_hz : float, optional
        Sampling rate [Hz]; default the problem's ``specs.sample_rate_hz``.
    delay_samples : int, optional
        Computation delay [samples]; default the problem's ``specs.delay_samples``.
    u_range : (float, float), optional
        Amplifier range [V] for saturation and anti-windup (default 0..150 V, the
        paper's amplifier; ``(-inf, inf)`` for none).

    Returns
    -------
    ExportedController
        Its ``certificate`` covers exactly the sampled loop at this rate and delay: the
        design's own certificate when the problem names them, else a new one.

    Raises
    ------
    SpecError
        No sampling rate anywhere, or a bad rate, delay or range.

    Examples
    --------
    >>> from robrst import export_controller, load_problem, run_problem
    >>> exp = export_controller(run_problem(load_problem("paper")), sample_rate_hz=20000.0)
    >>> exp.certified, float(exp.digital.S_z[0]), exp.recommended
    (True, 1.0, 'sections_float32')
    """
    problem = result.problem
    sp = problem.specs
    fs, k = sampling(problem, sample_rate_hz, delay_samples)
    lo, hi = check_u_range(u_range)
    ctrl = result.controller
    if sp.sampled and sp.sample_rate_hz == fs and sp.delay_samples == k:
        cert = result.certificate
    else:
        cert = certify_problem(replace(problem, specs=replace(sp, sample_rate_hz=fs,
                                                              delay_samples=k)), ctrl)
    dc = digital_controller(ctrl, fs)
    loops = [sampled_loop(ctrl, m, fs, k) for m in _certified_models(problem, cert)]
    nominal = problem.family.reference_model.temperature_C
    loops.sort(key=lambda lp: lp.plant.temperature_C != nominal)   # simulate the nominal model
    return ExportedController(problem=problem.name, digital=dc, delay_samples=k,
                              certificate=cert,
                              spectral_radius=max(lp.spectral_radius for lp in loops),
                              implementation=implementation_report(dc, loops, k),
                              u_range=(lo, hi))
