"""Continuous-time linear models in modal (partial-fraction) form, SISO or MIMO.

``G(s) = sum_p R_p / (s - p) + D`` with ``R_p`` the ``m x k`` residue of pole ``p``
(every output from every input shares the poles: a common-denominator transfer
matrix).  A complex pair is stored once (the member with positive imaginary part);
its conjugate term is implied, so every model is real.  This form needs no expanded
polynomial (coefficients of a 28th-order denominator would span hundreds of decades)
and makes the zero-order-hold discretisation exact mode by mode.

:func:`robrst.core.lti.zoh_modal` is the ZOH discretisation of the modal form; :class:`DiscreteModel`
simulates the sampled model from rest (parallel first-order recursions) or in
periodic steady state (exact, through the DFT).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import signal

from robrst.base.errors import SpecError
from robrst.core.lti import modal_polynomials, zoh_modal
from robrst.core.plant import Plant

if TYPE_CHECKING:
    import control
    from numpy.typing import ArrayLike

__all__ = ["ModalModel", "DiscreteModel", "pair_weight"]


def pair_weight(poles: ArrayLike) -> np.ndarray:
    """2 for the stored member of a complex pair (its conjugate is implied), 1 for real.

    Parameters
    ----------
    poles : array_like
        Stored poles (real, or positive imaginary part).

    Returns
    -------
    numpy.ndarray
        One weight per pole.
    """
    return np.where(np.imag(poles) > 0, 2.0, 1.0)


@dataclass(frozen=True, eq=False)
class ModalModel:
    """``G(s) = sum_p R_p/(s - p) + D``: poles [rad/s], residues ``(n, m, k)``, ``D (m, k)``.

    Units: inputs V, outputs µm, s in rad/s.  Stored poles are real or have positive
    imaginary part (see the module docstring).

    Parameters
    ----------
    poles : numpy.ndarray
        The stored poles [rad/s].
    residues : numpy.ndarray
        ``(n, m, k)``: the residue matrix of each pole.
    D : numpy.ndarray
        ``(m, k)``: the feedthrough.
    label : str
        Name used in files and reports.
    temperature_C : float, optional
        The temperature the model holds at [°C].

    Attributes
    ----------
    n_in, n_out : int
        Number of inputs ``k`` and outputs ``m``.
    order : int
        Number of poles counting both members of a pair (the SISO order).

    Raises
    ------
    SpecError
        Residues not of shape ``(n_poles, outputs, inputs)``, or poles that are not
        finite or stored with ``Im < 0``.
    """

    poles: np.ndarray
    residues: np.ndarray
    D: np.ndarray
    label: str = "model"
    temperature_C: float = None

    def __post_init__(self):
        p = np.asarray(self.poles, complex).ravel()
        R = np.asarray(self.residues, complex)
        D = np.atleast_2d(np.asarray(self.D, float))
        if R.ndim != 3 or R.shape[0] != p.size or R.shape[1:] != D.shape:
            raise SpecError(f"model {self.label!r}: residues must be (n_poles, outputs, inputs)"
                            f" = ({p.size}, {D.shape[0]}, {D.shape[1]}), got {R.shape}")
        if np.any(np.imag(p) < 0) or not (np.all(np.isfinite(p)) and np.all(np.isfinite(R))):
            raise SpecError(f"model {self.label!r}: poles must be finite, stored with Im >= 0")
        real = np.imag(p) == 0
        R = np.where(real[:, None, None], R.real + 0j, R)
        object.__setattr__(self, "poles", p)
        object.__setattr__(self, "residues", R)
        object.__setattr__(self, "D", D)

    @property
    def n_in(self):
        return self.D.shape[1]

    @property
    def n_out(self):
        return self.D.shape[0]

    @property
    def order(self):
        """Number of poles counting both members of a pair (the SISO order)."""
        return int(np.sum(pair_weight(self.poles)))

    def all_poles(self) -> np.ndarray:
        """Every pole, conjugates included [rad/s].

        Returns
        -------
        numpy.ndarray
        """
        p = self.poles
        return np.concatenate([p, np.conj(p[np.imag(p) > 0])])

    def freqresp(self, w: ArrayLike) -> np.ndarray:
        """Frequency response ``(F, m, k)`` at ``w`` [rad/s].

        Parameters
        ----------
        w : array_like
            ``F`` frequencies [rad/s].

        Returns
        -------
        numpy.ndarray
            Complex, ``(F, m, k)`` [µm/V].
        """
        s = 1j * np.atleast_1d(np.asarray(w, float))
        p, R = self.poles, self.residues
        out = np.zeros((s.size, self.n_out, self.n_in), complex) + self.D
        for pk, Rk in zip(p, R):
            out += Rk[None] / (s - pk)[:, None, None]
            if pk.imag > 0:
                out += np.conj(Rk)[None] / (s - np.conj(pk))[:, None, None]
        return out

    def dc_gain(self) -> np.ndarray:
        """Static gain ``(m, k)`` [µm/V] (inf entries for a pole at 0).

        Returns
        -------
        numpy.ndarray
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.freqresp([0.0])[0].real

    def discretise(self, fs: float) -> DiscreteModel:
        """The ZOH-sampled model at ``fs`` [Hz] (:class:`DiscreteModel`).

        Parameters
        ----------
        fs : float
            Sampling rate [Hz].

        Returns
        -------
        DiscreteModel
        """
        zp, dres = zoh_modal(self.poles, self.residues, fs)
        return DiscreteModel(zp, dres, self.D, float(fs), pair_weight(self.poles))

    def channel(self, i: int = 0, j: int = 0, label: str | None = None) -> Plant:
        """Output ``i`` from input ``j`` as a :class:`~robrst.core.plant.Plant` ``B(s)/A(s)``.

        Expanded in the scaled variable ``s / w0`` (``w0`` the geometric mean of the
        pole magnitudes) so the coefficients keep their precision, then unscaled.

        Parameters
        ----------
        i, j : int
            Output and input index.
        label : str, optional
            The plant's label (default ``"<label>_y<i+1>u<j+1>"``).

        Returns
        -------
        Plant
            At the model's temperature.

        Raises
        ------
        SpecError
            When the unscaled coefficients overflow float64.
        """
        B, A = modal_polynomials(self.poles, self.residues[:, i, j], self.D[i, j])
        n = len(A) - 1
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
            mags = np.abs(self.all_poles())
            w0 = float(np.exp(np.mean(np.log(mags[mags > 0])))) if np.any(mags > 0) else 1.0
            raise SpecError(f"model {self.label!r}: the expanded polynomials B(s), A(s) of"
                            f" order {n} overflow float64 (pole magnitudes around {w0:.3g}"
                            f" rad/s, w0^{n}); use the modal form")
        return Plant(B, A, label=label or f"{self.label}_y{i + 1}u{j + 1}",
                     temperature_C=self.temperature_C)

    @classmethod
    def from_plant(cls, plant: Plant, label: str | None = None) -> ModalModel:
        """Partial-fraction form of a SISO :class:`~robrst.core.plant.Plant` (distinct poles).

        Parameters
        ----------
        plant : Plant
            The model ``B(s)/A(s)``.
        label : str, optional
            The model's label (default the plant's).

        Returns
        -------
        ModalModel

        Raises
        ------
        SpecError
            For repeated poles (no modal form).
        """
        A, B = np.asarray(plant.A, float), np.asarray(plant.B, float)
        roots = np.roots(A)
        n = roots.size
        scale = np.maximum(np.abs(roots[:, None]), np.abs(roots[None, :]))
        gap = np.where(np.eye(n, dtype=bool), np.inf, np.abs(roots[:, None] - roots[None, :]))
        if n and np.min(gap / np.maximum(scale, 1e-300)) < 1e-6:
            raise SpecError(f"plant {plant.label!r}: repeated poles have no modal form;"
                            " separate them (e.g. by 1e-4 relative)")
        D = B[0] if len(B) == len(A) else 0.0
        Br = np.polysub(B, D * A) if D else B
        poles, res = [], []
        for k, pk in enumerate(roots):
            if pk.imag < 0 or (pk.imag > 0 and abs(pk.imag) < 1e-12 * abs(pk)):
                continue
            rk = np.polyval(Br, pk) / np.prod(pk - np.delete(roots, k))
            poles.append(pk if pk.imag > 0 else pk.real + 0j)
            res.append(rk)
        return cls(np.array(poles), np.array(res, complex).reshape(-1, 1, 1), [[D]],
                   label=label or plant.label, temperature_C=plant.temperature_C)

    def to_control(self) -> control.StateSpace:
        """A real ``control.StateSpace`` (block-diagonal, one block per mode and input).

        Returns
        -------
        control.StateSpace
        """
        import control

        m, k = self.n_out, self.n_in
        blocks_A, blocks_B, blocks_C = [], [], []
        for p, R in zip(self.poles, self.residues):
            for j in range(k):
                if p.imag > 0:
                    blocks_A.append(np.array([[p.real, p.imag], [-p.imag, p.real]]))
                    b = np.zeros((2, k))
                    b[0, j] = 2.0
                    blocks_B.append(b)
                    blocks_C.append(np.column_stack([R[:, j].real, R[:, j].imag]))
                else:
                    blocks_A.append(np.array([[p.real]]))
                    b = np.zeros((1, k))
                    b[0, j] = 1.0
                    blocks_B.append(b)
                    blocks_C.append(R[:, j].real.reshape(m, 1))
        from scipy.linalg import block_diag

        return control.ss(block_diag(*blocks_A), np.vstack(blocks_B), np.hstack(blocks_C), self.D)


@dataclass(frozen=True, eq=False)
class DiscreteModel:
    """A ZOH-sampled modal model: ``y[k] = sum_p w_p Re(R_p x_p[k]) + D u[k]``.

    ``x_p[k+1] = z_p x_p[k] + u[k]``: ``y[k]`` is sampled at the instant ``u[k]`` is
    applied (a strictly proper model's ``y[k]`` depends on ``u`` up to ``k - 1``).

    Parameters
    ----------
    zpoles : numpy.ndarray
        The sampled poles (stored members).
    residues : numpy.ndarray
        ``(n, m, k)`` discrete residues.
    D : numpy.ndarray
        ``(m, k)`` feedthrough.
    fs : float
        Sampling rate [Hz].
    weight : numpy.ndarray
        2 for a stored complex pair, 1 for a real pole.

    Attributes
    ----------
    stable : bool
        Every sampled pole inside the unit circle.
    """

    zpoles: np.ndarray
    residues: np.ndarray
    D: np.ndarray
    fs: float
    weight: np.ndarray

    @property
    def stable(self):
        return bool(np.all(np.abs(self.zpoles) < 1.0))

    def states(self, u: ArrayLike, pole_index: Sequence[int] | None = None) -> np.ndarray:
        """``x_p`` for each pole (rows) driven by the 1-D input ``u`` from rest.

        Parameters
        ----------
        u : array_like
            One input, ``N`` samples.
        pole_index : sequence of int, optional
            The poles to simulate (default all).

        Returns
        -------
        numpy.ndarray
            Complex, ``(len(pole_index), N)``.
        """
        idx = range(self.zpoles.size) if pole_index is None else pole_index
        u = np.asarray(u, float)
        return np.array([signal.lfilter([0.0, 1.0], [1.0, -self.zpoles[p]], u) for p in idx])

    def response(self, U: ArrayLike, periodic: bool = False,
                 poles: Sequence[int] | None = None) -> np.ndarray:
        """Output ``(N, m)`` for inputs ``U`` (N or N x k); ``poles`` limits the modes.

        Parameters
        ----------
        U : array_like
            Inputs, ``N`` or ``(N, k)``.
        periodic : bool
            The record holds whole periods of a periodic input, and the response is the
            periodic steady state (exact, by the DFT) instead of a start from rest.
        poles : sequence of int, optional
            Indices of the modes to include; the feedthrough ``D`` is included only when
            ``poles`` is None.

        Returns
        -------
        numpy.ndarray
            ``(N, m)`` [µm].
        """
        U = np.asarray(U, float).reshape(len(U), -1)
        N = U.shape[0]
        idx = np.arange(self.zpoles.size) if poles is None else np.atleast_1d(poles)
        if periodic:
            Uf = np.fft.rfft(U, axis=0)
            z = np.exp(2j * np.pi * np.arange(Uf.shape[0]) / N)
            H = self.transfer(z, idx, with_d=poles is None)     # (F, m, k)
            return np.fft.irfft(np.einsum("fmk,fk->fm", H, Uf), n=N, axis=0)
        Y = np.zeros((N, self.D.shape[0]))
        for j in range(U.shape[1]):
            if idx.size:
                X = self.states(U[:, j], idx)
                W = (self.residues[idx, :, j] * self.weight[idx, None]).T   # (m, n)
                Y += (W @ X).real.T
            if poles is None:
                Y += np.outer(U[:, j], self.D[:, j])
        return Y

    def transfer(self, z: ArrayLike, poles: Sequence[int] | None = None,
                 with_d: bool = True) -> np.ndarray:
        """``H(z)`` as ``(F, m, k)`` at the points ``z`` (conjugate terms included).

        Parameters
        ----------
        z : array_like
            ``F`` points of the z-plane.
        poles : sequence of int, optional
            Indices of the modes to include (default all).
        with_d : bool
            Include the feedthrough.

        Returns
        -------
        numpy.ndarray
            Complex, ``(F, m, k)``.
        """
        z = np.atleast_1d(np.asarray(z, complex))
        idx = np.arange(self.zpoles.size) if poles is None else np.atleast_1d(poles)
        H = np.zeros((z.size,) + self.D.shape, complex) + (self.D if with_d else 0.0)
        for p in idx:
            zp, R = self.zpoles[p], self.residues[p]
            H += R[None] / (z - zp)[:, None, None]
            if self.weight[p] == 2.0:
                H += np.conj(R)[None] / (z - np.conj(zp))[:, None, None]
        return H
