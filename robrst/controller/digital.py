"""The digital RST controller: a cascade of first- and second-order sections (Tustin).

A controller ``S u = T yr - R y`` designed in s has coefficients from 1 to 1e19; its
Tustin image in direct form (``R_z, S_z, T_z``, :func:`robrst.core.rst.tustin_polynomials`)
has O(1) coefficients, but poles close to ``z = 1`` (an integrator, slow poles, fast
sampling) make the direct form ill conditioned: a relative error ``eps`` in a
coefficient moves such a pole by about ``eps**(1/m)`` for an m-fold cluster.  What runs
on the target is therefore this realisation:

* **Factors.** The roots of S, computed in the scaled variable ``p = s/w0``
  (:class:`robrst.core.poly.Scaling`), give one first-order section per real root and one
  second-order section per complex pair, ordered slowest (inner) to fastest (outer).
* **Nesting.** ``[T, -R]/S = D + (1/S_m)(b_m + (1/S_m-1)(b_m-1 + ... (1/S_1) b_1))``
  (mixed-radix division by the factors, slowest first): section ``k`` filters the
  output ``w`` of section ``k - 1`` plus ``b_k [yr, y]``; one state per pole, states
  shared by both inputs, repeated poles (a double integrator) a Jordan chain for free.
* **Tustin per section**, exact (the bilinear map commutes with series connection),
  stored in **delta (increment) form** ``x <- x + F x + G v`` with ``F = Ad - I``
  computed without cancellation: a pole at ``z = 1 - 1e-6`` is a coefficient
  ``-1e-6`` known to full relative precision, not ``0.999999`` rounded.  An integrator
  is ``F = 0`` exactly, in any precision.
* **Anti-windup** by back-calculation: ``x <- x + ... + L (sat(u) - u)`` with ``L``
  placing the eigenvalues of ``Ad - L C`` (the controller's dynamics while saturated)
  at real, distinct, stable poles (:func:`aw_poles`; a Kalman-predictor gain when that
  placement is ill conditioned).  Without saturation ``L`` does nothing.

One step (``v_k = [w_k-1, yr, y]``, ``w_0 = 0``)::

    w_k = H_k x_k + J_k v_k           k = 1..m   (inner to outer)
    u   = w_m + D [yr, y];  us = clamp(u, u_min, u_max)
    x_k = x_k + (F_k x_k + G_k v_k + L_k (us - u))
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.base.errors import SpecError
from robrst.core.rst import RSTController, as_controller, tustin_polynomials

if TYPE_CHECKING:
    import control
    from numpy.typing import ArrayLike

__all__ = ["Section", "DigitalController", "digital_controller", "aw_poles", "exact_response",
           "tustin_frequencies"]

AW_SPREAD = 1.25     # ratio between successive anti-windup poles


@dataclass(frozen=True, eq=False)
class Section:
    """One section in delta form: ``x <- x + F x + G v + L du``, ``w = H x + J v``.

    ``v = [w_prev, yr, y]``.

    Parameters
    ----------
    F : numpy.ndarray
        ``n x n`` (``n`` = 1 or 2): ``Ad - I`` of the section.
    G : numpy.ndarray
        ``n x 3``.
    H : numpy.ndarray
        ``1 x n``.
    J : numpy.ndarray
        Length 3.
    L : numpy.ndarray
        Length ``n``: the anti-windup gain.
    pole_rad_s : complex
        The continuous pole [rad/s] (the upper one of a pair) whose Tustin image the
        section holds.

    Attributes
    ----------
    order : int
        ``n``: 1 for a real pole, 2 for a complex pair.
    """

    F: np.ndarray
    G: np.ndarray
    H: np.ndarray
    J: np.ndarray
    L: np.ndarray
    pole_rad_s: complex

    @property
    def order(self):
        return self.F.shape[0]

    def poles_z(self) -> np.ndarray:
        """Discrete poles of the section (eigenvalues of ``I + F``).

        Returns
        -------
        numpy.ndarray
        """
        return 1.0 + np.linalg.eigvals(self.F)

    def sos(self) -> dict[str, list[float]]:
        """The section as transfer functions in ``q^-1``: denominator ``a`` and numerators.

        ``a = [1, a1(, a2)]``; ``b_prev``, ``b_yr``, ``b_y`` from each input.  Formed
        from the delta form (``a1 = -2 - tr F``, ``a2 = 1 + tr F + det F``): the standard
        biquad view, for reading; :class:`DigitalController` runs the delta form.

        Returns
        -------
        dict
            ``{"a", "b_prev", "b_yr", "b_y"}`` -> coefficients, ascending powers of ``q^-1``.
        """
        F, G, H, J = self.F, self.G, self.H.ravel(), self.J
        if self.order == 1:
            f = F[0, 0]
            a = [1.0, -(1.0 + f)]
            nums = [[J[i], H[0] * G[0, i] - J[i] * (1.0 + f)] for i in range(3)]
        else:
            tr, det = np.trace(F), np.linalg.det(F)
            a = [1.0, -2.0 - tr, 1.0 + tr + det]
            Ad = np.eye(2) + F
            M = np.array([[-Ad[1, 1], Ad[0, 1]], [Ad[1, 0], -Ad[0, 0]]])
            nums = [[J[i], H @ G[:, i] + J[i] * a[1], H @ M @ G[:, i] + J[i] * a[2]]
                    for i in range(3)]
        return {"a": [float(x) for x in a],
                **{k: [float(x) for x in n] for k, n in zip(("b_prev", "b_yr", "b_y"), nums)}}

    def as_dict(self) -> dict:
        """The ``sections`` record of the export JSON.

        Returns
        -------
        dict
            ``order, pole_rad_s, poles_z, F, G, H, J, L, sos``.
        """
        return {"order": self.order, "pole_rad_s": [float(np.real(self.pole_rad_s)),
                                                     float(np.imag(self.pole_rad_s))],
                "poles_z": [[float(z.real), float(z.imag)] for z in self.poles_z()],
                "F": self.F.tolist(), "G": self.G.tolist(), "H": self.H.ravel().tolist(),
                "J": self.J.tolist(), "L": self.L.tolist(), "sos": self.sos()}


@dataclass(frozen=True, eq=False)
class DigitalController:
    """The Tustin RST controller at ``sample_rate_hz``: sections, direct form, anti-windup.

    Parameters
    ----------
    ctrl : RSTController
        The controller in s it came from.
    sample_rate_hz : float
        Sampling rate [Hz].
    w0 : float
        The scaling [rad/s] its sections were built in.
    sections : tuple of Section
        Inner to outer.
    D : numpy.ndarray
        The feedthrough ``[d_yr, d_y]`` added to the outer section's output.
    R_z, S_z, T_z : numpy.ndarray
        The same law in direct form (ascending powers of ``q^-1``, ``S_z[0] = 1``).
    aw_poles_z : numpy.ndarray
        The eigenvalues of ``A - L C`` (the dynamics while saturated) achieved.
    aw_method : {"placed", "kalman", "none"}
        How the anti-windup gain was found.

    Attributes
    ----------
    n_states : int
        Total number of states of the sections.
    """

    ctrl: RSTController
    sample_rate_hz: float
    w0: float
    sections: tuple
    D: np.ndarray
    R_z: np.ndarray
    S_z: np.ndarray
    T_z: np.ndarray
    aw_poles_z: np.ndarray
    aw_method: str = "none"

    @property
    def n_states(self):
        return sum(s.order for s in self.sections)

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The assembled realisation ``(A, B, C, D, L)``: ``x+ = A x + B [yr, y] + L du``.

        Returns
        -------
        A, B, C, D, L : numpy.ndarray
            ``u = C x + D [yr, y]``; ``L`` the anti-windup gain.
        """
        n = self.n_states
        A, B, L = np.eye(n), np.zeros((n, 2)), np.zeros(n)
        Cw, Dw = np.zeros(n), np.zeros(2)          # output of the previous section
        i = 0
        for s in self.sections:
            k = slice(i, i + s.order)
            A[k, :] += np.outer(s.G[:, 0], Cw)
            A[k, k] += s.F
            B[k, :] = np.outer(s.G[:, 0], Dw) + s.G[:, 1:]
            L[k] = s.L
            Cw_new = s.J[0] * Cw
            Cw_new[k] += s.H.ravel()
            Cw, Dw = Cw_new, s.J[0] * Dw + s.J[1:]
            i += s.order
        return A, B, Cw.reshape(1, n), (Dw + self.D).reshape(1, 2), L

    def freqresp(self, theta: ArrayLike) -> np.ndarray:
        """``[K_yr, K_y]`` of the sections at ``z = exp(j theta)`` (array ``(len, 2)``).

        Parameters
        ----------
        theta : array_like
            Angles on the unit circle [rad per sample].

        Returns
        -------
        numpy.ndarray
            Complex, shape ``(len(theta), 2)``.
        """
        theta = np.atleast_1d(np.asarray(theta, float))
        zm1 = 2j * np.sin(theta / 2) * np.exp(0.5j * theta)          # z - 1 without cancellation
        W = np.zeros((theta.size, 2), complex)
        for s in self.sections:
            n = s.order
            M = zm1[:, None, None] * np.eye(n) - s.F[None]
            X = np.linalg.solve(M, np.broadcast_to(s.G, (theta.size, n, 3)))
            tf = (s.H.ravel() @ X) + s.J                               # (len, 3)
            W = tf[:, :1] * W + tf[:, 1:]
        return W + self.D

    def to_ss(self) -> control.StateSpace:
        """The sections' realisation as a discrete ``control.StateSpace`` (``dt = 1/fs``).

        Returns
        -------
        control.StateSpace
            Inputs ``yr, y``, output ``u``.
        """
        import control

        A, B, C, D, _ = self.state_space()
        return control.ss(A, B, C, D, 1.0 / self.sample_rate_hz, inputs=["yr", "y"],
                          outputs=["u"])


def tustin_frequencies(theta: ArrayLike, sample_rate_hz: float) -> np.ndarray:
    """Continuous frequencies [rad/s] whose Tustin images are ``exp(j theta)``.

    Parameters
    ----------
    theta : array_like
        Angles on the unit circle [rad per sample].
    sample_rate_hz : float
        Sampling rate [Hz].

    Returns
    -------
    numpy.ndarray
        ``2 fs tan(theta / 2)``.
    """
    return 2.0 * float(sample_rate_hz) * np.tan(np.asarray(theta, float) / 2.0)


def exact_response(ctrl: RSTController, theta: ArrayLike, sample_rate_hz: float) -> np.ndarray:
    """``[T/S, -R/S]`` of the controller in s at the Tustin points of ``theta`` (reference).

    Evaluated on the scaled polynomials, independently of the sections.

    Parameters
    ----------
    ctrl : RSTController
        The controller in s.
    theta : array_like
        Angles on the unit circle [rad per sample].
    sample_rate_hz : float
        Sampling rate [Hz].

    Returns
    -------
    numpy.ndarray
        Complex, shape ``(len(theta), 2)``.
    """
    sc = poly.Scaling.natural(ctrl.S, ctrl.R)
    p = 1j * tustin_frequencies(theta, sample_rate_hz) / sc.w0
    S = np.polyval(sc.apply(ctrl.S), p)
    return np.column_stack([np.polyval(sc.apply(ctrl.T), p) / S,
                            -np.polyval(sc.apply(ctrl.R), p) / S])


def _factors(Ss):
    """Root groups of monic ``Ss``: ``(root, quadratic)``, slowest first."""
    roots = np.roots(Ss)
    out = []
    for r in roots:
        if r.imag == 0.0:
            out.append((complex(r.real), np.array([1.0, -r.real])))
        elif r.imag > 0.0:
            out.append((complex(r), np.array([1.0, -2.0 * r.real, r.real ** 2 + r.imag ** 2])))
    return sorted(out, key=lambda f: (abs(f[0]), f[0].real, f[0].imag))


def _divmod_monic(num, den):
    """Quotient and remainder of ``num`` by monic ``den`` (highest power first)."""
    num = np.array(num, float)
    d = len(den) - 1
    if len(num) <= d:
        return np.zeros(1), np.concatenate([np.zeros(d - len(num)), num])
    for i in range(len(num) - d):
        num[i + 1:i + d + 1] -= num[i] * den[1:]
    return num[:len(num) - d], num[len(num) - d:]


def _section_ct(root, quad, b):
    """Continuous scaled section for ``(w_prev + b e)/quad``: ``(A, B, C)``, inputs 3."""
    if len(quad) == 2:
        return np.array([[root.real]]), np.array([[1.0, b[0][0], b[1][0]]]), np.ones((1, 1))
    sig, om = root.real, root.imag
    rho = max(om, abs(sig))
    A = np.array([[sig, rho], [-om * om / rho, sig]])
    cols = [[0.0, 1.0 / rho]] + [[c[0], (c[1] + sig * c[0]) / rho] for c in b]
    return A, np.array(cols).T, np.array([[1.0, 0.0]])


def aw_poles(ctrl: RSTController, sample_rate_hz: float,
             aw_rad_s: float | None = None) -> np.ndarray:
    """Anti-windup poles in z: ``-a, -a r, -a r**2, ...`` (``r`` = 1.25) under Tustin.

    ``a`` defaults to the natural frequency of S (geometric mean of its non-zero roots,
    or of R's); the whole sequence is lowered, if needed, so that its fastest pole is at
    most ``fs`` rad/s (none nears ``z = -1``) and the poles stay distinct.

    Parameters
    ----------
    ctrl : RSTController
        The controller (one pole per degree of S).
    sample_rate_hz : float
        Sampling rate [Hz].
    aw_rad_s : float, optional
        The slowest pole ``a`` [rad/s].

    Returns
    -------
    numpy.ndarray
        ``deg S`` real poles in z.

    Raises
    ------
    SpecError
        When ``aw_rad_s`` is not > 0.
    """
    n = len(ctrl.S) - 1
    a = float(aw_rad_s) if aw_rad_s is not None else poly.Scaling.natural(ctrl.S, ctrl.R).w0
    if not a > 0:
        raise SpecError(f"anti-windup frequency must be > 0 rad/s, got {aw_rad_s}")
    cont = a * AW_SPREAD ** np.arange(n)
    if n and cont[-1] > float(sample_rate_hz):
        cont *= float(sample_rate_hz) / cont[-1]
    q = cont / (2.0 * float(sample_rate_hz))
    return (1.0 - q) / (1.0 + q)


def _aw_gain(A, C, targets):
    """``(L, method)`` making ``A - L C`` (the controller while saturated) stable.

    ``placed``: ``eig(A - L C) = targets`` by pole placement; if that fails or leaves a
    pole on or outside the unit circle (an ill-conditioned placement), ``kalman``: the
    steady-state Kalman predictor gain of the discrete Riccati equation (``Q = I``,
    ``R = 1``), stabilising whenever the realisation is observable; else ``none``
    (``L = 0``: saturation without anti-windup).
    """
    import scipy.linalg as sla
    import scipy.signal as sig

    n = A.shape[0]
    if n == 0:
        return np.zeros(0), "none"

    def stable(L):
        return np.all(np.isfinite(L)) and np.max(np.abs(np.linalg.eigvals(A - np.outer(L, C)))) < 1

    try:
        L = sig.place_poles(A.T, C.T, targets).gain_matrix.T.ravel()
        if stable(L):
            return L, "placed"
    except (ValueError, np.linalg.LinAlgError):
        pass
    try:
        P = sla.solve_discrete_are(A.T, C.T, np.eye(n), np.eye(1))
        L = (A @ P @ C.T / (1.0 + (C @ P @ C.T).item())).ravel()
        if stable(L):
            return L, "kalman"
    except (ValueError, np.linalg.LinAlgError):
        pass
    return np.zeros(n), "none"


def digital_controller(ctrl: RSTController, sample_rate_hz: float,
                       aw_rad_s: float | None = None) -> DigitalController:
    """The Tustin controller at ``sample_rate_hz`` as delta-form sections (see module doc).

    Parameters
    ----------
    ctrl : RSTController
        The controller in s.
    sample_rate_hz : float
        Sampling rate [Hz].
    aw_rad_s : float, optional
        Slowest anti-windup pole [rad/s] (default: :func:`aw_poles`).

    Returns
    -------
    DigitalController

    Raises
    ------
    SpecError
        When a controller pole sits at ``s = 2 fs`` (its Tustin image is at infinity).

    Examples
    --------
    >>> from robrst import paper_plant, pole_placement, PoleSpec, ControllerStructure
    >>> ctrl = pole_placement(paper_plant(), PoleSpec(wn=600.0, zeta=1.0),
    ...                       ControllerStructure(extra_degree=1)).controller
    >>> dc = digital_controller(ctrl, 20000.0)
    >>> [s.order for s in dc.sections], float(dc.S_z[0])
    ([1, 2, 1], 1.0)
    """
    fs = float(sample_rate_hz)
    ctrl = as_controller(ctrl)
    R_z, S_z, T_z = tustin_polynomials(ctrl, fs)
    sc = poly.Scaling.natural(ctrl.S, ctrl.R)
    n = len(ctrl.S) - 1
    Ss, Ts, Rs = (sc.normalize(np.concatenate([np.zeros(n + 1 - len(P)), P]), n)
                  for P in (ctrl.S, ctrl.T, ctrl.R))
    Ts, Rs, Ss = Ts / Ss[0], -Rs / Ss[0], Ss / Ss[0]
    h = sc.w0 / fs
    factors = _factors(Ss)
    Q = [Ts, Rs]
    parts = []
    for root, quad in factors:                     # slowest first: stable deflation
        qr = [_divmod_monic(c, quad) for c in Q]
        Q = [x[0] for x in qr]
        parts.append((root, quad, [x[1] for x in qr]))
    D = np.array([Q[0][-1], Q[1][-1]])
    raw = []
    for root, quad, b in parts:
        A, B, C = _section_ct(root, quad, b)
        M = np.eye(A.shape[0]) - 0.5 * h * A
        if np.linalg.cond(M) > 1e12:
            raise SpecError(f"controller pole {complex(root) * sc.w0:.6g} rad/s is at s = 2 fs:"
                            " its Tustin image is at z = infinity")
        G = np.linalg.solve(M, h * B)
        raw.append((np.linalg.solve(M, h * A), G, np.linalg.solve(M.T, C.T).T,
                    0.5 * (C @ G).ravel(), complex(root) * sc.w0))
    targets = aw_poles(ctrl, fs, aw_rad_s)
    dc = DigitalController(ctrl=ctrl, sample_rate_hz=fs, w0=sc.w0,
                           sections=tuple(Section(F, G, H, J, np.zeros(F.shape[0]), p)
                                          for F, G, H, J, p in raw),
                           D=D, R_z=R_z, S_z=S_z, T_z=T_z, aw_poles_z=targets)
    A, _, C, _, _ = dc.state_space()
    L, method = _aw_gain(A, C, targets)
    secs, i = [], 0
    for s in dc.sections:
        secs.append(Section(s.F, s.G, s.H, s.J, L[i:i + s.order], s.pole_rad_s))
        i += s.order
    achieved = np.linalg.eigvals(A - np.outer(L, C)) if A.size else np.zeros(0)
    return DigitalController(ctrl=ctrl, sample_rate_hz=fs, w0=sc.w0, sections=tuple(secs), D=D,
                             R_z=R_z, S_z=S_z, T_z=T_z, aw_poles_z=achieved, aw_method=method)
