"""The linear part of a diagnosis model: the user's model, its bounded corrections, exact simulation.

The simulation model is a modal model (:class:`~robrst.identify.modal.ModalModel`; a
SISO :class:`~robrst.core.plant.Plant` is converted).  Its corrections ``theta`` are

* per mode: the natural frequency (``dlog_freq``, log ratio) and, for a complex pair,
  the damping (``dlog_damping``);
* a gain: one overall ``gain`` (one input) or one ``input_gain`` per input;
* optionally (``modal_gains``, used by the amplitude-dependent dynamics) a gain per mode
  (``mode_gain``: the mode's participation).  With per-mode gains every gain is a *log*
  ratio (the factor ``exp(t)``, not ``1 + t``): a mode's gain and an input's gain then
  combine additively, so a correction that moves linearly with the excitation level
  extrapolates the same whichever of the two carries it (with ``1 + t`` factors their
  product is not linear in the level, and the split the data leave free changes the
  extrapolation).

The *zeros* of every channel stay the user's: when poles move, the residues are those
of the same numerators over the new denominator,
``R'_p = prod_{l != p} (p' - p_l)/(p' - p'_l) [R_p + sum_{q != p} R_q (p' - p_p)/(p' - p_q)]`` (all poles,
conjugates included; no polynomial is expanded).  A re-fit therefore corrects gains,
resonances and damping (the usual model errors) but cannot imitate a delay or an
effect by rotating phases.  ``theta = 0`` is the user's model; corrections are bounded
(``bounds``) and carry Gaussian priors (``prior_sd``, both in
:class:`~robrst.diagnose.options.LinearOptions`): a re-fit is regularised
toward the user's model.  Records are simulated exactly (ZOH,
:func:`~robrst.core.lti.zoh_modal`) from rest by first-order recursions, or in periodic
steady state on the DFT grid.  :class:`LinearPart` returns outputs and their Jacobian
(gains analytically, frequencies and damping by forward differences).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize, signal

from robrst.diagnose.options import OPTIONS
from robrst.identify.modal import ModalModel, pair_weight
from robrst.core.lti import zoh_modal
from robrst.core.plant import Plant

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["coefficient_changes", "LinearPart", "LinearSim", "as_modal", "refit_linear",
           "LinearFit", "parameter_std", "unexcited"]

GAIN_KINDS = ("gain", "input_gain", "mode_gain")
_LIN = OPTIONS.linear
_BLOCK = 1 << 15    # complex terms per block of frequencies (512 kB: they stay in cache)


def as_modal(model: ModalModel | Plant) -> ModalModel:
    """A :class:`ModalModel` from a ModalModel or a SISO Plant.

    Parameters
    ----------
    model : ModalModel or Plant
        The linear model.

    Returns
    -------
    ModalModel
    """
    return model if isinstance(model, ModalModel) else ModalModel.from_plant(model)


class LinearPart:
    """Corrections ``theta`` of a modal model and the sampled simulation at ``fs`` [Hz].

    Parameters
    ----------
    model : ModalModel or Plant
        The user's model.
    fs : float
        Sampling rate [Hz].
    modal_gains : bool
        Also a gain correction per mode (else one overall gain).

    Attributes
    ----------
    size : int
        Length of ``theta``.
    names : tuple of str
        The corrections' names (``gain``, ``mode1_dlog_freq``, ...).
    """

    def __init__(self, model: ModalModel | Plant, fs: float, modal_gains: bool = False) -> None:
        self.model = as_modal(model)
        self.modal_gains = bool(modal_gains)
        self.fs = float(fs)
        m = self.model
        self.weight = pair_weight(m.poles)
        names, kinds = [], []
        for p, pole in enumerate(m.poles):
            if pole != 0:
                names.append(f"mode{p + 1}_dlog_freq")
                kinds.append(("dlog_freq", p))
            if pole.imag > 0:
                names.append(f"mode{p + 1}_dlog_damping")
                kinds.append(("dlog_damping", p))
            if modal_gains:
                names.append(f"mode{p + 1}_gain")
                kinds.append(("mode_gain", p))
        if m.n_in > 1:
            for j in range(m.n_in):
                names.append(f"u{j + 1}_input_gain")
                kinds.append(("input_gain", j))
        else:
            names.append("gain")
            kinds.append(("gain", 0))
        self.names = tuple(names)
        self.kinds = tuple(kinds)
        self.lower = np.array([_LIN.bounds[k][0] for k, _ in kinds])
        self.upper = np.array([_LIN.bounds[k][1] for k, _ in kinds])
        if self.modal_gains:                  # log gains: the same factors 0.1 ... 3
            gain = np.array([k in GAIN_KINDS for k, _ in kinds])
            self.lower[gain] = np.log1p(self.lower[gain])
            self.upper[gain] = np.log1p(self.upper[gain])
        self.prior_sd = np.array([_LIN.prior_sd[k] for k, _ in kinds])
        self.moves = tuple(i for i, (k, _) in enumerate(kinds)
                           if k in ("dlog_freq", "dlog_damping", "mode_gain"))
        self._cache = {}          # sampled transfers by (theta, N): records share DFT grids
        self._term_cache = {}     # the latest theta's modal terms (finite differences)

    @property
    def size(self):
        return len(self.names)

    def _factor(self, t):
        """The gain factor of a correction ``t``: ``exp(t)`` with per-mode gains, else ``1 + t``."""
        return np.exp(t) if self.modal_gains else 1.0 + t

    def _gains(self, theta):
        """Relative gain per input (the overall gain for one input)."""
        gains = np.ones(self.model.n_in)
        for t, (kind, j) in zip(theta, self.kinds):
            if kind in ("input_gain", "gain"):
                gains[j] = self._factor(t)
        return gains

    def _poles(self, theta):
        p = self.model.poles.copy()
        dw = np.zeros(p.size)
        dz = np.zeros(p.size)
        for t, (kind, q) in zip(theta, self.kinds):
            if kind == "dlog_freq":
                dw[q] = t
            elif kind == "dlog_damping":
                dz[q] = t
        for q, pole in enumerate(p):
            if pole.imag > 0:
                wn, zeta = abs(pole), -pole.real / abs(pole)
                wn, zeta = wn * np.exp(dw[q]), min(zeta * np.exp(dz[q]), _LIN.max_damping)
                p[q] = complex(-zeta * wn, wn * np.sqrt(1 - zeta * zeta))
            else:
                p[q] = pole * np.exp(dw[q])
        return p

    def _modes(self, theta):
        """New poles and residues (same numerators), input gains applied: ``(n,), (n, m, k)``."""
        new, R = self._mapped(theta)
        R = R * self._mode_factors(theta)[:, None, None]
        return new, R * self._gains(theta)[None, None, :]

    def _mode_factors(self, theta):
        """The per-mode gain factors (1 without per-mode gains)."""
        f = np.ones(self.model.poles.size)
        for t, (kind, q) in zip(theta, self.kinds):
            if kind == "mode_gain":
                f[q] = self._factor(t)
        return f

    def _mapped(self, theta):
        """New poles and the residues of the same numerators over them (no gains)."""
        m = self.model
        new = self._poles(theta)
        if np.array_equal(new, m.poles):
            R = m.residues.copy()
        else:
            cj = np.imag(m.poles) > 0
            P0 = np.concatenate([m.poles, np.conj(m.poles[cj])])
            P1 = np.concatenate([new, np.conj(new[cj])])
            R0 = np.concatenate([m.residues, np.conj(m.residues[cj])])
            n = new.size
            x = P1[:n, None]                       # every new pole against all old/new ones
            off = ~np.eye(n, P0.size, dtype=bool)
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.prod(np.where(off, (x - P0[None, :]) / (x - P1[None, :]), 1.0),
                                axis=1)
                C = np.where(off, (x - P0[:n, None]) / (x - P0[None, :]), 0.0)
            rest = (C @ R0.reshape(P0.size, -1)).reshape((n,) + R0.shape[1:])
            R = ratio[:, None, None] * (R0[:n] + rest)
        return new, R

    def continuous(self, theta: np.ndarray) -> ModalModel:
        """The corrected model as a :class:`ModalModel`.

        Parameters
        ----------
        theta : numpy.ndarray
            The corrections.

        Returns
        -------
        ModalModel
        """
        new, R = self._modes(theta)
        D = self.model.D * self._gains(theta)[None, :]
        return ModalModel(new, R, D, label=f"{self.model.label}_refit",
                          temperature_C=self.model.temperature_C)

    def _H(self, theta, N):
        """Sampled transfer ``(N//2 + 1, m, k)`` on the DFT grid of length N (cached)."""
        key = (np.asarray(theta, float).tobytes(), int(N))
        H = self._cache.get(key)
        if H is None:
            new, R = self._modes(theta)
            zp, Rd = zoh_modal(new, R, self.fs)
            z = np.exp(2j * np.pi * np.arange(N // 2 + 1) / N)
            H = self._transfer(zp, Rd, z) + (self.model.D * self._gains(theta)[None, :])[None]
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[key] = H
        return H

    def _move_terms(self, theta, moves):
        """The modal terms of the finite-difference moves at ``theta`` (cached, the latest):
        ``(poles, residues, S, zq, Rq, pair)``.

        ``poles``/``residues`` are the sampled modes at ``theta``, each pair's conjugate
        appended (``(P,)``, ``(P, m, k)``).  Row ``r`` of ``S`` ``(len(moves), P)`` is the
        change of every mode's residue, as a multiple of itself, when correction
        ``moves[r]`` takes its finite-difference step.  A frequency or damping moves only
        its mode's pole, so every other mode's residue is its own times a scalar (the
        zero-preserving map of one pole, as :meth:`_mapped` composes); the moved mode's
        entry is ``-1`` and its new term ``Rq[r] / (z - zq[r])`` (and the conjugate when
        ``pair[r]``).  A mode's gain scales that mode's term alone (``Rq[r]`` zero)."""
        key = (np.asarray(theta, float).tobytes(), tuple(moves))
        if self._term_cache.get("key") == key:
            return self._term_cache["value"]
        new, Rm = self._mapped(theta)
        R = Rm * self._mode_factors(theta)[:, None, None] * self._gains(theta)[None, None, :]
        zp, Rd = zoh_modal(new, R, self.fs)
        pair = self.weight == 2.0
        poles = np.concatenate([zp, np.conj(zp[pair])])
        residues = np.concatenate([Rd, np.conj(Rd[pair])])
        S = np.zeros((len(moves), new.size), complex)
        zq = np.zeros(len(moves), complex)
        Rq = np.zeros((len(moves),) + Rd.shape[1:], complex)
        for r, i in enumerate(moves):
            kind, q = self.kinds[i]
            th = np.array(theta, float)
            th[i] += _LIN.fd_step
            if kind == "mode_gain":         # that mode's term scales: the others stay
                S[r, q] = self._factor(th[i]) / self._factor(theta[i]) - 1.0
                continue
            S[r], zq[r], Rq[r] = self._moved(new, Rm, th, q)
        S = np.concatenate([S, np.conj(S[:, pair])], axis=1)
        value = (poles, residues, S, zq, Rq, pair[[self.kinds[i][1] for i in moves]])
        self._term_cache = {"key": key, "value": value}
        return value

    def _moves_applied(self, theta, moves, Vf, N, out):
        """Write into ``out`` ``(F, m, len(moves))`` the change of the output spectrum that
        each move makes, per unit of the finite-difference step, for the input spectrum
        ``Vf`` ``(F, k)``: every mode's output term once (``Rd_p Vf / (z - zp_p)``), each
        move a column of ``S`` over them plus its moved mode's new term.  No transfer is
        formed, every product is a matrix product, and the frequencies go in blocks whose
        terms stay in cache (no array of every frequency is made and dropped per call)."""
        poles, residues, S, zq, Rq, pair = self._move_terms(theta, moves)
        P, m, k = residues.shape
        n = len(moves)
        step = 1.0 / _LIN.fd_step
        St = S.T * step
        res = residues.transpose(2, 1, 0).reshape(k, m * P)
        new = (Rq * step).transpose(2, 1, 0).reshape(k, m * n)
        new_c = (np.where(pair[:, None, None], np.conj(Rq), 0.0) * step).transpose(
            2, 1, 0).reshape(k, m * n)
        zq_c = np.conj(zq)
        F = N // 2 + 1
        block = max(1, _BLOCK // (m * max(P, n)))
        for f0 in range(0, F, block):
            f = np.arange(f0, min(F, f0 + block))
            z = np.exp(2j * np.pi * f / N)[:, None]
            V = Vf[f0:f0 + f.size]
            W = (V @ res).reshape(f.size, m, P)
            W *= (1.0 / (z - poles[None, :]))[:, None, :]
            blk = (W.reshape(f.size * m, P) @ St).reshape(f.size, m, n)
            blk += (V @ new).reshape(f.size, m, n) * (1.0 / (z - zq[None, :]))[:, None, :]
            if pair.any():
                blk += (V @ new_c).reshape(f.size, m, n) * (
                    1.0 / (z - zq_c[None, :]))[:, None, :]
            out[f0:f0 + f.size] = blk

    def _moved(self, new, Rm, th, q):
        """The change of every mode's residue scalar (``-1`` for mode ``q``, whose term is
        replaced), and the moved mode ``q``'s sampled pole and residue at ``th`` (which moves
        only mode ``q``'s pole)."""
        old, nw = new[q], self._poles(th)[q]
        pair = self.weight[q] == 2.0
        olds = np.array([old, np.conj(old)] if pair else [old])
        news = np.array([nw, np.conj(nw)] if pair else [nw])
        s = np.prod((new[:, None] - olds[None, :]) / (new[:, None] - news[None, :]), axis=1)
        s[q] = 0.0        # the moved mode's own term is replaced (its new term added)
        # the moved mode: its residue re-mapped over the new pole (ratio and sum of _mapped)
        cj = np.imag(new) > 0
        P0 = np.concatenate([new, np.conj(new[cj])])
        R0 = np.concatenate([Rm, np.conj(Rm[cj])])
        others = np.ones(P0.size, bool)
        others[q] = False
        ratio = (nw - np.conj(old)) / (nw - np.conj(nw)) if pair else 1.0
        rest = np.tensordot((nw - old) / (nw - P0[others]), R0[others], axes=1)
        Rq = ratio * (Rm[q] + rest) * self._mode_factors(th)[q] * self._gains(th)[None, :]
        zq, Rdq = zoh_modal(np.array([nw]), Rq[None], self.fs)
        return s - 1.0, zq[0], Rdq[0]

    def _parts(self, theta, V, periodic, Vf=None):
        """Per-input output contributions ``(N or F, m, k)`` (spectra when periodic; ``Vf``
        the input's spectrum when known)."""
        N = V.shape[0]
        if periodic:
            if Vf is None:
                Vf = np.fft.rfft(V, axis=0)
            return self._H(theta, N) * Vf[:, None, :]
        new, R = self._modes(theta)
        zp, Rd = zoh_modal(new, R, self.fs)
        D = self.model.D * self._gains(theta)[None, :]
        out = V[:, None, :] * D[None]
        for p in range(zp.size):
            self._add_mode(out, zp[p], Rd[p], V, p)
        return out

    def _add_mode(self, out, zp, Rd, X, p, inputs=None):
        """Add mode ``p``'s response to columns ``X`` (N, c) into ``out`` (N, m, c), from rest.

        Real arithmetic: a pair is the section ``(b1 q^-1 + b2 q^-2) / (1 - 2 Re z q^-1 +
        |z|^2 q^-2)`` with ``b1 = 2 Re R``, ``b2 = -2 Re(R conj z)``; its two numerator
        terms share one filtered signal (the second is the first delayed by a sample).
        """
        R = Rd if inputs is None else Rd[:, inputs]
        if self.weight[p] == 2.0:
            s1 = signal.lfilter([0.0, 1.0], [1.0, -2 * zp.real, abs(zp) ** 2], X, axis=0)
            s2 = np.zeros_like(s1)
            s2[1:] = s1[:-1]
            out += s1[:, None, :] * (2 * R.real)[None] - s2[:, None, :] * (
                2 * (R * np.conj(zp)).real)[None]
        else:
            s1 = signal.lfilter([0.0, 1.0], [1.0, -zp.real], X, axis=0)
            out += s1[:, None, :] * R.real[None]

    def _transfer(self, zp, Rd, z):
        """``sum_p Rd_p / (z - zp_p)`` (and the conjugate of every pair) on ``z``: one
        product of the ``(F, poles)`` partial fractions with the residues."""
        pair = self.weight == 2.0
        poles = np.concatenate([zp, np.conj(zp[pair])])
        res = np.concatenate([Rd, np.conj(Rd[pair])]).reshape(poles.size, -1)
        W = 1.0 / (z[:, None] - poles[None, :])
        return (W @ res).reshape((z.size,) + Rd.shape[1:])

    def simulate_inputs(self, theta: np.ndarray, X: np.ndarray, inputs: Sequence[int],
                        periodic: bool = False) -> np.ndarray:
        """Outputs ``(N, m, c)`` for columns ``X[:, c]`` each applied alone on ``inputs[c]``.

        Parameters
        ----------
        theta : numpy.ndarray
            The corrections.
        X : numpy.ndarray
            ``(N, c)`` signals.
        inputs : sequence of int
            The input each column drives.
        periodic : bool
            Steady state of a periodic record (else from rest).

        Returns
        -------
        numpy.ndarray
        """
        X = np.asarray(X, float).reshape(len(X), -1)
        inputs = np.asarray(inputs, int)
        N = X.shape[0]
        if periodic:
            H = self._H(theta, N)[:, :, inputs]
            return np.fft.irfft(H * np.fft.rfft(X, axis=0)[:, None, :], n=N, axis=0)
        new, R = self._modes(theta)
        zp, Rd = zoh_modal(new, R, self.fs)
        D = (self.model.D * self._gains(theta)[None, :])[:, inputs]
        Y = X[:, None, :] * D[None]
        for p in range(zp.size):
            self._add_mode(Y, zp[p], Rd[p], X, p, inputs)
        return Y

    def simulate_input(self, theta: np.ndarray, x: ArrayLike, j: int,
                       periodic: bool = False) -> np.ndarray:
        """Output ``(N, m)`` for the signal ``x`` on input ``j`` alone (others zero).

        Parameters
        ----------
        theta : numpy.ndarray
            The corrections.
        x : array_like
            The signal, ``N`` samples.
        j : int
            The input.
        periodic : bool
            Steady state of a periodic record (else from rest).

        Returns
        -------
        numpy.ndarray
        """
        return self.simulate_inputs(theta, np.asarray(x, float)[:, None], [j], periodic)[:, :, 0]

    def simulate(self, theta: np.ndarray, V: np.ndarray, periodic: bool = False) -> np.ndarray:
        """Outputs ``(N, m)`` for effective inputs ``V`` (N x k).

        Parameters
        ----------
        theta : numpy.ndarray
            The corrections.
        V : numpy.ndarray
            The inputs [V].
        periodic : bool
            Steady state of a periodic record (else from rest).

        Returns
        -------
        numpy.ndarray
        """
        return self.simulate_jac(theta, V, periodic, jac=False)[0]

    def simulate_jac(self, theta: np.ndarray, V: np.ndarray, periodic: bool = False,
                     jac: bool = True,
                     spectral: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """Outputs ``(N, m)`` and, if ``jac``, ``d outputs / d theta`` ``(N, m, size)``.

        Parameters
        ----------
        theta : numpy.ndarray
            The corrections.
        V : numpy.ndarray
            The inputs [V].
        periodic : bool
            Steady state of a periodic record (else from rest).
        jac : bool
            Also the Jacobian.
        spectral : bool
            A periodic record's outputs and Jacobian as their spectra (``rfft`` along the
            samples: ``(N//2 + 1, m)`` and ``(N//2 + 1, m, size)``), not transformed back.

        Returns
        -------
        Y : numpy.ndarray
        J : numpy.ndarray or None
        """
        theta = np.asarray(theta, float)
        V = np.asarray(V, float).reshape(len(V), -1)
        N = V.shape[0]
        Vf = np.fft.rfft(V, axis=0) if periodic and jac else None   # once, not per column
        parts = self._parts(theta, V, periodic, Vf)
        total = parts.sum(axis=2)
        back = (lambda A: np.fft.irfft(A, n=N, axis=0)) if periodic and not spectral else (
            lambda A: A)
        Y = back(total)
        if not jac:
            return Y, None
        cols = np.zeros(total.shape + (self.size,), total.dtype)
        gains = self._gains(theta)
        for i, (kind, q) in enumerate(self.kinds):
            if kind in ("gain", "input_gain"):       # d exp(t) = exp(t) dt; d (1 + t) = dt
                cols[..., i] = parts[:, :, q] if self.modal_gains else parts[:, :, q] / gains[q]
        moves = list(self.moves) if periodic else []
        if moves:                   # every move at once: its change of the output spectrum
            a, b = moves[0], moves[-1] + 1
            if moves == list(range(a, b)):      # the modes come first: a slice
                self._moves_applied(theta, tuple(moves), Vf, N, cols[..., a:b])
            else:
                dY = np.empty(cols.shape[:2] + (len(moves),), complex)
                self._moves_applied(theta, tuple(moves), Vf, N, dY)
                cols[..., moves] = dY
        for i in self.moves if not periodic else ():
            th = theta.copy()
            th[i] += _LIN.fd_step
            cols[..., i] = (self._parts(th, V, periodic, Vf).sum(axis=2) - total) / _LIN.fd_step
        return Y, back(cols)


@dataclass(frozen=True, eq=False)
class LinearSim:
    """Exact ZOH simulation of a linear model from rest: ``LinearSim.of(plant, fs)(u)``.

    ``y[k]`` is sampled at the instant ``u[k]`` is applied, as in the twin.  For one
    input and output ``u`` and the result are 1-D; else ``(N, k)`` and ``(N, m)``.

    Parameters
    ----------
    model : ModalModel
        The model.
    fs : float
        Sampling rate [Hz].

    Attributes
    ----------
    stable : bool
        Every pole in the open left half-plane.
    """

    model: ModalModel
    fs: float

    def __post_init__(self):
        object.__setattr__(self, "discrete", self.model.discretise(self.fs))

    @classmethod
    def of(cls, plant: Plant | ModalModel, fs: float) -> LinearSim:
        """The simulation of ``plant`` at ``fs``.

        Parameters
        ----------
        plant : Plant or ModalModel
            The model.
        fs : float
            Sampling rate [Hz].

        Returns
        -------
        LinearSim
        """
        return cls(as_modal(plant), float(fs))

    @property
    def stable(self):
        return self.discrete.stable

    def __call__(self, u, periodic=False):
        u = np.asarray(u, float)
        Y = self.discrete.response(u, periodic=periodic)
        return Y[:, 0] if u.ndim == 1 and Y.shape[1] == 1 else Y


@dataclass(frozen=True)
class LinearFit:
    """A re-fitted linear model: the model, its corrections with 1-sigma, evaluations.

    Parameters
    ----------
    plant : Plant or ModalModel
        The fitted model (a Plant for a SISO Plant given).
    rel_change : dict
        Correction name -> value (``theta``; for a Plant also ``b0..``, ``a1..``).
    std : dict
        Their 1-sigma.
    n_eval : int
        Model evaluations.
    """

    plant: Plant | ModalModel
    rel_change: dict       # correction name -> value (theta)
    std: dict
    n_eval: int


def refit_linear(plant: Plant | ModalModel, records: Sequence[tuple[np.ndarray, np.ndarray]],
                 fs: float, max_nfev: int = 60) -> LinearFit:
    """Re-fit the corrections of ``plant`` on ``records`` (output error, from rest).

    Parameters
    ----------
    plant : Plant or ModalModel
        The simulation model under diagnosis.
    records : list of (u, y)
        Training inputs [V] and measured outputs [µm].
    fs : float
        Sampling rate [Hz].
    max_nfev : int
        Evaluations allowed to the least-squares solver.

    Returns
    -------
    LinearFit
        For a :class:`Plant` the fitted model is a Plant (same degrees).
    """
    lp = LinearPart(plant, fs)
    pairs = [(np.asarray(u, float).reshape(len(u), -1), np.asarray(y, float).reshape(len(y), -1))
             for u, y in records]
    scale = np.sqrt(sum(float(np.sum((y - y.mean(0)) ** 2)) for _, y in pairs)) or 1.0

    def fun(th):
        return np.concatenate([(lp.simulate(th, u) - y).ravel() for u, y in pairs]) / scale

    def jac(th):
        return np.vstack([lp.simulate_jac(th, u)[1].reshape(-1, lp.size) for u, _ in pairs]) / scale

    # trial points may overflow (an effect driven far out): the optimiser
    # rejects them; their floating-point warnings only reach the user
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = optimize.least_squares(fun, np.zeros(lp.size), jac=jac,
                                     bounds=(lp.lower, lp.upper), method="trf", x_scale="jac",
                                     ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    std = parameter_std(res.jac, res.cost, len(res.fun))
    fitted = lp.continuous(res.x)
    rel = dict(zip(lp.names, map(float, res.x)))
    sd = dict(zip(lp.names, map(float, std)))
    if isinstance(plant, Plant):
        fitted = fitted.channel(0, 0, label=f"{plant.label}_refit")
        coef = coefficient_changes(plant, fitted)
        rel.update(coef)                       # the JSON contract's keys b0.., a1.. (kept)
        sd.update({k: float("nan") for k in coef})
    return LinearFit(plant=fitted, rel_change=rel, std=sd, n_eval=int(res.nfev))


def coefficient_changes(plant: Plant, fitted: Plant) -> dict[str, float]:
    """Relative change of every non-zero coefficient, ``b{i}`` of B and ``a{i}`` of monic A
    (highest power first, ``a0`` = 1 omitted): the keys earlier versions reported.

    Parameters
    ----------
    plant : Plant
        The user's model.
    fitted : Plant
        The re-fitted one (same degrees).

    Returns
    -------
    dict
    """
    out = {}
    if len(fitted.A) != len(plant.A) or len(fitted.B) != len(plant.B):
        return out
    for i in range(1, len(plant.A)):
        if plant.A[i] != 0:
            out[f"a{i}"] = float(fitted.A[i] / plant.A[i] - 1.0)
    for i, b in enumerate(plant.B):
        if b != 0:
            out[f"b{i}"] = float(fitted.B[i] / b - 1.0)
    return out


def unexcited(lin: LinearPart, inputs: Sequence[np.ndarray], fs: float) -> tuple:
    """Indices of ``lin``'s mode corrections the ``inputs`` do not excite.

    A mode's frequency and damping corrections are determined by records only through
    its own band: when the inputs put less than ``excited_share`` of their power (about
    their mean) within an octave of the mode's frequency, the records see the mode only
    through side effects (the low-frequency phase), where any other model error would
    pull it; such corrections are held at the user's values.

    Parameters
    ----------
    lin : LinearPart
        The linear part.
    inputs : list of array
        Input signals ``(N, k)`` of the training records.
    fs : float
        Sampling rate [Hz].

    Returns
    -------
    tuple of int
        Indices into ``lin``'s corrections.
    """
    num, den = {}, 0.0
    f_modes = np.abs(lin.model.poles) / (2 * np.pi)
    for U in inputs:
        U = np.asarray(U, float).reshape(len(U), -1)
        f, P = signal.welch(U - U.mean(axis=0), fs=fs, nperseg=min(4096, len(U)), axis=0)
        P = P.sum(axis=1)
        den += float(P[f > 0].sum())
        for q, fq in enumerate(f_modes):
            num[q] = num.get(q, 0.0) + float(P[(f >= fq / 2) & (f <= 2 * fq)].sum())
    if den <= 0:
        return ()
    quiet = {q for q, v in num.items() if v < _LIN.excited_share * den}
    return tuple(i for i, (kind, q) in enumerate(lin.kinds)
                 if kind in ("dlog_freq", "dlog_damping", "mode_gain") and q in quiet)


def parameter_std(J: np.ndarray, cost: float, m: int, rtol: float = 1e-7) -> np.ndarray:
    """1-sigma of least-squares parameters from the Jacobian ``J`` at the optimum.

    ``cov = s^2 (J^T J)^-1`` through the SVD of ``J`` (``s^2 = 2 cost / (m - n)``); a
    parameter taking part in a direction the data do not determine (singular value
    below ``rtol`` x the largest) gets ``inf``, never a misleadingly small number.

    Parameters
    ----------
    J : numpy.ndarray
        ``(m, n)`` Jacobian of the residuals.
    cost : float
        Half the sum of squared residuals.
    m : int
        Number of residuals.
    rtol : float
        Relative threshold of the singular values.

    Returns
    -------
    numpy.ndarray
        ``n`` standard deviations (``inf``: undetermined).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.diagnose.linear import parameter_std
    >>> J = np.array([[1.0, 1.0], [1.0, 1.0], [1.0, 1.0]])   # only the sum is determined
    >>> parameter_std(J, 0.5, 3).tolist()
    [inf, inf]
    """
    J = np.asarray(J, float)
    n = J.shape[1]
    if n == 0:
        return np.zeros(0)
    s2 = 2 * cost / max(m - n, 1)
    _, sv, Vt = np.linalg.svd(J.T @ J)
    sv = np.sqrt(np.maximum(sv, 0.0))
    if sv[0] == 0:
        return np.full(n, np.inf)
    good = sv > rtol * sv[0]
    d = np.sqrt((Vt[good].T ** 2) @ (1.0 / sv[good] ** 2) * s2)
    if not good.all():
        weak = (np.abs(Vt[~good]) > 1e-3).any(axis=0)
        d[weak] = np.inf
    return d
