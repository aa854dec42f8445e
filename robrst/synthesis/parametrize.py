"""The decision vector of the synthesis and the controller it stands for.

``S = Sf S'`` (``S'`` monic of degree ``ks``) and ``R = Rf R'`` (degree ``kr``), written
in the scaled variable ``p = s / w0`` and normalised (:meth:`robrst.core.poly.Scaling.normalize`)
so every coefficient is O(1).  The decision vector is ``x = [S' (non-leading), R']``.
:class:`Parametrization` maps a controller to ``x`` and back; the NLP, the convex
program and the robust driver share it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.base.errors import SolverError
from robrst.core.rst import RSTController
from robrst.synthesis import analytic

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.family import PlantFamily
    from robrst.core.plant import Plant
    from robrst.problem.records import ControllerStructure

__all__ = ["Parametrization", "TrackingRule", "integral_gain", "frequency_grid"]


def _scaled_factor(F, scaling):
    Fs = scaling.apply(poly.trim(F))
    return Fs / Fs[0]


@dataclass(frozen=True, eq=False)
class Parametrization:
    """Degrees, fixed factors and scaling of the controller's free coefficients.

    Use :meth:`of` to build it from a controller structure and the nominal plant.

    Parameters
    ----------
    scaling : Scaling
        The frequency scaling of the decision vector.
    S_fixed, R_fixed : numpy.ndarray
        The unscaled fixed factors of S and R.
    Sf : numpy.ndarray
        The scaled fixed factor of S, monic.
    Rf : numpy.ndarray
        The scaled fixed factor of R, leading coefficient 1.
    ks : int
        Degree of ``S'``.
    kr : int
        Degree of ``R'``.
    deg_s : int
        Degree of S.

    Attributes
    ----------
    n_x : int
        Length of the controller part of the decision vector.
    integrators : int
        Number of roots at ``s = 0`` in the fixed factor of S.
    """

    scaling: poly.Scaling
    S_fixed: np.ndarray     # unscaled fixed factors
    R_fixed: np.ndarray
    Sf: np.ndarray          # scaled, monic
    Rf: np.ndarray          # scaled, leading coefficient 1
    ks: int                 # degree of S'
    kr: int                 # degree of R'
    deg_s: int              # degree of S

    @classmethod
    def of(cls, structure: ControllerStructure, plant: Plant, scaling: poly.Scaling,
           extra_degree: int | None = None) -> Parametrization:
        """The parametrisation of ``structure`` for ``plant``.

        Parameters
        ----------
        structure : ControllerStructure
            Fixed factors and degrees.
        plant : Plant
            The nominal model.
        scaling : Scaling
            The frequency scaling.
        extra_degree : int, optional
            Overrides the structure's (the lower-degree problems of the homotopy).

        Returns
        -------
        Parametrization
        """
        Sf, Rf = poly.trim(structure.S_total), poly.trim(structure.R_fixed)
        extra = structure.extra_degree if extra_degree is None else extra_degree
        rel = structure.controller_relative_degree
        deg_am = analytic.closed_loop_degree(plant.n, plant.m, Sf, Rf, extra, rel)
        deg_s = deg_am - plant.n
        ks = deg_s - (len(Sf) - 1)
        kr = deg_s - rel - (len(Rf) - 1)  # R up to deg S - rel: extra degrees are free
        return cls(scaling=scaling, S_fixed=Sf, R_fixed=Rf, Sf=_scaled_factor(Sf, scaling),
                   Rf=_scaled_factor(Rf, scaling), ks=ks, kr=kr, deg_s=deg_s)

    @property
    def n_x(self):
        """Length of the controller part of the decision vector."""
        return self.ks + self.kr + 1

    @property
    def integrators(self):
        """Number of roots at ``s = 0`` in the fixed factor of S."""
        nz = np.flatnonzero(self.S_fixed)
        return len(self.S_fixed) - 1 - int(nz[-1])

    def vector(self, ctrl: RSTController) -> np.ndarray:
        """The scaled decision vector of a controller that contains the fixed factors.

        Parameters
        ----------
        ctrl : RSTController
            A controller of this structure's degrees.

        Returns
        -------
        numpy.ndarray
            ``[S' (non-leading coefficients), R']`` scaled.

        Raises
        ------
        SolverError
            Wrong degrees, or the fixed factors are not factors of ``ctrl`` (the division's
            remainder above 1e-8 of the largest normalised coefficient divided).
        """
        sc, n = self.scaling, self.deg_s
        pad = lambda c: np.concatenate([np.zeros(n + 1 - len(c)), c])  # noqa: E731
        if len(poly.trim(ctrl.S)) != n + 1 or len(poly.trim(ctrl.R)) > len(self.R_fixed) + self.kr:
            raise SolverError("initial controller has the wrong degrees for the structure")
        Ss, Rs = sc.normalize(pad(ctrl.S), n), sc.normalize(pad(ctrl.R), n)
        sp, rem = np.polydiv(Ss, self.Sf)
        rp, rem2 = np.polydiv(Rs, self.Rf)
        # remainders relative to the coefficients divided (rounding grows with their size)
        if (np.max(np.abs(rem)) > 1e-8 * max(1, np.max(np.abs(Ss)))
                or np.max(np.abs(rem2)) > 1e-8 * max(1, np.max(np.abs(Rs)))):
            raise SolverError("initial controller does not contain the fixed factors")
        if len(rp) > self.kr + 1:          # leading zeros of the padding
            rp = rp[len(rp) - self.kr - 1:]
        rp = np.concatenate([np.zeros(self.kr + 1 - len(rp)), rp]) / sp[0]
        sp = sp / sp[0]
        return np.concatenate([sp[1:], rp])

    def controller(self, x: np.ndarray, tracking: TrackingRule) -> RSTController:
        """The unscaled RST controller of the decision vector ``x``.

        Parameters
        ----------
        x : numpy.ndarray
            The decision vector (its controller part).
        tracking : TrackingRule
            Builds T from R.

        Returns
        -------
        RSTController
        """
        sp = np.concatenate([[1.0], x[:self.ks]])
        rp = x[self.ks:self.n_x]
        S = self.scaling.denormalize(np.polymul(self.Sf, sp), self.deg_s)
        R = poly.trim(self.scaling.denormalize(np.polymul(self.Rf, rp), self.deg_s))
        k = self.integrators
        S[len(S) - k:] = 0.0  # the integrators are structural (exact zeros, not 1e-300)
        return RSTController(R=R, S=S, T=tracking(R))

    def embed(self, ctrl: RSTController, root: float) -> np.ndarray | None:
        """``ctrl`` of a lower degree raised to this one: R and S times ``(s - root)``.

        The controller ``R/S`` is unchanged (a common factor).

        Parameters
        ----------
        ctrl : RSTController
            A controller of a lower degree.
        root : float
            The common root added [rad/s].

        Returns
        -------
        numpy.ndarray or None
            The decision vector, or ``None`` if the degrees do not fit.
        """
        f = poly.from_roots([root])
        R, S = poly.pmul(ctrl.R, f), poly.pmul(ctrl.S, f)
        if len(S) != self.deg_s + 1:
            return None
        try:
            return self.vector(RSTController(R=R, S=S, T=ctrl.T))
        except SolverError:
            return None


@dataclass(frozen=True, eq=False)
class TrackingRule:
    """``T`` from ``R`` with unit static gain (``T(0) = R(0)``): the structure's T_mode.

    Calling it with R returns T.

    Parameters
    ----------
    mode : str
        ``"static"`` (a constant T), else the paper's ``T = Bm_aux``.
    zeros : tuple of float
        Zeros of ``Bm_aux`` [rad/s].
    B : numpy.ndarray
        Numerator of the nominal plant.
    """

    mode: str
    zeros: tuple
    B: np.ndarray          # numerator of the nominal plant

    def __call__(self, R):
        Am0 = np.array([R[-1] * self.B[-1]])
        if self.mode == "static":
            return analytic.tracking_polynomial("static", R, self.B, Am0, np.ones(1))
        return analytic.tracking_polynomial("paper", R, self.B, Am0, np.ones(1), self.zeros)


def integral_gain(ctrl: RSTController) -> float:
    """``lim_{s->0} s R/S`` [V/(µm s)]: the low-frequency disturbance-rejection gain.

    Computed from its definition: with ``k`` roots of ``S`` and ``m`` of ``R`` at ``s = 0``
    (:func:`robrst.core.poly.origin_roots`), ``s R/S`` behaves as ``s**(1 + m - k)`` near
    0.  One integrator more in ``S`` than in ``R`` gives the ratio of their lowest
    non-zero coefficients; a controller **without an integrator** (``S(0) != 0``) gives
    **0** (it rejects no constant disturbance); more integrators give ``inf``.

    Parameters
    ----------
    ctrl : RSTController
        The controller.

    Returns
    -------
    float
        0 without an integrator; ``inf`` when ``S`` has more roots at ``s = 0`` than ``R``
        plus one (JSON: ``null``).

    Examples
    --------
    >>> from robrst.core.rst import RSTController
    >>> from robrst.synthesis.parametrize import integral_gain
    >>> integral_gain(RSTController([3.0, 6.0], [1.0, 2.0, 0.0], [6.0]))   # (3s + 6)/(s^2 + 2s)
    3.0
    >>> integral_gain(RSTController([3.0, 6.0], [1.0, 2.0, 5.0], [6.0]))   # no integrator
    0.0
    """
    R, S = poly.trim(ctrl.R), poly.trim(ctrl.S)
    if not np.any(R):
        return 0.0
    k, m = poly.origin_roots(S), poly.origin_roots(R)
    if 1 + m - k > 0:
        return 0.0
    if 1 + m - k < 0:
        return float("inf")
    return float(R[len(R) - 1 - m] / S[len(S) - 1 - k])


RESONANCE_DAMPING = 0.1     # poles less damped than this get a dense grid around them


def _resonance_points(roots):
    """Points every half damping bandwidth within +-10 of them around lightly damped roots."""
    out = []
    for r in roots:
        w = abs(r)
        if w == 0 or r.imag <= 0:
            continue
        z = -r.real / w
        if z < RESONANCE_DAMPING:
            h = max(z, 1e-4)
            out.append(w * (1 + 0.5 * h * np.arange(-10, 11)))
    return out


def frequency_grid(family: PlantFamily, Am: ArrayLike, n_freq: int) -> np.ndarray:
    """The NLP's frequency grid [rad/s]: log-spaced around every pole, zero and Am root,
    dense around every lightly damped pole of every model (their peaks are narrow).

    Parameters
    ----------
    family : PlantFamily
        The models.
    Am : array_like
        The nominal characteristic polynomial.
    n_freq : int
        The grid's base size (``solver.n_freq``).

    Returns
    -------
    numpy.ndarray
        Increasing positive frequencies.
    """
    roots = [np.abs(np.roots(Am))]
    extra = []
    for m in family.models:
        p = m.poles()
        roots.append(np.abs(p))
        extra += _resonance_points(p)
        if m.m:
            roots.append(np.abs(m.zeros()))
    r = np.concatenate(roots)
    r = r[r > 0]
    lo, hi = r.min() / 30.0, r.max() * 30.0
    extra += [[np.max(np.abs(m.poles().imag)) for m in family.models]]
    far = [hi * 1e2, hi * 1e4]  # the high-frequency limits of |S|, |U| (peaks at infinity)
    pts = np.concatenate([np.geomspace(lo, hi, n_freq), *extra, far])
    return np.unique(pts[pts > 0])
