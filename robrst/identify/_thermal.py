"""The temperature family of identified models: the per-kelvin laws and their uncertainty.

Records at several temperatures give one model per temperature (:mod:`robrst.identify.
identification`).  Each model's modal parameters — static gain, natural frequency and
damping of every resonant pair, the real poles — get a covariance from its own fit
(:func:`modal_parameters`: the output-error problem linearised at the fit,
:func:`robrst.identify.vf.output_error_jacobian`, then the delta method), and
:func:`thermal_law` fits the thermal law robrst designs with
(:mod:`robrst.core.thermal`: ``resonance_per_K``, ``damping_per_K``, ``gain_per_K`` around
the reference temperature) by weighted least squares, with 1-sigma uncertainties.  The law
*holds* (``consistent``) when every model agrees with it within its uncertainty
(chi-square, 5 standard deviations): the same structure at every temperature, real poles
that do not move, one relative change per kelvin for every resonance, and (with three
temperatures or more) changes linear in temperature.  ``robrst identify`` then writes the
family as ``[family.parametric]`` (the twin and the sweeps take its laws); otherwise the
explicit models, and says why.
"""

from dataclasses import dataclass, field

import numpy as np

from robrst.identify.vf import fit_residues, output_error_jacobian, to_continuous

__all__ = ["ModalParameters", "ThermalLaw", "modal_parameters", "thermal_law", "polish_fit",
           "long_run_scores", "MAX_ORDER", "SIGMAS"]

MAX_ORDER = 12          # the covariance is computed up to this order (a dense Jacobian)
SIGMAS = 5.0            # agreement: chi-square's mean plus this many standard deviations
REL_FLOOR = 1e-7        # a relative standard deviation never below this (noise-free records)
NOT_RESONANT = 0.999    # the thermal law's resonant pairs (robrst.core.thermal)


@dataclass(frozen=True, eq=False)
class ModalParameters:
    """One model's modal parameters and their covariance.

    Attributes
    ----------
    temperature_C : float
    gain : float
        Static gain [µm/V].
    pairs : tuple of (float, float)
        Resonances ``(wn [rad/s], zeta)`` by frequency.
    real : tuple of float
        Real poles' magnitudes [rad/s].
    cov : numpy.ndarray or None
        Covariance of :attr:`vector` (``None`` when not computed).
    """

    temperature_C: float
    gain: float
    pairs: tuple
    real: tuple
    cov: np.ndarray = None

    @property
    def vector(self):
        """``[gain, wn..., zeta..., real...]``."""
        return np.array([self.gain, *(w for w, _ in self.pairs), *(z for _, z in self.pairs),
                         *self.real], float)

    @property
    def std(self):
        """1-sigma of :attr:`vector` (zeros without a covariance)."""
        if self.cov is None:
            return np.zeros(self.vector.size)
        return np.sqrt(np.maximum(np.diag(self.cov), 0.0))


def _params(model):
    """(gain, pairs, real) of a SISO continuous modal model."""
    gain = float(model.dc_gain()[0, 0])
    pairs, real = [], []
    for s in model.poles:
        if s.imag > 0:
            wn, z = abs(s), -s.real / abs(s)
            if z < NOT_RESONANT:
                pairs.append((float(wn), float(z)))
            else:
                real += [float(-s.real - abs(s.imag)), float(-s.real + abs(s.imag))]
        else:
            real.append(float(-s.real))
    return gain, tuple(sorted(pairs)), tuple(sorted(real))


HAC_LAGS = 2.0          # Bartlett lags of the long-run covariance: this x N**(1/3)


def long_run_scores(J: np.ndarray, r: np.ndarray, correction: float = 1.0) -> np.ndarray:
    """``J' Omega J``: the covariance of the least-squares scores ``J_t r_t`` for residuals
    that may be correlated (Newey-West: Bartlett weights up to ``HAC_LAGS N**(1/3)`` lags).

    The output-error covariance ``sigma^2 (J'J)^-1`` holds for white noise only; a lab
    record's noise is coloured (the sensor, the drive), which made the resonances' standard
    deviations 2 to 4 times too small.  The sandwich ``(J'J)^-1 J' Omega J (J'J)^-1`` holds
    for white noise (then ``J' Omega J = sigma^2 J'J``) and coloured noise alike.

    Parameters
    ----------
    J : ndarray (N, p)
        The Jacobian of the residuals (rows in time order).
    r : ndarray (N,)
        The residuals.
    correction : float
        Small-sample factor (``N / (N - p)``).

    Returns
    -------
    ndarray (p, p)
    """
    G = J * r[:, None]
    N = len(r)
    out = G.T @ G
    for lag in range(1, min(N - 1, int(np.ceil(HAC_LAGS * N ** (1 / 3)))) + 1):
        w = 1.0 - lag / (np.ceil(HAC_LAGS * N ** (1 / 3)) + 1.0)
        C = G[lag:].T @ G[:-lag]
        out += w * (C + C.T)
    return out * correction


POLISH_STEPS = 8        # Gauss-Newton steps onto the output-error optimum
POLISH_TOL = 1e-12      # stop when the residual falls by less than this, relatively


def polish_fit(data: object, dm: object, feedthrough: bool = False, markov: int = 0) -> object:
    """The fit moved onto the output-error least-squares optimum (Gauss-Newton, halved
    steps), where the covariance of :func:`modal_parameters` holds.

    The vector-fitting iterations end near, not at, the optimum of the output error: on
    records of an exactly linear law the resonances came out 2 to 3 of their own standard
    deviations from the truth (the covariance is that of the optimum), and the law was
    rejected.  A few Gauss-Newton steps on :func:`robrst.identify.vf.output_error_jacobian`
    close the gap: each moves the poles, the residues are solved again for them (the
    Markov constraints hold exactly), and a step is accepted only when the residual falls.

    Parameters
    ----------
    data : FitData
        What ``dm`` was fitted on.
    dm : DiscreteModel
        The fit.
    feedthrough : bool
    markov : int
        Markov parameters constrained to zero (kept so).

    Returns
    -------
    DiscreteModel
        The polished fit (``dm`` itself when no step lowers the residual).
    """
    J, r, theta, model_of, _ = output_error_jacobian(data, dm, feedthrough, markov)
    cost = float(r @ r)
    for _ in range(POLISH_STEPS):
        step = np.linalg.lstsq(J, r, rcond=None)[0]
        t, moved = 1.0, False
        while t >= 1.0 / 64:
            try:     # the step's poles, their residues solved again (the Markov
                # constraints depend on the poles: exact only for the residues of these)
                cand = fit_residues(data, model_of(theta - t * step).zpoles, feedthrough,
                                    markov=markov)[0]
                Jc, rc, thc, mc, _ = output_error_jacobian(data, cand, feedthrough, markov)
            except (ValueError, np.linalg.LinAlgError):
                rc = None
            if rc is not None and np.all(np.isfinite(rc)) and float(rc @ rc) < cost \
                    and np.all(np.abs(cand.zpoles) < 1):
                moved = True
                break
            t /= 2
        if not moved:
            break
        gain = cost - float(rc @ rc)
        dm, J, r, theta, model_of, cost = cand, Jc, rc, thc, mc, float(rc @ rc)
        if gain <= POLISH_TOL * cost:
            break
    return dm


def modal_parameters(data: object, dm: object, temperature_C: float, feedthrough: bool = False,
                     markov: int = 0) -> ModalParameters:
    """The modal parameters of a fitted sampled model and their covariance.

    Parameters
    ----------
    data : FitData
        What the model was fitted on.
    dm : DiscreteModel
        The fit (one input and one output).
    temperature_C : float
    feedthrough : bool
    markov : int
        Markov parameters constrained to zero in the fit (:func:`robrst.identify.vf.
        relative_degree`).

    Returns
    -------
    ModalParameters
        ``cov`` is ``sigma^2 g' (J'J)^+ g'^T`` (``sigma^2`` the residual per degree of
        freedom; ``g'`` the parameters' derivatives by central differences), or ``None``
        above :data:`MAX_ORDER`.
    """
    gain, pairs, real = _params(to_continuous(dm))
    out = ModalParameters(temperature_C, gain, pairs, real)
    if int(np.sum(np.where(dm.zpoles.imag > 0, 2, 1))) > MAX_ORDER:
        return out
    J, r, theta, model_of, dof = output_error_jacobian(data, dm, feedthrough, markov)
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    Js = J / scale
    inv = np.linalg.pinv(Js.T @ Js, rcond=1e-13)
    cov_theta = inv @ long_run_scores(Js, r, r.size / dof) @ inv / np.outer(scale, scale)

    def g(th):
        gn, pr, re = _params(to_continuous(model_of(th)))
        if len(pr) != len(pairs) or len(re) != len(real):
            return None
        return np.array([gn, *(w for w, _ in pr), *(z for _, z in pr), *re], float)

    G = []
    for q in range(theta.size):
        h = 1e-6 * max(abs(theta[q]), 1e-3)
        up, dn = theta.copy(), theta.copy()
        up[q] += h
        dn[q] -= h
        a, b = g(up), g(dn)
        if a is None or b is None:
            return out
        G.append((a - b) / (2 * h))
    G = np.array(G).T
    return ModalParameters(temperature_C, gain, pairs, real, G @ cov_theta @ G.T)


@dataclass(frozen=True)
class ThermalLaw:
    """The per-kelvin laws fitted to a temperature family (see the module docstring).

    Attributes
    ----------
    reference_C : float
        Where the laws are centred [°C].
    gain_per_K, resonance_per_K, damping_per_K : float
        robrst's thermal law (:mod:`robrst.core.thermal`).
    std : dict
        1-sigma of each coefficient.
    consistent : bool
        Every model agrees with the law within its uncertainty.
    note : str
        Why not, when not.
    temperatures_C : tuple of float
        The models' temperatures.
    """

    reference_C: float
    gain_per_K: float = 0.0
    resonance_per_K: float = 0.0
    damping_per_K: float = 0.0
    std: dict = field(default_factory=dict)       # 1-sigma of each coefficient
    consistent: bool = False
    note: str = ""
    temperatures_C: tuple = ()

    def as_dict(self) -> dict:
        """The ``thermal`` object of ``robrst identify --json``.

        Returns
        -------
        dict
        """
        return {"reference_C": self.reference_C, "temperatures_C": list(self.temperatures_C),
                "law": {k: getattr(self, k) for k in ("gain_per_K", "resonance_per_K",
                                                      "damping_per_K")},
                "std": dict(self.std), "consistent": self.consistent, "note": self.note}


def _sd(v, s):
    return np.maximum(np.asarray(s, float), REL_FLOOR * np.abs(np.asarray(v, float)))


def _line(dT, v, s):
    """Weighted ``v = a + b dT``: (a, b, cov[a, b], chi2, dof)."""
    w = 1.0 / s ** 2
    X = np.column_stack([np.ones_like(dT), dT])
    C = np.linalg.inv(X.T @ (X * w[:, None]))
    a, b = C @ (X.T @ (w * v))
    chi2 = float(np.sum(w * (v - a - b * dT) ** 2))
    dof = len(v) - 2
    if dof > 0 and chi2 > dof:           # scatter beyond the stated uncertainty: inflate
        C = C * chi2 / dof
    return a, b, C, chi2, dof


def _relative(dT, v, s):
    """Relative slope ``b / a`` of ``v = a (1 + rel dT)`` and its 1-sigma, and the line's
    agreement (chi2, dof)."""
    a, b, C, chi2, dof = _line(dT, v, s)
    rel = b / a
    var = (C[1, 1] - 2 * rel * C[0, 1] + rel ** 2 * C[0, 0]) / a ** 2
    return rel, float(np.sqrt(max(var, 0.0))), chi2, dof


def _agrees(chi2, dof):
    return dof <= 0 or chi2 <= dof + SIGMAS * np.sqrt(2.0 * dof)


def _combine(rels, sds):
    """Inverse-variance mean of one coefficient measured on several resonances, its
    1-sigma and whether they agree."""
    rels, sds = np.asarray(rels), np.maximum(np.asarray(sds), 1e-300)
    w = 1.0 / sds ** 2
    mean = float(np.sum(w * rels) / np.sum(w))
    chi2 = float(np.sum(w * (rels - mean) ** 2))
    return mean, float(1.0 / np.sqrt(np.sum(w))), _agrees(chi2, len(rels) - 1)


def _gain_note(dT, gain, sd, n_pairs, r):
    """Why the law's gain fails: ``gain_per_K`` scales the numerator B (the static gain
    times ``wn^2`` of every resonant pair), so a static gain linear in temperature with a
    moving resonance makes B quadratic; the note says which of the two is not linear."""
    if not n_pairs:
        return "the static gain does not change linearly with temperature"
    why = ("the numerator's gain (the static gain times wn^2 of each resonance: what"
           " gain_per_K scales) does not change linearly with temperature")
    g, _, chi2, dof = _relative(dT, gain, sd)
    if dof > 0 and _agrees(chi2, dof):
        why += (f"; the static gain alone does ({100 * g:+.3g} %/K), but with the resonance"
                f" moving {100 * r:+.3g} %/K the numerator is quadratic in temperature")
    return why


def thermal_law(params: list, reference_C: float) -> ThermalLaw:
    """Fit the per-kelvin laws to models at several temperatures.

    Parameters
    ----------
    params : sequence of ModalParameters
        One per temperature (at least two).
    reference_C : float
        Where the laws are centred (the nominal model's temperature).

    Returns
    -------
    ThermalLaw
        ``consistent`` says whether robrst's thermal law describes the family within the
        models' uncertainty; ``note`` says why not.
    """
    temps = tuple(float(p.temperature_C) for p in params)
    base = ThermalLaw(reference_C=float(reference_C), temperatures_C=temps)
    shapes = {(len(p.pairs), len(p.real)) for p in params}
    if len(params) < 2:
        return base
    if len(shapes) > 1:
        return ThermalLaw(**{**base.__dict__, "note": "the models differ in structure"
                             " (resonances and real poles) between temperatures"})
    if any(p.cov is None for p in params):
        return ThermalLaw(**{**base.__dict__, "note": f"order above {MAX_ORDER}: no"
                             " uncertainty, no law fitted"})
    dT = np.array(temps) - reference_C
    V = np.array([p.vector for p in params])
    S = _sd(V, np.array([p.std for p in params]))
    n_pairs = len(params[0].pairs)
    notes = []
    rs, rsd, zs, zsd = [], [], [], []
    for i in range(n_pairs):
        r, sd, chi2, dof = _relative(dT, V[:, 1 + i], S[:, 1 + i])
        rs.append(r)
        rsd.append(sd)
        if not _agrees(chi2, dof):
            notes.append(f"resonance {i + 1} does not change linearly with temperature")
        z, sdz, chi2, dof = _relative(dT, V[:, 1 + n_pairs + i], S[:, 1 + n_pairs + i])
        zs.append(z)
        zsd.append(sdz)
        if not _agrees(chi2, dof):
            notes.append(f"the damping of resonance {i + 1} does not change linearly with"
                         " temperature")
    r = sdr = z = sdz = 0.0
    if n_pairs:
        r, sdr, ok = _combine(rs, rsd)
        if not ok:
            notes.append("the resonances move by different relative amounts per kelvin")
        z, sdz, ok = _combine(zs, zsd)
        if not ok:
            notes.append("the resonances' dampings change by different relative amounts")
    # B scales by 1 + g dT; the static gain also by (1 + r dT)^-2 per resonant pair
    corr = (1.0 + r * dT) ** (2 * n_pairs)
    g, sdg, chi2, dof = _relative(dT, V[:, 0] * corr, S[:, 0] * corr)
    sdg = float(np.hypot(sdg, 2 * n_pairs * sdr))
    if not _agrees(chi2, dof):
        notes.append(_gain_note(dT, V[:, 0], S[:, 0], n_pairs, r))
    for k in range(1 + 2 * n_pairs, V.shape[1]):
        w = 1.0 / S[:, k] ** 2
        mean = np.sum(w * V[:, k]) / np.sum(w)
        chi2 = float(np.sum(w * (V[:, k] - mean) ** 2))
        if not _agrees(chi2, len(temps) - 1):
            notes.append(f"a real pole moves with temperature ({V[0, k]:.4g} rad/s at"
                         f" {temps[0]:g} °C, {V[-1, k]:.4g} at {temps[-1]:g} °C): the law"
                         " keeps real poles")
    return ThermalLaw(reference_C=float(reference_C), gain_per_K=float(g),
                      resonance_per_K=float(r), damping_per_K=float(z),
                      std={"gain_per_K": sdg, "resonance_per_K": sdr, "damping_per_K": sdz},
                      consistent=not notes, note="; ".join(notes), temperatures_C=temps)
