"""Bounds of a step response between the points of its grid: the kernel of
:mod:`robrst.certificate._stepbound`.

The grid of :mod:`robrst.certificate._stepgrid` holds exact states at its points.  On an interval
``[a, a + h]`` of a continuous loop ``y(t) = C x(t) + d``, ``x' = A x + B``, so ``y'' = C
A x'`` and ``x'(a + s) = e^{A s} x'(a)``: with ``w(s) = y''(a + s)`` (which dies out, ``A`` being Hurwitz)

    ``w(s)**2 = -int_s^inf 2 w w' <= 2 ||w||_2 ||w'||_2``,

and ``||w||_2**2 = v^T G1 v``, ``||w'||_2**2 = v^T G2 v`` for ``v = x'(a)`` and the
observability Gramians ``G1, G2`` of ``(A, C A)`` and ``(A, C A**2)``
(:func:`gramians`).  So ``|y''| <= M = sqrt(2) (v^T G1 v v^T G2 v)**(1/4)`` at every time
after ``a``, and ``y`` is within ``M h**2 / 8`` of the chord between its end values, and
below ``y(a) + y'(a) s + M s**2 / 2`` and ``y(a + h) - y'(a + h) (h - s) + M (h - s)**2 /
2`` (:func:`interval_max` takes the least of the three bounds of the largest value).  A
sampled loop is the same with differences: ``x[k + 1] - x[k] = Ad**j (x[1] - x[0])``,
second differences bounded by the discrete Gramians of ``(Ad, C (Ad - I))`` and ``(Ad, C
(Ad - I)**2)`` (``s[j]**2 <= 2 ||s||_2 ||s[j + 1] - s[j]||_2``), and only the samples of
an interval count.  The bounds are output energies: a slow mode that ``y`` hardly sees
(a creep pair that the reference path cancels) hardly weighs in them, whatever the state.

The Gramians of all the loops of a batch are stacked (:func:`gramians`); the rounding of
their sums is covered by a slack (first order in ``eps``), so a bound stays a bound.
"""

import numpy as np

__all__ = ["Curvature", "gramians", "interval_max"]

_TAIL = 1e-14          # Smith's doubling stops at ||Phi**m||_F**2 below this (< rounding)


def gramians(A, rates, U):
    """Gramians ``G = int_0^inf e^{A^T t} u^T u e^{A t} dt`` of the rows ``u`` of ``U`` for
    stacked Hurwitz ``A``, by Smith's doubling on the Cayley transform ``(c - A)^{-1} (c +
    A)`` (``c`` the geometric mean of the extreme eigenvalue moduli ``rates``).

    Parameters
    ----------
    A : ndarray
        Shape ``(K, n, n)``.
    rates : ndarray
        Shape ``(K, n)``: the moduli of the eigenvalues of each ``A``.
    U : ndarray
        Shape ``(K, q, n)``.

    Returns
    -------
    G : ndarray
        Shape ``(K, q, n, n)``.
    slack : ndarray
        Shape ``(K, q)``: ``v^T G_exact v <= max(v^T G v, 0) + slack |v|**2`` covers the
        truncated doubling (``G_exact - G = Phi_m^T G_exact Phi_m``, ``Phi_m`` the last
        power) and the rounding of the sums and of the form (first order: ``4 n eps``
        times the norms of the terms, ``sum (1 + |Phi_i|_F**2) |G|_F``); ``inf`` where the
        doubling did not converge (``A`` not Hurwitz).
    """
    K, n = A.shape[0], A.shape[-1]
    c = np.sqrt(rates.min(axis=1) * rates.max(axis=1))[:, None, None]
    eye = np.eye(n)
    with np.errstate(all="ignore"):
        R = np.linalg.inv(c * eye - A)
        Phi = R @ (c * eye + A)
        W = U @ R
        G = 2 * c[:, None] * W[..., :, None] * W[..., None, :]    # Stein: Phi^T G Phi - G = -Q
        terms = np.ones(K)                # sum of (1 + |Phi_i|_F**2) over the doublings
        for _ in range(64):
            f2 = (Phi * Phi).sum(axis=(1, 2))
            if not np.any(f2 > _TAIL):   # (nan: diverged, left to ``ok``)
                break
            terms += 1 + f2
            G = G + np.swapaxes(Phi, 1, 2)[:, None] @ G @ Phi[:, None]
            Phi = Phi @ Phi
        rel = f2 / (1 - f2) + 4 * n * np.finfo(float).eps * terms
        slack = np.sqrt((G * G).sum(axis=(2, 3))) * rel[:, None]
    ok = f2 < 0.5
    return np.where(ok[:, None, None, None], G, 0.0), np.where(ok[:, None], slack, np.inf)


class Curvature:
    """Bounds of ``|y''|`` (continuous) or of the second differences (sampled) of each
    output of the loops of ``r``, valid at every time after the state they start from.

    With ``first = 0`` the same bound one derivative lower: of ``|y - y_inf|`` at every
    time after a state, from its deviation ``x - x_inf`` from the steady state (``w = C
    e^{A s} (x - x_inf)`` dies out: ``w**2 <= 2 ||w||_2 ||w'||_2``, the Gramians of ``(A, C)``
    and ``(A, C A)``; sampled, of ``(Ad, C)`` and ``(Ad, C (Ad - I))``): the response after
    the end of its grid (:meth:`robrst.certificate._stepbound.StepBounds.tail`).

    Parameters
    ----------
    r : StepResponses
    first : int
        The derivative bounded (2: ``y''`` from the velocity; 0: ``y - y_inf`` from the
        deviation); the Gramians are those of ``C D**(first - 1)`` and ``C D**first``.
    """

    def __init__(self, r, first=2):
        n = r.A.shape[-1]
        D = r.A - np.eye(n) if r.discrete else r.A
        U1 = r.C @ D if first == 2 else r.C
        U = np.stack([U1, U1 @ D], axis=2).reshape(len(r.A), -1, n)   # per row: u1, u2
        if r.discrete:       # the discrete Gramians from the bilinear variable's Lyapunov
            ch = (2 / r.h_sample)[:, None, None]
            U = U @ (ch * np.eye(n) - r.generator) / np.sqrt(2 * ch)
        self.G, self.slack = gramians(r.generator, r.rates, U)

    def sup(self, ks, rows, V):
        """The bound of output ``rows[j]`` of loop ``ks[j]`` from its velocities ``V[j]``
        (:meth:`robrst.certificate._stepgrid.StepResponses.velocity`), shape ``(J, n, N)``: ``(J, N)``."""
        q = 2 * np.asarray(rows)
        return self._bound(ks[:, None], q[:, None] + np.arange(2), V)[:, 0]

    def sup_all(self, V):
        """The bounds of every output of every loop from velocities ``V`` ``(K, n, N)``:
        ``(K, r, N)``."""
        K = len(V)
        return self._bound(np.arange(K)[:, None], np.arange(self.G.shape[1])[None, :], V)

    def _bound(self, ks, qs, V):
        """``sqrt(2) (g1 g2)**(1/4)`` from the forms of the Gramians ``qs`` (pairs) of loops
        ``ks`` (broadcast, shape ``(J, 2 r')``) at ``V`` ``(J, n, N)``: ``(J, r', N)``."""
        J, n, N = V.shape
        Q = np.broadcast_shapes(np.shape(ks), np.shape(qs))[1]
        G = self.G[ks, qs]                                      # (J, 2r', n, n)
        GV = (G.reshape(J, Q * n, n) @ V).reshape(J, Q, n, N)
        g = np.maximum((V[:, None] * GV).sum(axis=2), 0.0) \
            + self.slack[ks, qs][..., None] * (V * V).sum(axis=1)[:, None]
        g = g.reshape(J, Q // 2, 2, N)
        with np.errstate(invalid="ignore"):
            M = np.sqrt(2.0) * np.sqrt(np.sqrt(g[:, :, 0] * g[:, :, 1]))
        ok = np.isfinite(self.slack[ks, qs]).reshape(J, Q // 2, 2).all(axis=2)
        return np.where(ok[..., None], M, np.inf)


def interval_max(ya, yb, da, db, M, h, discrete):
    """Upper bound of ``y`` on intervals of length ``h`` from its end values ``ya, yb``,
    slopes ``da, db`` (``y'``; sampled: ``y[k + 1] - y[k]``) and curvature bound ``M``
    (sampled: only the samples, ``h`` of them after the first).

    Returns
    -------
    ndarray
        The least of the chord bound and the two one-sided Taylor bounds.
    """
    with np.errstate(invalid="ignore"):
        hi = np.maximum(ya, yb)
        if discrete:
            inner = h > 1
            chord = hi + np.where(inner, M * h * h / 8, 0.0)
            left = np.maximum(ya, ya + h * da + M * h * (h - 1) / 2)
            right = np.maximum(yb, yb - h * db + M * h * (h + 1) / 2)
            return np.where(inner, np.minimum(chord, np.minimum(left, right)), hi)
        chord = hi + M * h * h / 8
        left = np.maximum(ya, ya + h * da + M * h * h / 2)
        right = np.maximum(yb, yb - h * db + M * h * h / 2)
        return np.minimum(chord, np.minimum(left, right))
