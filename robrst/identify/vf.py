"""Discrete-time vector fitting on input-output data, and the exact return to continuous time.

The sampled model is sought in modal form ``H(z) = sum_p R_p / (z - a_p) + D`` with
poles shared by every output and input.  Vector fitting (Gustavsen & Semlyen; here in
the z-domain, on input-output data rather than on a measured FRF) alternates

1. with the current poles ``a_p`` fixed, the linear least-squares problem
   ``N(z) U - sigma(z) Y = 0``, ``sigma = 1 + sum d_p/(z - a_p)`` (a Steiglitz–McBride /
   Sanathanan–Koerner step: consistent for white output noise), solved output by
   output with the private numerator columns eliminated by QR;
2. relocation: the new poles are the zeros of ``sigma`` (eigenvalues of
   ``Lambda - b d^T``), unstable ones reflected into the unit circle.

Data are either spectra at excited DFT lines of periodic records (averaged over
periods; exact steady state) or time signals (the basis is then applied by filtering
from rest).  A time record need not start at rest (``fit_data(..., free=True)``): its
constant output offset and the free response of its initial state, in the current
poles (:mod:`robrst.identify._free`), are then nuisance terms of every least-squares
problem, eliminated record by record (each record's equations projected onto the
orthogonal complement of its nuisance columns).  Both are weighted so a residual's squared norm is the
time-domain output-error energy (Parseval), and they may be mixed.  Finally the
residues are fitted by output-error least squares with the poles fixed.

:func:`to_continuous` inverts the zero-order hold mode by mode
(``s = fs ln z``, ``R = R_d s / (z - 1)``): no polynomial is ever expanded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import linalg, signal

from robrst.base.errors import SpecError
from robrst.identify._free import SIGNIFICANT_SIGMAS, free_columns
from robrst.identify.modal import DiscreteModel, ModalModel, pair_weight
from robrst.core.lti import d2c_modal

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset

__all__ = ["FitData", "fit_data", "initial_poles", "vector_fit", "fit_residues",
           "to_continuous", "EXCITED_DB", "markov_rows", "relative_degree",
           "output_error_jacobian"]

EXCITED_DB = 40.0   # a DFT line is excited if its input power is within 40 dB of the
                    # strongest line above DC (DC: a bias, not an excitation of the dynamics)


@dataclass(frozen=True, eq=False)
class FitData:
    """Records prepared for fitting: spectra of periodic ones, signals of the others.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    n_in, n_out : int
        Number of inputs and outputs.
    freq : tuple
        Per periodic record ``(z (L,), U (L, k), Y (L, m), weight)`` at its excited lines.
    time : tuple
        Per non-periodic record ``(U (N, k), Y (N, m), free)``.
    band : tuple of float
        ``(f_lo, f_hi)`` [Hz]: the excited lines, or record length to Nyquist.
    """

    fs: float
    n_in: int
    n_out: int
    freq: tuple     # (z (L,), U (L, k), Y (L, m), weight) per periodic record
    time: tuple     # (U (N, k), Y (N, m), free) per non-periodic record
    band: tuple     # (f_lo, f_hi) [Hz]: excited lines, or record length to Nyquist


def fit_data(records: Sequence[Dataset], free: bool | Sequence[bool] = False) -> FitData:
    """Split records into periodic spectra (excited lines) and time signals.

    Parameters
    ----------
    records : sequence of Dataset
        Records of one sampling rate and channel counts.
    free : bool or sequence of bool
        One value, or one per record: a time record need not start at rest; its constant
        output offset and initial-state free response are estimated with the model
        (nuisance terms).  Default False: records start at rest, with no offset.

    Returns
    -------
    FitData
    """
    fs = records[0].fs
    flags = [bool(free)] * len(records) if np.ndim(free) == 0 else [bool(f) for f in free]
    freq, time, lo, hi = [], [], [], []
    for d, flag in zip(records, flags):
        U, Y = d.U - 0.0, d.Y - 0.0
        if d.period and d.periods >= 1:
            P = d.period
            Uf = np.fft.rfft(U.reshape(d.periods, P, -1), axis=1).mean(axis=0)
            Yf = np.fft.rfft(Y.reshape(d.periods, P, -1), axis=1).mean(axis=0)
            power = np.sum(np.abs(Uf) ** 2, axis=1)
            # relative to the strongest line above DC: a bias (a unipolar piezo drive) is
            # no excitation of the dynamics, and would otherwise hide every line below it
            ref = power[1:].max() if power[1:].max() > 0 else power[0]
            lines = np.flatnonzero(power > ref * 10 ** (-EXCITED_DB / 10))
            z = np.exp(2j * np.pi * lines / P)
            w = np.where((lines == 0) | (2 * lines == P), 1.0, 2.0) * d.periods / P
            freq.append((z, Uf[lines], Yf[lines], np.sqrt(w)))
            pos = lines[lines > 0] * fs / P
            lo.append(pos.min() if pos.size else fs / P)
            hi.append(pos.max() if pos.size else 0.48 * fs)
        else:
            time.append((U, Y, flag))
            lo.append(fs / d.n)
            hi.append(0.48 * fs)
    return FitData(fs=fs, n_in=records[0].n_in, n_out=records[0].n_out, freq=tuple(freq),
                   time=tuple(time), band=(min(lo), max(hi)))


def initial_poles(n: int, fs: float, f_lo: float, f_hi: float) -> np.ndarray:
    """``n`` starting poles (z-domain): lightly damped pairs evenly spaced in [f_lo, f_hi] Hz.

    Even spacing (not logarithmic) is vector fitting's usual start for resonant data;
    an odd order adds a real pole at ``f_lo``.

    Parameters
    ----------
    n : int
        The model order (a pair counts two).
    fs : float
        Sampling rate [Hz].
    f_lo, f_hi : float
        The band [Hz].

    Returns
    -------
    numpy.ndarray
        The stored poles in z (real, or positive imaginary part).
    """
    npair = n // 2
    f_lo = max(f_lo, 1e-6)
    f = np.linspace(f_lo, max(min(f_hi, 0.49 * fs), f_lo), npair + 1)[1:]
    w = 2 * np.pi * f
    s = -w / 100 + 1j * w
    poles = list(np.exp(s / fs))
    if n % 2:
        poles.insert(0, np.exp(-2 * np.pi * max(f_lo, 1e-6) / fs) + 0j)
    return np.array(poles, complex)


def _basis_freq(z, poles):
    """Real basis functions at the points z: (L, n_basis) complex."""
    cols = []
    for a in poles:
        g = 1.0 / (z - a)
        if a.imag > 0:
            h = 1.0 / (z - np.conj(a))
            cols += [g + h, 1j * (g - h)]
        else:
            cols.append(g)
    return np.column_stack(cols)


def _basis_time(x, poles):
    """Real basis applied to the signal x (filtered from rest): (N, n_basis)."""
    cols = []
    for a in poles:
        s = signal.lfilter([0.0, 1.0], [1.0, -a], x)
        if a.imag > 0:
            cols += [2 * s.real, -2 * s.imag]
        else:
            cols.append(s.real)
    return np.column_stack(cols)


def _eliminate(N, A, b):
    """``[A | b]`` once the nuisance columns ``N`` are solved for: projected onto the
    orthogonal complement of ``N``'s columns (same least-squares residual for every
    value of ``A``'s unknowns).  Returns ``(A', b', equations left)``."""
    R, scale = tall_r(N)
    Q = linalg.solve_triangular(R, (N / scale).T, trans="T").T     # N = Q R diag(scale)
    M = np.column_stack([A, b])
    M = M - Q @ (Q.T @ M)
    return M[:, :-1], M[:, -1], A.shape[0] - N.shape[1]


def _blocks(data, poles, i, with_y, feedthrough):
    """Real design blocks (rows) for output ``i``: [Phi_U | U | -Phi_Y], rhs Y_i.

    Returns ``(A, b, equations)``: with nuisance terms (``free`` records) a time record's
    rows are already reduced, and ``equations`` counts what is left to fit the columns.
    """
    rows_A, rows_b, n_eq = [], [], 0
    for z, U, Y, w in data.freq:
        Phi = _basis_freq(z, poles)
        cols = [Phi * U[:, [j]] for j in range(U.shape[1])]
        if feedthrough:
            cols.append(U)
        if with_y:
            cols.append(-Phi * Y[:, [i]])
        A = np.hstack(cols) * w[:, None]
        b = Y[:, i] * w
        rows_A += [A.real, A.imag]
        rows_b += [b.real, b.imag]
        n_eq += 2 * A.shape[0]
    for U, Y, free in data.time:
        cols = [_basis_time(U[:, j], poles) for j in range(U.shape[1])]
        if feedthrough:
            cols.append(U)
        if with_y:
            cols.append(-_basis_time(Y[:, i], poles))
        A, b = np.hstack(cols), Y[:, i]
        if free:
            A, b, n = _eliminate(free_columns(poles, len(b)), A, b)
        else:
            n = A.shape[0]
        rows_A.append(A)
        rows_b.append(b)
        n_eq += n
    return np.vstack(rows_A), np.concatenate(rows_b), n_eq


def tall_r(M, chunk=8192):
    """Triangular factor ``R`` of the QR of a tall matrix (CholeskyQR2, columns scaled).

    Two Gram passes in row chunks (BLAS-3, a fraction of Householder QR's time on
    very tall matrices) reproduce QR's accuracy for condition numbers below ~1e7 of the
    column-scaled matrix; otherwise (Cholesky fails) Householder QR is used.
    Returns ``(R, scale)`` with ``M / scale = Q R``.
    """
    scale = np.linalg.norm(M, axis=0)
    scale[scale == 0] = 1.0
    n = M.shape[1]

    def gram(f):
        G = np.zeros((n, n))
        for a in range(0, M.shape[0], chunk):
            B = f(M[a:a + chunk] / scale)
            G += B.T @ B
        return G

    try:
        R1 = linalg.cholesky(gram(lambda B: B), lower=False)
        R2 = linalg.cholesky(gram(lambda B: linalg.solve_triangular(R1, B.T, trans="T").T),
                             lower=False)
        R = R2 @ R1
        if np.all(np.isfinite(R)):
            return R, scale
    except linalg.LinAlgError:
        pass
    return np.linalg.qr(M / scale, mode="r"), scale


def _realisation(poles):
    """Real (Lambda, b) with c (zI - Lambda)^-1 b = the real basis (pairs: [[a', a''], [-a'', a']], [2, 0])."""
    blocks, b = [], []
    for a in poles:
        if a.imag > 0:
            blocks.append(np.array([[a.real, a.imag], [-a.imag, a.real]]))
            b += [2.0, 0.0]
        else:
            blocks.append(np.array([[a.real]]))
            b.append(1.0)
    return linalg.block_diag(*blocks), np.array(b)


def _canonical(p):
    """Keep one member per conjugate pair (Im > 0) and real poles; reflect unstable ones.

    A real pole on the negative real axis (or at 0) has no continuous-time counterpart
    under ZOH; it is mirrored to the positive real axis (same modulus, at least 1e-6) and
    the next relocation moves it on.
    """
    p = np.where(np.abs(p) > 1.0, p / np.abs(p) ** 2, p)
    p = np.where(np.abs(p) > 1 - 1e-9, p / np.abs(p) * (1 - 1e-9), p)
    real = np.abs(p.imag) <= 1e-12 * np.maximum(np.abs(p), 1e-300)
    reals = np.maximum(np.abs(p[real].real), 1e-6)
    out = list(reals + 0j) + list(p[(~real) & (p.imag > 0)])
    return np.array(sorted(out, key=lambda z: (abs(np.angle(z)), -abs(z))), complex)


def vector_fit(data: FitData, poles: np.ndarray, n_iter: int = 12, feedthrough: bool = False,
               tol: float = 1e-7) -> np.ndarray:
    """Relocate ``poles`` by vector fitting on ``data``; returns the final poles.

    Parameters
    ----------
    data : FitData
        The prepared records.
    poles : numpy.ndarray
        Starting poles in z (stored members).
    n_iter : int
        Most relocations.
    feedthrough : bool
        Fit a direct term ``D``.
    tol : float
        Stop when the poles move by less than this (relative).

    Returns
    -------
    numpy.ndarray
        The relocated poles in z, stable (unstable ones reflected into the unit circle).
    """
    for _ in range(n_iter):
        nb = int(np.sum(pair_weight(poles)))
        n_priv = nb * data.n_in + (data.n_in if feedthrough else 0)
        R22, rhs = [], []
        for i in range(data.n_out):
            A, b, n_eq = _blocks(data, poles, i, True, feedthrough)
            _enough(n_eq, A.shape[1], nb)
            R, scale = tall_r(np.column_stack([A, b]))
            R[:, -1] *= scale[-1]
            R22.append(R[n_priv:n_priv + nb, n_priv:n_priv + nb] * scale[None, n_priv:n_priv + nb])
            rhs.append(R[n_priv:n_priv + nb, -1])
        M = np.vstack(R22)
        cs = np.linalg.norm(M, axis=0)
        cs[cs == 0] = 1.0
        d = np.linalg.lstsq(M / cs, np.concatenate(rhs), rcond=None)[0] / cs
        Lam, bvec = _realisation(poles)
        new = _canonical(np.linalg.eigvals(Lam - np.outer(bvec, d)))
        if new.size != poles.size:   # a pair split into two reals (or back): keep going
            poles = new
            continue
        change = np.max(np.abs(np.sort_complex(new) - np.sort_complex(poles)))
        poles = new
        if change < tol:
            break
    return poles


def _enough(n_eq, n_unknown, order):
    """Refuse a least-squares system with no more equations than unknowns (a periodic
    record with too few excited lines for this order)."""
    if n_eq <= n_unknown:
        raise SpecError(f"order {order}: {n_eq} equations for {n_unknown} unknowns"
                        " (too few excited lines or samples for this order)")


def markov_rows(poles: np.ndarray, fs: float, n_in: int, count: int) -> np.ndarray:
    """Rows ``G`` with ``G x = 0`` for the first ``count`` continuous Markov parameters of
    every input's channel, ``x`` the real residue unknowns of one output (as
    :func:`fit_residues` orders them: per input, per pole, real and imaginary parts).

    The continuous residue of a sampled one is ``R = Rd s/(z - 1)`` (:func:`d2c_modal`), and
    ``h_k = sum R p^k`` over every pole (conjugates included) is the ``k``-th Markov
    parameter ``C A^k B``: ``h_0 = ... = h_(r-1) = 0`` means a relative degree above ``r``.
    Rows are scaled by ``w0^-k`` (``w0`` the geometric mean of the pole magnitudes).

    Parameters
    ----------
    poles : numpy.ndarray
        Stored sampled poles.
    fs : float
        Sampling rate [Hz].
    n_in : int
        Inputs.
    count : int
        Markov parameters constrained.

    Returns
    -------
    numpy.ndarray
        ``(count * n_in, n_basis * n_in)``.
    """
    s, f = d2c_modal(poles, np.ones((poles.size, 1, 1)), fs)
    f = f[:, 0, 0]
    mags = np.abs(s[np.abs(s) > 0])
    w0 = float(np.exp(np.mean(np.log(mags)))) if mags.size else 1.0
    nb = int(np.sum(pair_weight(poles)))
    rows = []
    for k in range(count):
        g = f * (s / w0) ** k
        block = []
        for a, gp in zip(poles, g):
            block += [2.0 * gp.real, -2.0 * gp.imag] if a.imag > 0 else [gp.real]
        for j in range(n_in):
            row = np.zeros(nb * n_in)
            row[j * nb:(j + 1) * nb] = block
            rows.append(row)
    return np.array(rows).reshape(-1, nb * n_in)


def fit_residues(data: FitData, poles: np.ndarray, feedthrough: bool = False,
                 markov: int = 0) -> tuple:
    """Output-error least squares of residues (and D) with the poles fixed.

    ``markov`` > 0 (no feedthrough) constrains the first ``markov`` continuous Markov
    parameters of every channel to zero (:func:`markov_rows`): a relative degree above
    ``markov`` in continuous time.

    Parameters
    ----------
    data : FitData
    poles : numpy.ndarray
        Stored sampled poles.
    feedthrough : bool
        Fit a direct term ``D``.
    markov : int

    Returns
    -------
    (DiscreteModel, float)
        The model and the summed squared residual.
    """
    dm, cost, _ = _fit_residues(data, poles, feedthrough, markov)
    return dm, cost


def _fit_residues(data, poles, feedthrough=False, markov=0):
    """:func:`fit_residues` plus the equations left over the unknowns (the residual's
    degrees of freedom)."""
    nb = int(np.sum(pair_weight(poles)))
    k, m = data.n_in, data.n_out
    res = np.zeros((poles.size, m, k), complex)
    D = np.zeros((m, k))
    cost, dof = 0.0, 0
    G = markov_rows(poles, data.fs, k, markov) if markov and not feedthrough else None
    for i in range(m):
        A, b, n_eq = _blocks(data, poles, i, False, feedthrough)
        _enough(n_eq, A.shape[1], nb)
        R, scale = tall_r(np.column_stack([A, b]))
        q = A.shape[1]
        dof += n_eq - q
        if G is None:
            x = linalg.lstsq(R[:q, :q], R[:q, q])[0] * scale[-1] / scale[:q]
            cost += float((R[q, q] * scale[-1]) ** 2)
        else:
            # x = N y with N spanning the null space of G (in the scaled unknowns)
            Gs = G / scale[None, :q]
            _, sv, Vt = np.linalg.svd(Gs)
            rank = int(np.sum(sv > 1e-12 * sv[0])) if sv.size else 0
            N = Vt[rank:].T
            M = R[:q, :q] @ N
            y = linalg.lstsq(M, R[:q, q])[0]
            left = R[:q, q] - M @ y
            x = (N @ y) * scale[-1] / scale[:q]
            cost += float((float(left @ left) + R[q, q] ** 2) * scale[-1] ** 2)
        for j in range(k):
            c = x[j * nb:(j + 1) * nb]
            q = 0
            for p, a in enumerate(poles):
                if a.imag > 0:
                    res[p, i, j] = c[q] + 1j * c[q + 1]
                    q += 2
                else:
                    res[p, i, j] = c[q]
                    q += 1
        if feedthrough:
            D[i] = x[nb * k:nb * k + k]
    return DiscreteModel(poles, res, D, data.fs, pair_weight(poles)), cost, dof


def relative_degree(datas: list, poles: list, feedthrough: bool = False,
                    sigmas: float = SIGNIFICANT_SIGMAS) -> int:
    """The continuous relative degree the data support, one for every model and channel.

    Starting from 1 (what a sampled fit gives generically: a leading numerator
    coefficient fitted to the noise puts a zero far beyond Nyquist, e.g. at 1e9 rad/s
    for a second-order stage), the next Markov parameter of every channel is constrained
    to zero while that raises the summed output-error energy over ``datas`` (one
    :class:`FitData` per model, ``poles`` each) by no more than noise would: ``q + sigmas
    sqrt(2 q)`` noise variances for ``q`` constraints (chi-square's mean plus ``sigmas``
    standard deviations); the noise variance is the free fit's residual per degree of
    freedom, pooled.  With ``feedthrough`` the relative degree is 0 (none tested).

    Parameters
    ----------
    datas : list of FitData
        One per model.
    poles : list of numpy.ndarray
        Each model's stored sampled poles.
    feedthrough : bool
    sigmas : float

    Returns
    -------
    int
        The number of leading Markov parameters set to zero (0: relative degree 1).
    """
    if feedthrough:
        return 0
    free = [_fit_residues(d, p) for d, p in zip(datas, poles)]
    base = sum(c for _, c, _ in free)
    var = base / max(sum(f for *_, f in free), 1)
    order = min(int(np.sum(pair_weight(p))) for p in poles)
    per = sum(d.n_in * d.n_out for d in datas)
    r = 0
    while r + 1 < order:
        q = (r + 1) * per
        cost = sum(_fit_residues(d, p, markov=r + 1)[1] for d, p in zip(datas, poles))
        if not cost - base <= (q + sigmas * np.sqrt(2.0 * q)) * var:
            break
        r += 1
    return r


def to_continuous(dmodel: DiscreteModel, label: str = "identified",
                  temperature_C: float | None = None) -> ModalModel:
    """The continuous-time :class:`ModalModel` whose ZOH sampling is ``dmodel`` (exactly).

    Parameters
    ----------
    dmodel : DiscreteModel
        The sampled model.
    label : str
        The model's label.
    temperature_C : float, optional
        Its temperature [°C].

    Returns
    -------
    ModalModel

    Raises
    ------
    SpecError
        For a pole on the negative real axis or at 0 (no real continuous-time
        counterpart).
    """
    z = dmodel.zpoles
    bad = (np.abs(z.imag) == 0) & (z.real <= 0)
    if np.any(bad):
        raise SpecError(f"identified pole z = {z[bad][0].real:.3g} on the negative real axis has"
                        " no continuous-time counterpart (too high an order for the data?)")
    s, residues = d2c_modal(z, dmodel.residues, dmodel.fs)
    return ModalModel(s, residues, dmodel.D, label=label, temperature_C=temperature_C)


def _pole_theta(poles):
    """Real parameters of stored sampled poles: ``(ln|z|, arg z)`` per pair, ``ln z`` per
    real pole (positive: a negative one has no continuous counterpart)."""
    out = []
    for a in poles:
        out += [np.log(abs(a)), np.angle(a)] if a.imag > 0 else [np.log(abs(a.real))]
    return np.array(out)


def _theta_poles(theta, template):
    out, k = [], 0
    for a in template:
        if a.imag > 0:
            out.append(np.exp(theta[k] + 1j * theta[k + 1]))
            k += 2
        else:
            out.append(np.exp(theta[k]) + 0j)
            k += 1
    return np.array(out, complex)


def _x_of(dm, feedthrough):
    """Per output, the real unknowns of :func:`fit_residues` (its column order)."""
    xs = []
    for i in range(dm.D.shape[0]):
        x = []
        for j in range(dm.D.shape[1]):
            for p, a in enumerate(dm.zpoles):
                R = dm.residues[p, i, j]
                x += [R.real, R.imag] if a.imag > 0 else [R.real]
        if feedthrough:
            x += list(dm.D[i])
        xs.append(np.array(x))
    return xs


def output_error_jacobian(data: FitData, dm: DiscreteModel, feedthrough: bool = False,
                          markov: int = 0, step: float = 1e-7) -> tuple:
    """The output-error least-squares problem of a fitted sampled model, linearised.

    Parameters are ``theta = [pole parameters (ln|z|, arg z per pair; ln z per real
    pole), then per output the residue unknowns]`` (in the null space of the Markov
    constraints when ``markov`` > 0, :func:`markov_rows`).  The residual is the stacked
    output error of every output (a time record's nuisance terms eliminated, as in the
    fit).  The pole columns are central differences.

    Parameters
    ----------
    data : FitData
        What ``dm`` was fitted on.
    dm : DiscreteModel
        The fit.
    feedthrough : bool
    markov : int
        Markov parameters constrained in the fit.
    step : float
        Relative step of the central differences.

    Returns
    -------
    J : ndarray (rows, parameters)
    r : ndarray (rows,)
        The residual at ``dm``.
    theta : ndarray
    model_of : callable
        ``theta -> DiscreteModel``.
    dof : int
        Equations left over the parameters.
    """
    poles = dm.zpoles
    k, m = data.n_in, data.n_out
    tp = _pole_theta(poles)
    G = markov_rows(poles, data.fs, k, markov) if markov and not feedthrough else None
    Ns, ys = [], []
    for x in _x_of(dm, feedthrough):
        if G is None:
            N = np.eye(x.size)
        else:
            Gp = np.hstack([G, np.zeros((G.shape[0], x.size - G.shape[1]))])
            _, sv, Vt = np.linalg.svd(Gp)
            N = Vt[int(np.sum(sv > 1e-12 * sv[0])):].T
        Ns.append(N)
        ys.append(N.T @ x)
    nb = int(np.sum(pair_weight(poles)))

    def blocks(p):
        return [_blocks(data, p, i, False, feedthrough) for i in range(m)]

    def residual(p, ys_):
        return np.concatenate([b - A @ (N @ y) for (A, b, _), N, y in zip(blocks(p), Ns, ys_)])

    base = blocks(poles)
    r = np.concatenate([b - A @ (N @ y) for (A, b, _), N, y in zip(base, Ns, ys)])
    cols = []
    for q in range(tp.size):
        h = step * max(1.0, abs(tp[q]))
        up, dn = tp.copy(), tp.copy()
        up[q] += h
        dn[q] -= h
        cols.append((residual(_theta_poles(up, poles), ys)
                     - residual(_theta_poles(dn, poles), ys)) / (2 * h))
    rows = r.size
    lin = []
    off = 0
    for (A, _, _), N in zip(base, Ns):
        blk = np.zeros((rows, N.shape[1]))
        blk[off:off + A.shape[0]] = -A @ N
        off += A.shape[0]
        lin.append(blk)
    J = np.column_stack(cols + lin)
    n_eq = sum(n for _, _, n in base)
    theta = np.concatenate([tp] + ys)

    def model_of(th):
        p = _theta_poles(th[:tp.size], poles)
        res = np.zeros((poles.size, m, k), complex)
        D = np.zeros((m, k))
        o = tp.size
        for i, N in enumerate(Ns):
            x = N @ th[o:o + N.shape[1]]
            o += N.shape[1]
            for j in range(k):
                c, q = x[j * nb:(j + 1) * nb], 0
                for pi, a in enumerate(p):
                    if a.imag > 0:
                        res[pi, i, j] = c[q] + 1j * c[q + 1]
                        q += 2
                    else:
                        res[pi, i, j] = c[q]
                        q += 1
            if feedthrough:
                D[i] = x[nb * k:nb * k + k]
        return DiscreteModel(p, res, D, data.fs, pair_weight(p))

    return J, r, theta, model_of, max(n_eq - theta.size, 1)
