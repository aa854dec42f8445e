"""Amplitude-dependent residues: the linear (variable-projection) step of the dynamic form.

The dynamic form of hysteresis (:mod:`robrst.diagnose.fit`) lets each mode's frequency,
damping and gain move with the excitation level ``a``.  Measured structures also
change their mode *shapes* with amplitude (a hysteretic joint stiffens one path more
than another), which per-mode gains cannot follow.  With the poles fixed at each
level, the outputs are linear in the residues, so their level slopes ``dR`` are a
linear least-squares problem::

    R_p(a) = R_p(theta(a)) + dR0_p + f(a) dR_p [+ sum_k max(f(a) - f_k, 0) dH_kp],
    f(a) = (a - a_ref) / a_ref

(the knots ``f_k`` at the interior training levels, :func:`robrst.diagnose.fit.slope_basis`)
solved on the training records only (ridge-regularised toward zero with a prior of one
residue magnitude, per unit of ``f`` for the slopes), every output at once: the residues
are re-fitted at the reference level too (the corrections of poles and gains alone left
the lowest level's shapes as the user's model had them); held-out records judge whether
the slopes generalise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal

from robrst.diagnose.fit import Fitted, level_factor, pool_periodic, slope_basis
from robrst.diagnose.options import OPTIONS
from robrst.identify.modal import ModalModel

if TYPE_CHECKING:
    from robrst.diagnose.fit import Prepared

__all__ = ["Polished", "polish_residues", "reduced_rows"]


@dataclass(frozen=True, eq=False)
class Polished(Fitted):
    """A dynamic-form fit with level slopes ``dR`` of the residues (continuous time).

    Parameters
    ----------
    name : str
        The candidate's name.
    effects : tuple of str
        The effects fitted.
    form : str
        ``"dynamic"``.
    chain : Chain
        The effects' chain.
    lin : LinearPart
        The linear corrections' model.
    x : numpy.ndarray
        The fitted parameters.
    std : numpy.ndarray
        Their 1-sigma.
    joint : bool
        The linear corrections were fitted.
    slopes : tuple of int
        Indices into ``theta`` that vary with level.
    level_ref : float
        The reference level [V rms].
    n_eval : int
        Model evaluations.
    train_cost : float
        The final least-squares cost.
    theta_fixed : numpy.ndarray, optional
        Fixed linear corrections when not ``joint``.
    post : Post, optional
        The output-side blocks fitted.
    n_offset : int
        Constant output offsets fitted.
    level_knots : tuple of float
        Interior knots of the level coordinate (:class:`~robrst.diagnose.fit.Fitted`).
    dR : numpy.ndarray
        ``(2 + knots, n, m, k)`` complex: the residues' change at the reference level, then
        per function of :func:`slope_basis` (per unit of level factor, and per interior
        knot).
    """

    dR: np.ndarray = None          # (n, m, k) complex, per unit of level factor

    def model_at(self, level: float, x: np.ndarray | None = None) -> ModalModel:
        """The continuous-time :class:`ModalModel` at excitation level ``level`` [V rms]
        (parameters ``x``, default the fitted ones; ``dR`` stays the fitted one).

        Parameters
        ----------
        level : float
            The level [V rms].
        x : numpy.ndarray, optional
            A parameter vector.

        Returns
        -------
        ModalModel
        """
        cm = self.lin.continuous(self.theta_at(level, x))
        b = np.concatenate([[1.0], slope_basis(level_factor(level, self.level_ref),
                                               self.level_knots)])
        dR = self.dR.reshape((b.size,) + cm.residues.shape)
        return ModalModel(cm.poles, cm.residues + np.tensordot(b, dR, axes=1), cm.D,
                          label=cm.label, temperature_C=cm.temperature_C)

    def linear_change(self) -> tuple[dict, dict]:
        """As :meth:`Fitted.linear_change`, plus ``residue_change_per_level``: the largest
        ``|dR_p| / |R_p|`` over the modes (max over outputs and inputs).

        Returns
        -------
        values, sigmas : dict
        """
        out, sd = super().linear_change()
        R = self.lin.continuous(self.theta_at(self.level_ref)).residues
        dR = self.dR.reshape((-1,) + R.shape)[1]
        rel = [np.max(np.abs(d)) / max(np.max(np.abs(r)), 1e-300) for d, r in zip(dR, R)]
        out["residue_change_per_level"] = float(max(rel, default=0.0))
        sd["residue_change_per_level"] = float("nan")
        return out, sd

    def linear_output(self, p: Prepared, V: np.ndarray,
                      x: np.ndarray | None = None) -> np.ndarray:
        """Outputs ``(N, m)`` of the linear part at the record's level (residues included).

        Parameters
        ----------
        p : Prepared
            The record (its level and whether it is periodic).
        V : numpy.ndarray
            Effective inputs ``(N, k)``.
        x : numpy.ndarray, optional
            A parameter vector (default the fitted one).

        Returns
        -------
        numpy.ndarray
        """
        return self.model_at(p.level, x).discretise(self.lin.fs).response(V, periodic=p.periodic)


def _mode_signal(zq, x, periodic):
    """Complex state ``x_q`` of the mode ``1 / (z - zq)`` driven by ``x`` (rest or steady)."""
    if periodic:
        N = x.size
        z = np.exp(2j * np.pi * np.arange(N) / N)
        return np.fft.ifft(np.fft.fft(x) / (z - zq))
    # from rest: x_q[k+1] = zq x_q[k] + x[k]
    return signal.lfilter([0.0, 1.0], [1.0, -zq], x.astype(complex))


def _columns(model, fs, V, periodic):
    """Regression columns ``(N, c)`` of the CT residues' real/imag parts (per mode, input)."""
    dm = model.discretise(fs)
    cols, index = [], []
    T = 1.0 / fs
    for q, (s, zq, w) in enumerate(zip(model.poles, dm.zpoles, dm.weight)):
        F = np.expm1(s * T) / s if abs(s * T) > 1e-8 else T * (1 + s * T / 2)
        for j in range(V.shape[1]):
            xq = F * _mode_signal(zq, V[:, j], periodic)
            cols.append(w * xq.real)
            index.append((q, j, 1.0))
            if w == 2.0:
                cols.append(-w * xq.imag)
                index.append((q, j, 1j))
    return np.column_stack(cols), index


def reduced_rows(C: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R, z)`` with ``||C X - y||^2 = ||R X - z||^2 + constant`` for every ``X``: the
    triangular factor of ``[C, y]`` (``C`` as it is when it has no more rows than ``[C, y]``
    has columns).

    Parameters
    ----------
    C : numpy.ndarray
        Rows ``(N, c)``.
    y : numpy.ndarray
        Right-hand sides ``(N, m)``.

    Returns
    -------
    R : numpy.ndarray
        ``(c, c)`` upper triangular (or ``C``).
    z : numpy.ndarray
        ``(c, m)`` (or ``y``).
    """
    c = C.shape[1]
    if C.shape[0] <= c + y.shape[1]:
        return C, y
    R = np.linalg.qr(np.hstack([C, y]), mode="r")
    return R[:c, :c], R[:c, c:]


def polish_residues(fit: Fitted, train: Sequence[Prepared], noise_sigma: float) -> Fitted:
    """Fit the level slopes of the residues of a dynamic-form ``fit`` (see module doc).

    Parameters
    ----------
    fit : Fitted
        A dynamic-form fit (``fit.form == "dynamic"``).
    train : list of Prepared
        The training records it was fitted on.
    noise_sigma : float
        Noise std per sample [µm] (weight of the prior).

    Returns
    -------
    Polished
        Same parameters as ``fit`` plus ``dR``; ``fit`` itself is returned unchanged
        when the training records span a single level.
    """
    fs = fit.lin.fs
    knots = getattr(fit, "level_knots", ())
    rows, rhs = [], []
    index = None
    if fit.chain.size == 0 and fit.post is None:    # linear in the records: pool them
        train = pool_periodic(train, by_level=True).records
    for p in train:
        f = level_factor(p.level, fit.level_ref)
        V = fit.effective_input(p)[0]
        model = fit.lin.continuous(fit.theta_at(p.level))
        C, index = _columns(model, fs, V, p.periodic)
        base = model.discretise(fs).response(V, periodic=p.periodic)
        # one block of columns per level function: a change at every level (the reference
        # level's residues re-fitted too), then the slopes; the record's rows are
        # ``C (b^T kron I)``, so ``C``'s triangular factor stands for them (``[C, y] = Q R``:
        # the same least squares with ``c`` rows instead of ``N``, a QR of ``c`` columns,
        # not of ``c nb``)
        b = np.concatenate([[1.0], slope_basis(f, knots)])
        C, y = reduced_rows(C * p.weight, (p.Y - fit.output_side(base)) * p.weight)
        rows.append(np.hstack([C * v for v in b]))
        rhs.append(y)
    if not rows or all(level_factor(p.level, fit.level_ref) == 0.0 for p in train):
        return fit
    nb = 2 + len(knots)
    ref = fit.lin.continuous(fit.theta_at(fit.level_ref))
    mag = np.array([max(np.max(np.abs(ref.residues[q])), 1e-300) for q, _, _ in index] * nb)
    ridge = noise_sigma / (OPTIONS.fit.prior_per_level * mag)
    A = np.vstack(rows + [np.diag(ridge)])
    B = np.vstack(rhs + [np.zeros((ridge.size, rhs[0].shape[1]))])
    cs = np.linalg.norm(A, axis=0)
    cs[cs == 0] = 1.0
    X = np.linalg.lstsq(A / cs, B, rcond=None)[0] / cs[:, None]      # (c nb, m)
    dR = np.zeros((nb,) + ref.residues.shape, complex)
    for b in range(nb):
        for (q, j, unit), xr in zip(index, X[b * len(index):(b + 1) * len(index)]):
            dR[b, q, :, j] += unit * xr
    return Polished(**{k: getattr(fit, k) for k in fit.__dataclass_fields__}, dR=dR)
