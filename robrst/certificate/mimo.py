"""The certificate of a multi-axis controller on a MIMO family, over the whole parameter interval.

Nothing from the program is trusted: every figure is recomputed from the state spaces of
the unscaled loop (:mod:`robrst.core.mimo_loop`).

* **Per model** (family members): the closed-loop spectrum (stability), the exact peaks of
  the largest singular value of ``S``, ``T``, ``U = K S``, ``Sd = S G`` and ``Ti``
  (:func:`robrst.core.sigma.sigma_peak`, Hamiltonian level sets), every axis's ``|S_ii|``
  and ``|T_ii|`` peaks, the crosstalk (the largest peak of ``|Tr_ij|``, ``i != j``, over
  the crosstalk band) and every axis's tracking bandwidth (where ``|Tr_ii|`` first falls
  to ``1/sqrt(2)``, located on a grid and refined by bisection: a stated figure, not a
  bound).  With a sampling rate the same on the exact sampled loop (ZOH plant, Tustin
  controller, computation delay) in the w-plane (:func:`robrst.core.mimo.sampled_mimo`):
  physical frequencies up to Nyquist, the band warped, Nyquist itself checked as
  ``nu = inf``.
* **Between neighbouring models** ``a, b`` the family holds ``G(lam) = (1 - lam) G_a +
  lam G_b`` for every ``lam`` in ``[0, 1]`` (:meth:`robrst.core.mimo.MimoFamily.at`).

  - *Stability, proved*: at a checked ``lam_k`` with a stable loop, ``G(lam_k + d) =
    G(lam_k) + d (G_b - G_a)`` is the loop under an additive perturbation; by the
    small-gain theorem the loop stays stable for ``|d| < 1 / ||M_k||_inf``, with ``M_k``
    the closed-loop map from a signal added at the plant output to ``(G_b - G_a) u``
    (its exact peak, the upper end of its bracket).  Points are added where these
    intervals leave a gap, until they cover the segment (``stability: "small_gain"``) or
    the budget ends (a violation ``unresolved``).
  - *Peaks, on a refined sweep*: ``cert_points`` inner points, then an interval is halved
    while a bounded figure changes across it by more than half its margin to the bound
    (:data:`REFINE_RATIO`); still unresolved at the budget's end: a violation.

With ``input_gain_deviation`` (a sector of input gains ``[1 - delta, 1 + delta]``) every
record also holds ``sector_S``, ``sector_T`` and ``sector_U``: small-gain bounds on the
peaks of ``S``, ``T`` and ``K S`` for every gain in the sector (:func:`sector_figures`),
so performance, not only stability, is stated under hysteresis and creep taken as a gain
deviation; ``sector_*_max`` bound them.

A controller is certified when no figure exceeds its bound beyond ``rtol``, every loop is
stable, every peak is verified and every segment's stability is proved.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.threads import one_blas_thread
from robrst.core.mimo import MimoPlant, combination, sampled_mimo
from robrst.core.mimo_loop import MimoLoop, mimo_loop
from robrst.core.peaks import Peak
from robrst.core.sampled import unwarp, warp, warp_band
from robrst.core.sigma import frequency_response, sigma_max, sigma_peak
from robrst.problem.mimo import MIMO_SPECS, MimoSpecs

if TYPE_CHECKING:
    from robrst.core.mimo import MimoFamily
    from robrst.core.mimo_loop import MimoController
    from robrst.problem.mimo import MimoProblem

__all__ = ["MimoLoopFigures", "MimoModelRecord", "MimoViolation", "MimoCertificate",
           "MimoInterval", "MimoSegment", "SegmentLoopProof",
           "certify_mimo", "certify_mimo_problem", "check_models", "loop_figures",
           "sector_figures", "scaled_sector_peak", "stability_radius",
           "REFINE_RATIO", "LOOPS"]

REFINE_RATIO = 0.5      # halve an interval when a figure moves by more than this x its margin
LOOPS = ("continuous", "sampled")
PEAK_RTOL = 1e-9        # the accuracy of every exact peak
BANDWIDTH_LEVEL = 1.0 / np.sqrt(2.0)


@dataclass(frozen=True, eq=False)
class MimoLoopFigures:
    """The figures of one loop of one model.

    Parameters
    ----------
    loop : {"continuous", "sampled"}
    stable : bool
        Every closed-loop pole in the open left half-plane (sampled: inside the unit
        circle; the w-plane loop).
    spectral_abscissa : float
        Largest real part of the closed-loop poles (w-plane for the sampled loop).
    peaks : dict
        ``{figure: Peak}``: ``sigma_S``, ``sigma_T``, ``sigma_U``, ``sigma_Sd``,
        ``sigma_Ti`` (those computed), physical frequencies [rad/s].
    axis : dict
        ``{"S": (Peak per axis), "T": (...)}`` (empty when not computed).
    crosstalk : tuple or None
        ``(Peak, i, j)``: the largest off-diagonal peak of ``Tr`` over the band.
    bandwidth_hz : tuple or None
        Every axis's tracking bandwidth [Hz] (``None`` for an axis whose ``|Tr_ii|``
        stays above ``1/sqrt(2)``).
    radius : float or None
        Between family members: how far (in ``lam``) stability is proved around this
        point.
    pole_radius : float or None
        The sampled loop's largest discrete pole modulus.
    """

    loop: str
    stable: bool
    spectral_abscissa: float
    peaks: dict = field(default_factory=dict)
    axis: dict = field(default_factory=dict)
    crosstalk: tuple | None = None
    bandwidth_hz: tuple | None = None
    radius: float | None = None
    pole_radius: float | None = None

    def value(self, figure: str) -> float | None:
        """A figure's value (``axis_S``: the worst axis; ``crosstalk``: the worst entry).

        Parameters
        ----------
        figure : str

        Returns
        -------
        float or None
        """
        if figure in self.peaks:
            return self.peaks[figure].value
        if figure.startswith("axis_") and self.axis.get(figure[5:]):
            return max(p.value for p in self.axis[figure[5:]])
        if figure == "crosstalk" and self.crosstalk is not None:
            return self.crosstalk[0].value
        if figure == "spectral_abscissa":
            return self.spectral_abscissa
        return None

    def verified(self) -> bool:
        """Every peak's level-set iteration settled.

        Returns
        -------
        bool
        """
        pks = list(self.peaks.values()) + [p for v in self.axis.values() for p in v]
        if self.crosstalk is not None:
            pks.append(self.crosstalk[0])
        return all(p.verified for p in pks)

    def as_dict(self) -> dict:
        """JSON-ready figures (frequencies in Hz).

        Returns
        -------
        dict
        """
        def pk(p):
            return {"value": p.value, "freq_hz": p.freq_rad_s / (2 * np.pi),
                    "verified": p.verified}
        out = {"stable": self.stable, "spectral_abscissa": self.spectral_abscissa,
               **{k: pk(p) for k, p in self.peaks.items()}}
        for k, v in self.axis.items():
            out[f"axis_{k}"] = [pk(p) for p in v]
        if self.crosstalk is not None:
            out["crosstalk"] = {**pk(self.crosstalk[0]), "output": self.crosstalk[1] + 1,
                                "reference": self.crosstalk[2] + 1}
        if self.bandwidth_hz is not None:
            out["bandwidth_hz"] = list(self.bandwidth_hz)
        if self.radius is not None:
            out["stability_radius"] = self.radius
        if self.pole_radius is not None:
            out["pole_radius"] = self.pole_radius
        return out


@dataclass(frozen=True, eq=False)
class MimoModelRecord:
    """One checked model: a family member or a point between neighbours.

    Parameters
    ----------
    label : str
    value : float or None
        Its parameter value.
    member : bool
        A model of the family (not a point between two).
    continuous : MimoLoopFigures
    sampled : MimoLoopFigures or None
    """

    label: str
    value: float | None
    member: bool
    continuous: MimoLoopFigures
    sampled: MimoLoopFigures | None = None

    def loop(self, name: str) -> MimoLoopFigures | None:
        """The figures of ``name`` (``"continuous"`` or ``"sampled"``).

        Parameters
        ----------
        name : str

        Returns
        -------
        MimoLoopFigures or None
        """
        return self.continuous if name == "continuous" else self.sampled

    def as_dict(self) -> dict:
        """JSON-ready record.

        Returns
        -------
        dict
        """
        out = {"label": self.label, "value": self.value, "member": self.member,
               "continuous": self.continuous.as_dict()}
        if self.sampled is not None:
            out["sampled"] = self.sampled.as_dict()
        return out


@dataclass(frozen=True)
class MimoViolation:
    """One failed check.

    Parameters
    ----------
    label : str
        The model.
    value_param : float or None
        Its parameter value (temperature or level).
    quantity : str
        The figure (``"sigma_S"``, ``"crosstalk"``, ``"stability"``, ...).
    value, bound : float
        What was found, and its bound.
    freq_rad_s : float or None
        Where (physical frequency).
    loop : {"continuous", "sampled"}
    kind : {"exceeds", "unstable", "unresolved", "unverified"}
    """

    label: str
    value_param: float | None
    quantity: str
    value: float
    bound: float
    freq_rad_s: float | None = None
    loop: str = "continuous"
    kind: str = "exceeds"

    @property
    def ratio(self) -> float:
        """``value / bound`` for an exceeded bound, ``inf`` otherwise."""
        if self.kind == "exceeds" and self.bound:
            return self.value / self.bound
        return np.inf

    def describe(self) -> str:
        """One line, e.g. ``"model mirror_200mV: sigma_S = 2.31 > 2 at 612 Hz"``.

        Returns
        -------
        str
        """
        loop = " in the sampled loop" if self.loop == "sampled" else ""
        at = "" if self.freq_rad_s is None else f" at {self.freq_rad_s / (2 * np.pi):.4g} Hz"
        if self.kind == "exceeds":
            return f"model {self.label}: {self.quantity} = {self.value:.4g} > {self.bound:.4g}{at}{loop}"
        if self.kind == "unstable":
            return (f"model {self.label}: closed loop unstable{loop} (spectral abscissa"
                    f" {self.value:.4g} rad/s)")
        return f"model {self.label}: {self.quantity}{loop}"

    def as_dict(self) -> dict:
        """JSON-ready violation.

        Returns
        -------
        dict
        """
        return {"label": self.label, "value_param": self.value_param, "quantity": self.quantity,
                "value": self.value, "bound": self.bound, "freq_rad_s": self.freq_rad_s,
                "loop": self.loop, "kind": self.kind}


@dataclass(frozen=True)
class SegmentLoopProof:
    """What was proved of one loop between two neighbouring models.

    Parameters
    ----------
    stability : {"small_gain", "not_proved"}
        Every combination stable (the small-gain intervals of the checked points cover
        the segment), or not proved.
    gaps_lam : tuple of (float, float)
        Where no interval reaches (``lam`` in ``[0, 1]``).
    """

    stability: str
    gaps_lam: tuple = ()

    def as_dict(self) -> dict:
        """``{"stability", "gaps_lam"}``.

        Returns
        -------
        dict
        """
        return {"stability": self.stability, "gaps_lam": [list(g) for g in self.gaps_lam]}


@dataclass(frozen=True)
class MimoSegment:
    """The check between two neighbouring models of the family.

    Parameters
    ----------
    between : tuple of str
        The two models' labels.
    range : tuple of float
        Their parameter values.
    points : int
        Points checked on the segment, its ends included.
    proof : dict
        ``{loop: SegmentLoopProof}``.
    radius_start, radius_end : dict
        ``{loop: stability radius}`` at the two ends (``lam`` 0 and 1).
    """

    between: tuple
    range: tuple
    points: int
    proof: dict
    radius_start: dict
    radius_end: dict

    def as_dict(self) -> dict:
        """The JSON's segment: ``between, range, points, proof, radius_at_ends``.

        Returns
        -------
        dict
        """
        return {"between": list(self.between), "range": list(self.range),
                "points": self.points,
                "proof": {k: v.as_dict() for k, v in self.proof.items()},
                "radius_at_ends": {"0.0": dict(self.radius_start),
                                   "1.0": dict(self.radius_end)}}


@dataclass(frozen=True)
class MimoInterval:
    """What the certificate established between the family's models.

    Parameters
    ----------
    parameter : str
        What the family runs over.
    range : tuple of float
        The family's range.
    segments : tuple of MimoSegment
        One per pair of neighbouring models (none when they were not checked).
    statement : str
        The verdict in one sentence.
    """

    parameter: str = "temperature_C"
    range: tuple = ()
    segments: tuple = ()
    statement: str = ""

    def as_dict(self) -> dict:
        """The JSON's ``interval``: ``parameter, range, segments, statement``.

        Returns
        -------
        dict
        """
        return {"parameter": self.parameter, "range": list(self.range),
                "segments": [g.as_dict() for g in self.segments],
                "statement": self.statement}


@dataclass(frozen=True, eq=False)
class MimoCertificate:
    """What was checked and proved (module docstring).

    Parameters
    ----------
    certified : bool
    models : tuple of MimoModelRecord
        Members and inner points, in parameter order.
    violations : tuple of MimoViolation
    bounds : dict
        ``{figure: bound}`` (the sector as ``1/delta`` on ``sigma_Ti``).
    rtol : float
    interval : MimoInterval
        Per segment and loop: the points checked and what was proved.
    parameter, unit : str
        What the family runs over.
    """

    certified: bool
    models: tuple
    violations: tuple
    bounds: dict
    rtol: float
    interval: MimoInterval = field(default_factory=MimoInterval)
    parameter: str = "temperature_C"
    unit: str = ""

    def worst(self, figure: str, loop: str = "continuous") -> float | None:
        """The largest value of ``figure`` over the checked models.

        Parameters
        ----------
        figure : str
            ``sigma_S``, ``axis_T``, ``crosstalk``, ``spectral_abscissa``, ...
        loop : {"continuous", "sampled"}

        Returns
        -------
        float or None
        """
        vals = [v for m in self.models if (lp := m.loop(loop)) is not None
                and (v := lp.value(figure)) is not None]
        return max(vals) if vals else None

    def ratios(self) -> dict:
        """Worst ``value / bound`` of every bound, per loop (``"sigma_S_sampled"``, ...).

        Returns
        -------
        dict
        """
        out = {}
        for fig, b in self.bounds.items():
            for loop in LOOPS:
                w = self.worst(fig, loop)
                if w is not None:
                    out[fig if loop == "continuous" else f"{fig}_sampled"] = w / b
        return out

    def members(self) -> list[MimoModelRecord]:
        """The family members' records.

        Returns
        -------
        list of MimoModelRecord
        """
        return [m for m in self.models if m.member]

    def as_dict(self) -> dict:
        """The ``certificate`` object of the multi-axis JSON.

        Returns
        -------
        dict
        """
        return {"certified": self.certified, "rtol": self.rtol, "bounds": dict(self.bounds),
                "ratios": self.ratios(), "parameter": self.parameter, "unit": self.unit,
                "models": [m.as_dict() for m in self.models],
                "violations": [v.as_dict() for v in self.violations],
                "interval": self.interval.as_dict()}


def _physical(nu, fs):
    """Loop-variable frequency -> physical [rad/s] (identity for the continuous loop)."""
    if fs is None or nu is None:
        return nu
    return float(np.pi * fs) if not np.isfinite(nu) else float(unwarp(nu, fs))


def _peak(A, B, C, D, band, fs):
    pk = sigma_peak(A, B, C, D, band=band, rtol=PEAK_RTOL)
    return Peak(pk.value, _physical(pk.freq_rad_s, fs), pk.verified)


def _band(band_rad_s, fs):
    """A physical band as a band of the loop variable."""
    lo, hi = band_rad_s
    if fs is None:
        return (lo, hi)
    return warp_band(lo, hi, fs)


def _bandwidths(lp: MimoLoop, fs):
    """Every axis's tracking bandwidth [Hz]: the first frequency where ``|Tr_ii|`` falls to
    ``1/sqrt(2)`` (a 30-per-decade grid from 1e-3 of the slowest closed-loop pole, refined
    by bisection)."""
    A, B, C, D = lp.transfer("Tr")
    mags = np.abs(np.linalg.eigvals(A))
    mags = mags[mags > 0]
    lo = max(float(mags.min()) * 1e-3, 1e-3) if mags.size else 1e-3
    hi = float(np.pi * fs) * 0.999 if fs else float(mags.max()) * 10 if mags.size else 1e3
    if not hi > lo:
        return tuple(None for _ in range(lp.m))
    w = np.geomspace(lo, hi, int(30 * np.log10(hi / lo)) + 2)
    nu = warp(w, fs) if fs else w
    H = MimoPlant(A, B, C, D, "Tr").freqresp(nu)
    out = []
    for i in range(lp.m):
        g = np.abs(H[:, i, i])
        below = np.flatnonzero(g < BANDWIDTH_LEVEL)
        if not below.size or below[0] == 0:
            out.append(None if not below.size else float(w[0] / (2 * np.pi)))
            continue
        a, b = w[below[0] - 1], w[below[0]]
        Ai, Bi, Ci, Di = lp.transfer("Tr", i, i)
        for _ in range(40):
            mid = np.sqrt(a * b)
            v = sigma_max(Ai, Bi, Ci, Di, [warp(mid, fs) if fs else mid])[0]
            a, b = (mid, b) if v >= BANDWIDTH_LEVEL else (a, mid)
        out.append(float(np.sqrt(a * b) / (2 * np.pi)))
    return tuple(out)


def loop_figures(lp: MimoLoop, specs: MimoSpecs, loop: str, full: bool = True,
                 perturbation: tuple | None = None) -> MimoLoopFigures:
    """The figures of one closed loop (module docstring).

    Parameters
    ----------
    lp : MimoLoop
        The closed loop (the w-plane loop for ``loop = "sampled"``).
    specs : MimoSpecs
        Which figures are bounded (always computed), the band, the rate.
    loop : {"continuous", "sampled"}
    full : bool
        Also every unbounded figure (``sigma_S, T, U, Sd``, per-axis peaks, crosstalk,
        bandwidths); ``False``: the bounded ones only (points between members).
    perturbation : (dC, dD), optional
        The direction of the plant's ``C, D`` along a segment: the stability radius is
        computed.

    Returns
    -------
    MimoLoopFigures
    """
    fs = specs.sample_rate_hz if loop == "sampled" else None
    poles = lp.poles
    sa = float(np.max(poles.real)) if poles.size else -np.inf
    stable = sa < 0
    pole_radius = None
    if fs is not None and poles.size:
        q = poles / (2.0 * fs)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.abs((1 + q) / (1 - q))
        pole_radius = float(np.max(np.where(np.isfinite(z), z, np.inf)))
    fig = MimoLoopFigures(loop, stable, sa, pole_radius=pole_radius)
    if not stable:
        return fig
    bounded = specs.bounded
    delta = specs.input_gain_deviation
    asked = any(r.figure in bounded for r in MIMO_SPECS if r.kind == "robust")
    robust = delta is not None and (full or asked)
    peaks = {}
    for row in MIMO_SPECS:
        if row.kind in ("sigma", "sector") and (row.figure in bounded or robust or (
                full and row.kind == "sigma")):
            A, B, C, D = lp.transfer(row.transfer)
            peaks[row.figure] = _peak(A, B, C, D, None, fs)
    if robust:      # the scaled bounds (tens of peaks each) only where a spec bounds them
        peaks.update(sector_figures(peaks, delta, lp if asked else None,
                                    tighten={f for f in bounded if f.startswith("sector_")}))
    axis = {}
    for name in ("S", "T"):
        if full or f"axis_{name}" in bounded:
            axis[name] = tuple(_peak(*lp.transfer(name, i, i), None, fs) for i in range(lp.m))
    xt = None
    if lp.m > 1 and (full or "crosstalk" in bounded):
        band = _band(specs.crosstalk_band_rad_s, fs)
        entries = [(_peak(*lp.transfer("Tr", i, j), band, fs), i, j)
                   for i in range(lp.m) for j in range(lp.m) if i != j]
        pk, i, j = max(entries, key=lambda e: e[0].value)
        xt = (Peak(pk.value, pk.freq_rad_s, all(e[0].verified for e in entries)), i, j)
    radius = None if perturbation is None else stability_radius(lp, *perturbation)
    return MimoLoopFigures(loop, stable, sa, peaks, axis, xt,
                           _bandwidths(lp, fs) if full else None, radius, pole_radius)


def sector_figures(peaks: dict, delta: float, lp: MimoLoop | None = None,
                   tighten: Collection[str] | None = None) -> dict:
    """The peaks of ``S``, ``T`` and ``K S`` for every input gain in the sector.

    With the actuator's input ``(I + Delta) u``, ``Delta`` any operator of ``L2`` gain at
    most ``delta`` (time-varying gains per input, or a memoryless nonlinearity in that
    sector: hysteresis and creep as a gain deviation), ``I + G (I + Delta) K = (I + G K)
    (I + S G Delta K)`` gives, by the push-through identity,

    ``S' = S - S G (I + Delta Ti)^-1 Delta K S``,  ``T' = I - S'`` and
    ``K S' = (I - Ti (I + Delta Ti)^-1 Delta) K S``, bounded as

    ``||S'|| <= ||S|| + ||S G|| ||K S|| g``, ``||T'|| <= ||T|| + ||S G|| ||K S|| g``,
    ``||K S'|| <= ||K S|| / (1 - delta ||Ti||)``, with ``g = delta / (1 - delta ||Ti||)``

    (``||.||``: the peak of the largest singular value, the ``L2``-induced norm; the same
    with the sampled loop's peaks and ``l2``).  Two peaks at different frequencies
    multiply there; with the loop ``lp`` each bound is then tightened by constant
    scalings, one per input (:func:`scaled_sector_peak`: robust performance against one
    deviation per input, time-varying or nonlinear included), the least bound kept.
    Where ``delta ||Ti|| >= 1`` the small-gain theorem proves nothing and every figure is
    ``inf``.

    Parameters
    ----------
    peaks : dict
        ``{figure: Peak}`` holding ``sigma_S``, ``sigma_T``, ``sigma_U``, ``sigma_Sd`` and
        ``sigma_Ti`` of one loop.
    delta : float
        The sector's half-width (``input_gain_deviation``).
    lp : MimoLoop, optional
        The (stable) loop those peaks are of: the scaled bounds too.
    tighten : collection of str, optional
        The figures the scaled bounds tighten (``None``: all three); the others keep the
        product bound (tens of exact peaks each: the certificate tightens the figures a
        spec bounds).

    Returns
    -------
    dict
        ``{"sector_S": Peak, "sector_T": Peak, "sector_U": Peak}``, each at the frequency
        of its nominal peak, verified when every peak it uses is.
    """
    S, T, U, Sd, Ti = (peaks[f"sigma_{k}"] for k in ("S", "T", "U", "Sd", "Ti"))
    ok = all(p.verified for p in (S, T, U, Sd, Ti))
    loop = delta * Ti.value
    g = delta / (1.0 - loop) if loop < 1.0 else np.inf
    cross = Sd.value * U.value * g if g < np.inf else np.inf
    out = {"sector_S": (S, S.value + cross), "sector_T": (T, T.value + cross),
           "sector_U": (U, U.value / (1.0 - loop) if loop < 1.0 else np.inf)}
    if lp is not None and loop < 1.0 and ok:
        for fig, (nom, bound) in out.items():
            if tighten is not None and fig not in tighten:
                continue
            d0 = np.sqrt(Sd.value / (delta * U.value * nom.value))   # balances the blocks
            out[fig] = (nom, min(bound, scaled_sector_peak(lp, delta, fig[7:], nom.value,
                                                           bound, d0)))
    return {fig: Peak(v, nom.freq_rad_s, ok) for fig, (nom, v) in out.items()}


SCALE_POINTS = 300      # the scalings are searched on this many frequencies (and the
#                         system's own), the proof then exact ...
SCALE_RETRIES = 2       # ... a grid that missed the scaled peak gets its frequency and again
ACTIVE = 16             # the search's active frequencies at first ...
ACTIVE_ROUNDS = 6       # ... grown by the grid's worst this many times at most
GAMMA_STEPS = 12        # bisection steps on the bound


def scaled_sector_peak(lp: MimoLoop, delta: float, which: str, lo: float,
                       hi: float, d0: float = 1.0) -> float:
    """A bound on the peak of ``S'``, ``T'`` or ``K S'`` over the sector, by a scaled
    small-gain test with one scaling per input.

    The loop with the deviation is ``[z; e] = M [w; v]``: ``z`` the controller outputs the
    deviation acts on, ``w = Delta z`` entering at the plant inputs, ``v -> e`` the
    performance channel (``d_o -> y`` for ``S``, ``n -> -y`` for ``T``, ``d_o -> -u``
    for ``K S``).  The deviation is one per input, ``Delta = diag(Delta_1, ..., Delta_k)``,
    each of gain at most ``delta`` (a gain varying in time or a memoryless nonlinearity of
    that sector: each actuator's hysteresis acts on its own input).  If, for a positive
    diagonal ``D``, ``||diag(D, I) N_gamma diag(D^-1, I)|| < 1`` with ``N_gamma =
    [[delta M_zw, delta M_zv], [M_ew / gamma, M_ev / gamma]]``, then ``||e|| < gamma ||v||``
    for every such ``Delta`` (``D Delta D^-1 = Delta``: constant scalings, so nonlinear
    and time-varying deviations too).

    For each ``gamma`` of a bisection between the nominal peak and the product bound, the
    scaling minimises the largest singular value over a frequency grid — a convex function
    of ``log D`` (Sezginer and Overton 1990), so its local minimum (Nelder-Mead from the
    previous step's scaling) is the grid's best — and the bound is proved only by the exact
    peak of the scaled system (its upper bracket below 1); a grid that missed the scaled
    peak gets that frequency and is searched again.  A scalar ``D = d I`` is a special
    case: the bound is never above the best scalar scaling the grid finds.

    Parameters
    ----------
    lp : MimoLoop
        The stable closed loop (the w-plane loop of a sampled one).
    delta : float
        The sector's half-width.
    which : {"S", "T", "U"}
        The performance channel.
    lo, hi : float
        The nominal peak of that channel and a valid bound (the product bound).
    d0 : float
        The first scaling, every input's (``sqrt(||S G|| / (delta ||K S|| lo))`` balances
        the off-diagonal blocks).

    Returns
    -------
    float
        The least bound proved, ``hi`` when no scaling proves less.
    """
    from scipy import optimize           # SciPy loads with the first sector bound asked

    A, Bw, Cz, Dzw = lp.transfer("Ti")
    _, Bv, _, Dzv = lp.transfer("U")          # z = -u: the rows of U and Ti
    if which == "S":
        _, _, Ce, Dew = lp.transfer("Sd")
        Dev = lp.transfer("S")[3]
    elif which == "T":                        # e = -y from n; n enters as d_o does
        _, _, Ce, Dew = lp.transfer("Sd")
        Ce, Dew = -Ce, -Dew
        _, Bv, _, Dev = lp.transfer("T")
    else:
        Ce, Dew, Dev = Cz, Dzw, Dzv
    k = Bw.shape[1]
    if not np.isfinite(hi) or k == 0:
        return hi
    B, C = np.hstack([Bw, Bv]), np.vstack([Cz, Ce])
    D = np.block([[Dzw, Dzv], [Dew, Dev]])
    ne, nv = Ce.shape[0], Bv.shape[1]

    def scales(logd, gamma):
        d = np.exp(logd)
        return (np.concatenate([delta * d, np.full(ne, 1.0 / gamma)]),
                np.concatenate([1.0 / d, np.ones(nv)]))

    def exact(logd, gamma):
        rows, cols = scales(logd, gamma)
        return sigma_peak(A, B * cols, rows[:, None] * C, rows[:, None] * D * cols,
                          rtol=PEAK_RTOL)

    lam = np.linalg.eigvals(A) if A.size else np.zeros(0)
    mag = np.abs(lam[lam != 0]) if np.any(lam != 0) else np.ones(1)
    H = frequency_response(A, B, C, D, np.concatenate([
        [0.0, np.inf], np.abs(lam.imag),                      # the system's own frequencies
        np.geomspace(mag.min() / 10, mag.max() * 10, SCALE_POINTS)]))
    if not np.all(np.isfinite(H)):
        return hi

    def sigmas(logd, gamma, idx):
        rows, cols = scales(logd, gamma)
        return np.linalg.svd(H[idx] * rows[:, None] * cols, compute_uv=False)[:, 0]

    # the scaling is searched on an active set of the grid's frequencies: those where the
    # scaled value is largest, grown by the grid's worst ones until none lies above
    active = list(np.argsort(sigmas(np.full(k, np.log(d0)), hi, slice(None)))[-ACTIVE:])

    def least(gamma, x0):
        """The grid's best scaling for ``gamma`` and the grid's largest value there."""
        for _ in range(ACTIVE_ROUNDS):
            simplex = x0 + np.vstack([np.zeros(k), 0.5 * np.eye(k)])
            res = optimize.minimize(lambda x: float(np.max(sigmas(x, gamma, active))), x0,
                                    method="Nelder-Mead",
                                    options={"initial_simplex": simplex, "xatol": 1e-3,
                                             "fatol": 1e-4, "maxfev": 200 * k})
            full = sigmas(res.x, gamma, slice(None))
            above = [int(i) for i in np.argsort(full)[-3:]
                     if full[i] > res.fun and int(i) not in active]
            if not above:
                break
            active.extend(above)
            x0 = res.x
        return res.x, float(np.max(full))

    def proved(gamma, x0):
        """The scaling that proves ``gamma`` (``None``: none found)."""
        nonlocal H
        for _ in range(SCALE_RETRIES + 1):
            x, top = least(gamma, x0)
            if top >= 1.0:
                return None
            pk = exact(x, gamma)
            if pk.verified and pk.value * (1 + 2 * PEAK_RTOL) < 1.0:
                return x
            if not np.isfinite(pk.freq_rad_s) and not np.isfinite(pk.value):
                return None
            # the grid missed the scaled peak: its frequency joins the grid, active
            H = np.concatenate([H, frequency_response(A, B, C, D, [pk.freq_rad_s])])
            active.append(len(H) - 1)
            x0 = x
        return None

    x = np.full(k, float(np.log(d0)))
    found = proved(hi, x)
    if found is None:
        return hi
    x, a, b = found, np.log(max(lo, 1e-300)), np.log(hi)
    for _ in range(GAMMA_STEPS):
        mid = 0.5 * (a + b)
        got = proved(float(np.exp(mid)), x)
        if got is None:
            a = mid
        else:
            x, b = got, mid
    return min(float(np.exp(b)), hi)


def stability_radius(lp: MimoLoop, dC: np.ndarray, dD: np.ndarray) -> float:
    """How far the plant may move along ``(dC, dD)`` with the loop provably stable.

    The plant ``(A, B, C + d dC, D + d dD)`` is the loop's plant under the additive
    perturbation ``d (dC (sI - A)^-1 B + dD)`` (the same states); with ``M`` the closed-loop
    map from a signal added at the plant output to ``dC x + dD u``, the small-gain theorem
    keeps the loop stable for ``|d| < 1 / ||M||_inf`` (``lp`` stable).

    Parameters
    ----------
    lp : MimoLoop
        A stable closed loop.
    dC, dD : numpy.ndarray
        The direction, of the shapes of the plant's ``C`` and ``D``.

    Returns
    -------
    float
        ``1 / (peak (1 + 2 rtol))`` (the peak's upper bracket), ``inf`` for a null
        direction, 0 when the peak is not verified or the loop is unstable.
    """
    if not lp.stable:
        return 0.0
    do = slice(2 * lp.m, 3 * lp.m)
    urows = slice(lp.m, lp.m + lp.k)
    Cz = np.hstack([dC, np.zeros((dC.shape[0], lp.A.shape[0] - lp.n_plant))]) \
        + dD @ lp.C[urows]
    Dz = dD @ lp.D[urows, do]
    pk = sigma_peak(lp.A, lp.B[:, do], Cz, Dz, rtol=PEAK_RTOL)
    if not pk.verified:
        return 0.0
    return np.inf if pk.value == 0 else 1.0 / (pk.value * (1 + 2 * PEAK_RTOL))


def _loops(plant: MimoPlant, ctrl, specs):
    """``{loop: MimoLoop}`` of a plant (the continuous loop, and the sampled one)."""
    out = {"continuous": mimo_loop(plant, ctrl)}
    if specs.sampled:
        out["sampled"] = mimo_loop(sampled_mimo(plant, specs.sample_rate_hz,
                                                specs.delay_samples), ctrl)
    return out


def _violations(rec: MimoModelRecord, specs: MimoSpecs, rtol: float) -> list[MimoViolation]:
    out = []
    for loop in LOOPS:
        lp = rec.loop(loop)
        if lp is None:
            continue
        if not lp.stable:
            out.append(MimoViolation(rec.label, rec.value, "stability", lp.spectral_abscissa,
                                     0.0, None, loop, "unstable"))
            continue
        for fig, b in specs.bounded.items():
            v = lp.value(fig)
            if v is None:
                continue
            if v > b * (1 + rtol):
                if fig in lp.peaks:
                    f = lp.peaks[fig].freq_rad_s
                elif fig == "crosstalk":
                    f = lp.crosstalk[0].freq_rad_s
                else:
                    f = max(lp.axis[fig[5:]], key=lambda p: p.value).freq_rad_s
                out.append(MimoViolation(rec.label, rec.value, fig, v, b, f, loop))
        if not lp.verified():
            out.append(MimoViolation(rec.label, rec.value, "a peak's level-set iteration did"
                                     " not settle (not proved)", 0.0, 0.0, None, loop,
                                     "unverified"))
    return out


def _record(plant, ctrl, specs, member, full, pert=None):
    loops = _loops(plant, ctrl, specs)
    figs = {k: loop_figures(lp, specs, k, full, None if pert is None else pert[k])
            for k, lp in loops.items()}
    return MimoModelRecord(plant.label, plant.value, member, figs["continuous"],
                           figs.get("sampled"))


def _segment_directions(a: MimoPlant, b: MimoPlant, specs: MimoSpecs) -> dict:
    """``{loop: (dC, dD)}``: how the parallel realisation's ``C, D`` move with ``lam``."""
    out = {}
    p0, p1 = combination(a, b, 0.0), combination(a, b, 1.0)
    out["continuous"] = (p1.C - p0.C, p1.D - p0.D)
    if specs.sampled:
        s0, s1 = (sampled_mimo(p, specs.sample_rate_hz, specs.delay_samples) for p in (p0, p1))
        out["sampled"] = (s1.C - s0.C, s1.D - s0.D)
    return out


def _segment(family, i, ctrl, specs, rtol, points, budget, members):
    """Check segment ``i`` (module docstring): its records, violations and proof."""
    a, b = family.models[i], family.models[i + 1]
    pert = _segment_directions(a, b, specs)

    def at(lam):
        v = a.value + lam * (b.value - a.value)
        p = combination(a, b, lam, label=f"{family.parameter}={v:.6g}", value=v)
        if lam in (0.0, 1.0):       # a member: its own figures, the radius on the segment
            own = members[i + int(lam)]
            loops = _loops(p, ctrl, specs)
            figs = {k: replace(own.loop(k), radius=stability_radius(lp, *pert[k]))
                    for k, lp in loops.items()}
            return replace(own, continuous=figs["continuous"], sampled=figs.get("sampled"))
        return _record(p, ctrl, specs, False, False, pert)

    recs = {lam: at(lam) for lam in np.linspace(0.0, 1.0, points + 2)}
    bounds = specs.bounded
    loops = [lp for lp in LOOPS if recs[0.0].loop(lp) is not None]
    left = budget

    def gaps():
        """Intervals where no checked point proves stability, per loop."""
        out = []
        for loop in loops:
            lams = sorted(recs)
            cov = []
            for lam in lams:
                lf = recs[lam].loop(loop)
                r = lf.radius if lf.stable and lf.radius is not None else 0.0
                cov.append((lam - r, lam + r))
            reach = 0.0
            for lo, hi in sorted(cov):
                if lo > reach:
                    out.append((reach, lo))
                reach = max(reach, hi)
            if reach < 1.0:
                out.append((reach, 1.0))
        return out

    def unresolved():
        out = []
        lams = sorted(recs)
        for x, y in zip(lams[:-1], lams[1:]):
            for loop in loops:
                fa, fb = recs[x].loop(loop), recs[y].loop(loop)
                if not (fa.stable and fb.stable):
                    continue
                for fig, bd in bounds.items():
                    va, vb = fa.value(fig), fb.value(fig)
                    if va is None or vb is None:
                        continue
                    room = min(bd - va, bd - vb)
                    if room > 0 and abs(va - vb) > REFINE_RATIO * room:
                        out.append((x, y, fig, loop))
        return out

    while left > 0:
        todo = set()
        for lo, hi in gaps():
            lams = sorted(recs)
            inside = [lam for lam in lams if lo <= lam <= hi]
            # a gap between points: its midpoint; around an unstable point: nothing to add
            if not any(not recs[lam].loop(lp).stable for lam in inside for lp in loops):
                todo.add(0.5 * (lo + hi))
        for x, y, _, _ in unresolved():
            todo.add(0.5 * (x + y))
        todo = sorted(todo - set(recs))[:left]
        if not todo:
            break
        for lam in todo:
            recs[lam] = at(lam)
        left -= len(todo)
    viols = []
    for lam in sorted(recs):
        if lam in (0.0, 1.0):
            continue        # the members' own records carry their figures
        viols += _violations(recs[lam], specs, rtol)
    proof = {}
    for loop in loops:
        g = [(lo, hi) for lo, hi in gaps()]
        ok = not g and all(recs[lam].loop(loop).stable for lam in recs)
        proof[loop] = SegmentLoopProof("small_gain" if ok else "not_proved",
                                       tuple((float(lo), float(hi)) for lo, hi in g))
        if not ok and all(recs[lam].loop(loop).stable for lam in recs):
            viols.append(MimoViolation(f"{a.label}..{b.label}", None, "stability between"
                                       f" {a.value:g} and {b.value:g} {family.unit} not proved"
                                       " (small-gain intervals leave a gap)", 0.0, 0.0, None,
                                       loop, "unresolved"))
    for x, y, fig, loop in unresolved():
        va = a.value + x * (b.value - a.value)
        vb = a.value + y * (b.value - a.value)
        viols.append(MimoViolation(f"{a.label}..{b.label}", va, f"{fig} changes too fast"
                                   f" between {va:.6g} and {vb:.6g} {family.unit} to be"
                                   " resolved by the sweep", 0.0, 0.0, None, loop,
                                   "unresolved"))
    inner = [replace(r, member=False) for lam, r in sorted(recs.items())
             if lam not in (0.0, 1.0)]
    # the radius of the members' own points, for the record
    radius = {lam: {lp: recs[lam].loop(lp).radius for lp in loops} for lam in (0.0, 1.0)}
    return inner, viols, MimoSegment((a.label, b.label), (a.value, b.value), len(recs),
                                     proof, radius[0.0], radius[1.0])


def check_models(models: Sequence[MimoPlant], ctrl: MimoController, specs: MimoSpecs, rtol: float = 1e-3,
                 full: bool = False) -> tuple[list[MimoModelRecord], list[MimoViolation]]:
    """The figures and violations of each model (no interval check): the program's rounds.

    Parameters
    ----------
    models : sequence of MimoPlant
        Continuous plants.
    ctrl : MimoController
    specs : MimoSpecs
    rtol : float
    full : bool
        Every figure (as a certificate's members), or the bounded ones only.

    Returns
    -------
    records : list of MimoModelRecord
    violations : list of MimoViolation
    """
    recs, viols = [], []
    with one_blas_thread():
        for mdl in models:
            rec = _record(mdl, ctrl, specs, True, full)
            recs.append(rec)
            viols += _violations(rec, specs, rtol)
    return recs, viols


def certify_mimo(family: MimoFamily, ctrl: MimoController, specs: MimoSpecs,
                 rtol: float = 1e-3, points: int = 2, budget: int = 12,
                 interval: bool = True) -> MimoCertificate:
    """Certify ``ctrl`` on ``family`` (module docstring).

    Parameters
    ----------
    family : MimoFamily
    ctrl : MimoController
    specs : MimoSpecs
    rtol : float
        Relative tolerance on the bounds.
    points : int
        Inner points checked per segment before refinement.
    budget : int
        Further points per segment (stability gaps and the refinement).
    interval : bool
        Check between members (``False``: the members only; nothing is then proved
        between them and the certificate says so).

    Returns
    -------
    MimoCertificate

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoFamily, MimoPlant
    >>> from robrst.core.mimo_loop import MimoController
    >>> from robrst.core.rst import RSTController
    >>> from robrst.problem.mimo import MimoSpecs
    >>> G = MimoPlant(-np.eye(2), np.eye(2), [[1.0, 0.2], [0.1, 1.0]], np.zeros((2, 2)))
    >>> K = MimoController([RSTController([1.0], [1.0, 0.0], [1.0])] * 2)
    >>> cert = certify_mimo(MimoFamily((G,)), K, MimoSpecs(sigma_S_max=2.0))
    >>> cert.certified, round(cert.worst("sigma_S"), 4)
    (True, 1.541)
    """
    with one_blas_thread():
        recs, viols = [], []
        for mdl in family.models:
            rec = _record(mdl, ctrl, specs, True, True)
            recs.append(rec)
            viols += _violations(rec, specs, rtol)
        segments, statement = [], ""
        if len(family.models) > 1 and interval:
            members = list(recs)
            for i in range(len(family.models) - 1):
                inner, v, seg = _segment(family, i, ctrl, specs, rtol, points, budget,
                                         members)
                recs += inner
                viols += v
                segments.append(seg)
            statement = (
                "closed-loop stability proved for every convex combination of neighbouring"
                " models (small-gain theorem around every checked point, the intervals"
                " covering each segment); peaks exact at every checked point, on a sweep"
                f" refined until no bounded figure changes by more than {REFINE_RATIO:g} x"
                " its margin between neighbouring points")
        elif len(family.models) > 1:
            statement = "the family's models only; nothing checked between them"
            viols.append(MimoViolation("family", None, "not checked between the models"
                                       " (interval = False)", 0.0, 0.0, None, "continuous",
                                       "unresolved"))
        else:
            statement = "a single model"
        recs.sort(key=lambda r: (r.value if r.value is not None else 0.0, not r.member))
    return MimoCertificate(certified=not viols, models=tuple(recs), violations=tuple(viols),
                           bounds=specs.bounded, rtol=rtol,
                           interval=MimoInterval(family.parameter, tuple(family.range),
                                                 tuple(segments), statement),
                           parameter=family.parameter, unit=family.unit)


def certify_mimo_problem(problem: MimoProblem, ctrl: MimoController,
                         interval: bool = True) -> MimoCertificate:
    """Certify ``ctrl`` on a problem's family and specs with its solver options.

    Parameters
    ----------
    problem : MimoProblem
    ctrl : MimoController
    interval : bool
        Check between the family's members too.

    Returns
    -------
    MimoCertificate
    """
    so = problem.solver
    return certify_mimo(problem.family, ctrl, problem.specs, rtol=so.cert_tol,
                        points=so.cert_points, interval=interval)
