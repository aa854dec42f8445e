"""Numeric data of the robust RST program (everything but the CasADi graph).

Everything is posed in the scaled variable ``p = s / w0``.  Plant polynomials are
divided by ``w0**deg A`` and the controller by ``w0**deg S``, which keeps every
closed-loop ratio unchanged while bringing coefficients to O(1).  Decision
variables: the free coefficients of ``S'`` and ``R'`` (``S = Sf S'``, ``R = Rf R'``),
optionally the dominant pole parameters ``(wn, zeta)``, and ``gamma`` (the worst
normalised spec ratio of the soft-goal phase, or the ``|S|`` bound of ``min_Ms``).  Every
closed-loop polynomial is *affine* in the controller coefficients, so on a frequency
grid each peak constraint ``|N(jw)|^2 <= M^2 |Delta(jw)|^2`` (denominators cleared,
divided by a fixed weight ``|Delta_0(jw)|^2``) is a quadratic in the variables: this
module turns a problem into those numeric rows (:class:`GridBlock`), the Routh and
Diophantine maps; :mod:`robrst.synthesis.template` holds the one CasADi program that
takes them as parameters.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core import poly
    from robrst.core.plant import Plant


__all__ = ["GridBlock", "NLPSetup", "Region", "t_map", "grid_blocks", "conv_matrix", "jw_matrices",
           "routh_column", "scale_plant", "closed_loop_maps", "affine_controller",
           "objective_rows", "shift_matrix", "controller_conditions", "local_maxima",
           "PEAK_KEYS"]

PEAK_KEYS = ("S", "T", "U", "Tband", "Uhf", "Sd", "Ry")


def conv_matrix(c: ArrayLike, n: int) -> np.ndarray:
    """Matrix ``M`` with ``M @ x == np.convolve(c, x)`` for ``len(x) == n``.

    Parameters
    ----------
    c : array_like
        Coefficients.
    n : int
        Length of ``x``.

    Returns
    -------
    numpy.ndarray
        ``(len(c) + n - 1, n)``.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.synthesis._nlp import conv_matrix
    >>> (conv_matrix([1.0, 2.0], 2) @ np.array([3.0, 4.0])).tolist()
    [3.0, 10.0, 8.0]
    """
    c = np.asarray(c, dtype=float)
    M = np.zeros((len(c) + n - 1, n))
    for j in range(n):
        M[j:j + len(c), j] = c
    return M


def jw_matrices(nu: np.ndarray, deg: int) -> tuple[np.ndarray, np.ndarray]:
    """Real and imaginary parts of ``[ (j nu)^deg, ..., 1 ]`` (highest power first).

    Parameters
    ----------
    nu : numpy.ndarray
        Scaled frequencies.
    deg : int
        The degree.

    Returns
    -------
    real, imag : numpy.ndarray
        ``(len(nu), deg + 1)``: ``c(j nu) = (real + j imag) @ c``.
    """
    k = np.arange(deg, -1, -1)
    z = (1j * np.asarray(nu, float)[:, None]) ** k[None, :]
    return z.real, z.imag


def routh_column(c: np.ndarray | ca.MX) -> np.ndarray | ca.MX:
    """First column of the Routh array of a polynomial with symbolic (CasADi) or numeric
    (1-D numpy) coefficients.

    All entries > 0 (with ``c[0] > 0``) is the Hurwitz condition.

    Parameters
    ----------
    c : numpy.ndarray or casadi.MX
        Coefficients, highest power first (a 1-D array, or a CasADi column).

    Returns
    -------
    numpy.ndarray or casadi.MX
        The column (normalised as the program's rows), numeric or symbolic as ``c``.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.synthesis._nlp import routh_column
    >>> bool((routh_column(np.array([1.0, 3.0, 3.0, 1.0])) > 0).all())   # (s + 1)^3: Hurwitz
    True
    """
    numeric = isinstance(c, np.ndarray)
    n = (c.size if numeric else c.numel()) - 1
    r0 = [c[i] for i in range(0, n + 1, 2)]
    r1 = [c[i] for i in range(1, n + 1, 2)]
    col = [r0[0]]
    while r1:
        col.append(r1[0])
        nxt = []
        for i in range(len(r0) - 1):
            b = r1[i + 1] if i + 1 < len(r1) else 0
            nxt.append((r1[0] * r0[i + 1] - r0[0] * b) / r1[0])
        r0, r1 = r1, nxt
    return np.array(col, dtype=float) if numeric else ca.vertcat(*col)


def shift_matrix(deg: int, a: float) -> np.ndarray:
    """Matrix ``M`` with ``M @ c`` the coefficients of ``c(p - a)`` (``len(c) == deg + 1``).

    Parameters
    ----------
    deg : int
        The degree.
    a : float
        The shift.

    Returns
    -------
    numpy.ndarray
        ``(deg + 1, deg + 1)``.
    """
    M = np.zeros((deg + 1, deg + 1))
    for j in range(deg + 1):          # column j: the monomial p**(deg - j)
        col = np.ones(1)
        for _ in range(deg - j):
            col = np.convolve(col, [1.0, -a])
        M[j:, j] = col
    return M


@dataclass(frozen=True, eq=False)
class NLPSetup:
    """Numeric data of one program instance (all polynomials scaled).

    Parameters
    ----------
    w0 : float
        The frequency scale [rad/s].
    models : tuple
        ``((label, T, a, b), ...)``: the scaled plant polynomials.
    ref : int
        Index of the nominal model in ``models``.
    Sf, Rf : numpy.ndarray
        Scaled fixed factors of S (monic) and R.
    ks, kr : int
        Degrees of ``S'`` and ``R'``.
    nu : numpy.ndarray
        Scaled frequency grid.
    bounds : dict
        ``{"S": Ms, "T": Mt, "U": Mu, "Tband": ..., "Uhf": ..., "Sd": Msd, "Ry": Mry}``.
    objective : str
        The objective.
    Am_fixed : numpy.ndarray
        Scaled monic Am (placement ``"fixed"``).
    pole_bounds : tuple
        ``((wn_lo, wn_hi), (z_lo, z_hi))`` scaled (placement ``"dominant"``).
    aux_factor : float
        Auxiliary poles at this factor times the fastest dominant one.
    n_dom_real : tuple
        Extra dominant real poles (scaled), fixed.
    stable_controller : bool
        ``S/s`` must be Hurwitz.
    bands : tuple
        Per model, its scaled resonance-band grid.
    rates : tuple
        ``(label, sample rate [Hz])`` of the sampled-loop models.
    placement : {"fixed", "dominant", "free"}
        Nominal closed loop ``= Am_fixed``; ``(wn, zeta)`` free within ``pole_bounds``; or
        no Diophantine equality (stability of every model by Routh only).
    hf : tuple
        Per model, its scaled grid above the ``Mu_hf`` frequency.
    integrators : int
        Roots of S at ``s = 0``.
    sign : float
        Sign of the integral gain of a stabilising controller.
    ctrl_shift : float, optional
        The controller's poles other than its integrators are kept at
        ``Re p <= -ctrl_shift`` (``None``: not imposed) — ``max_integral_gain`` needs it,
        else a second slow controller pole makes ``lim s K(s)`` unbounded.
    ctrl_max : float, optional
        And at ``Re p >= -ctrl_max`` (with every coefficient free, a controller pole can
        otherwise run off to infinity chasing a PI/PID limit).
    grids : tuple
        Per model, its scaled grid for S, T, U (default: ``nu``).
    T_shape : numpy.ndarray, optional
        ``T = R(0) T_shape`` (scaled, ``T_shape(0) = 1``: the feed-forward of the
        structure's ``T_mode``), for the ``|B T / Delta|`` bound ``"Ry"``.
    fs_of : tuple
        Per model, the sample rate of a sampled-loop model (``None``: continuous).
    region : Region, optional
        The pole region.
    model_bounds : dict, optional
        ``{key: (bound of model 0, ...)}``: a block's bound that differs per model (the
        ``|B S / Delta|`` bound of ``Msd_rel_max``: the ratio times each model's own
        open-loop peak), combined with ``bounds`` by :meth:`bound`.

    Attributes
    ----------
    n_x : int
        Length of the controller part of the decision vector.
    free_poles : bool
        ``placement == "dominant"``.
    """

    w0: float
    models: tuple          # ((label, T, a, b), ...) scaled plant polynomials
    ref: int               # index of the nominal model in ``models``
    Sf: np.ndarray         # scaled fixed factor of S (monic)
    Rf: np.ndarray         # scaled fixed factor of R
    ks: int                # degree of S'
    kr: int                # degree of R'
    nu: np.ndarray         # scaled frequency grid
    bounds: dict           # {"S": Ms, "T": Mt, "U": Mu, "Tband": ..., "Uhf": ...}
    objective: str
    Am_fixed: np.ndarray   # scaled monic Am (placement "fixed")
    pole_bounds: tuple     # ((wn_lo, wn_hi), (z_lo, z_hi)) scaled (placement "dominant")
    aux_factor: float
    n_dom_real: tuple      # extra dominant real poles (scaled), fixed
    stable_controller: bool
    bands: tuple = ()      # per model, its scaled resonance-band grid
    rates: tuple = ()      # (label, sample rate [Hz]) of the sampled-loop models
    placement: str = "fixed"
    hf: tuple = ()         # per model, its scaled grid above the Mu_hf frequency
    integrators: int = 1
    sign: float = 1.0      # sign of the integral gain of a stabilising controller
    ctrl_shift: float = None
    ctrl_max: float = None
    grids: tuple = ()      # per model, its scaled grid for S, T, U (default: nu)
    T_shape: np.ndarray = None
    fs_of: tuple = ()
    region: Region | None = None
    model_bounds: dict = None   # {key: per model, its own bound (None: none)}

    def bound(self, key: str, model: int) -> float | None:
        """The bound of block ``key`` on model ``model``: the smaller of ``bounds[key]``
        and the model's own (``model_bounds``; a relative spec such as ``Msd_rel_max``).

        Parameters
        ----------
        key : str
            The block (:data:`PEAK_KEYS`).
        model : int
            Index into ``models``.

        Returns
        -------
        float or None
        """
        b = self.bounds.get(key)
        own = (self.model_bounds or {}).get(key)
        m = None if own is None else own[model]
        if m is None or not np.isfinite(m):
            return b
        return m if b is None else min(b, m)

    @property
    def n_x(self):
        return self.ks + self.kr + 1

    @property
    def free_poles(self):
        return self.placement == "dominant"


def affine_controller(setup: NLPSetup) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Numeric maps ``S = Ls x + s0`` and ``R = Lr x`` of the decision vector ``x``.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.

    Returns
    -------
    Ls, s0, Lr : numpy.ndarray
    """
    ks, kr = setup.ks, setup.kr
    nx = ks + kr + 1
    CS = conv_matrix(setup.Sf, ks + 1)          # S = CS @ [1; x[:ks]]
    CR = conv_matrix(setup.Rf, kr + 1)          # R = CR @ x[ks:nx]
    Ls = np.zeros((CS.shape[0], nx))
    Ls[:, :ks] = CS[:, 1:]
    Lr = np.zeros((CR.shape[0], nx))
    Lr[:, ks:] = CR
    return Ls, CS[:, 0], Lr


def _product(c, L, l0, n_out):
    """``conv(c, L x + l0)`` as ``(M, m0)`` padded (leading zeros) to length ``n_out``."""
    C = conv_matrix(c, L.shape[0])
    M, m0 = C @ L, C @ l0
    pad = n_out - M.shape[0]
    return np.vstack([np.zeros((pad, M.shape[1])), M]), np.concatenate([np.zeros(pad), m0])


@dataclass(frozen=True)
class Region:
    """The closed-loop pole region imposed in one program (scaled).

    Parameters
    ----------
    zeta : float, optional
        Damping floor of every closed-loop pole (a sampled model's mapped to s by
        ``fs ln z``; :mod:`robrst.synthesis._polerows`).
    sigma : float, optional
        Decay rate (scaled; sampled models: ``|z| < exp(-sigma w0 / fs)``,
        :mod:`robrst.synthesis.stability`).
    ctrl_zeta : float, optional
        Damping floor of the controller's own poles.
    """

    zeta: float = None
    sigma: float = None
    ctrl_zeta: float = None


def t_map(setup: NLPSetup, Lr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The feed-forward as an affine map of the controller vector.

    Parameters
    ----------
    setup : NLPSetup
        The program's data (its ``T_shape``).
    Lr : numpy.ndarray
        ``R = Lr x`` (:func:`affine_controller`).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``(Lt, t0)`` with ``T = Lt x + t0`` (``T = R(0) T_shape``).
    """
    shape = np.ones(1) if setup.T_shape is None else np.asarray(setup.T_shape, float)
    return np.outer(shape, Lr[-1]), np.zeros(len(shape))


def closed_loop_maps(setup: NLPSetup) -> Callable:
    """``closed_loop(a, b) -> ((Dm, Dc), {key: (Nm, Nc)})`` affine maps of ``xc``.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.

    Returns
    -------
    callable
        ``closed_loop(a, b)`` for a scaled plant: ``Delta = Dm xc + Dc`` and the
        numerators of ``"S"``, ``"T"``, ``"U"``, ``"Tband"``, ``"Uhf"``, ``"Sd"`` (``B S``)
        and ``"Ry"`` (``B T``) likewise.
    """
    Ls, s0, Lr = affine_controller(setup)
    Lt, t0 = t_map(setup, Lr)
    zero_r = np.zeros(Lr.shape[0])

    def closed_loop(a, b):
        n_out = max(len(a) + Ls.shape[0], len(b) + Lr.shape[0]) - 1
        AS = _product(a, Ls, s0, n_out)
        BR = _product(b, Lr, zero_r, n_out)
        AR = _product(a, Lr, zero_r, n_out)
        BS = _product(b, Ls, s0, n_out)
        BT = _product(b, Lt, t0, n_out)
        D = (AS[0] + BR[0], AS[1] + BR[1])
        return D, {"S": AS, "T": BR, "U": AR, "Tband": BR, "Uhf": AR, "Sd": BS, "Ry": BT}

    return closed_loop


def objective_rows(setup: NLPSetup) -> tuple[np.ndarray, np.ndarray, float]:
    """Rows ``(r0, q0, q0c)``: ``sign R(0) = r0 @ x``, ``(S/s^k)(0) = q0 @ x + q0c``.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.

    Returns
    -------
    r0, q0 : numpy.ndarray
    q0c : float
    """
    Ls, s0, Lr = affine_controller(setup)
    k = setup.integrators
    return setup.sign * Lr[-1], Ls[-1 - k], float(s0[-1 - k])


def controller_conditions(setup: NLPSetup, shift: float | None, stable: bool,
                          bounded: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """Hurwitz conditions on the controller's poles other than its integrators.

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    shift : float or None
        ``Q(p - shift)`` must be Hurwitz (``Re p <= -shift``).
    stable : bool
        ``Q`` itself must be Hurwitz (shift 0).
    bounded : bool
        ``Q(-p - ctrl_max)`` must be Hurwitz (``Re p >= -ctrl_max``).

    Returns
    -------
    (M, m) or None
        The stacked coefficients ``M x + m`` of the polynomials that must be Hurwitz
        (``Q = S/s^k``); ``None`` when nothing is asked or ``Q`` is a constant.
    """
    Ls, s0, _ = affine_controller(setup)
    k = setup.integrators
    Lq, q = Ls[:len(s0) - k], s0[:len(s0) - k]
    d = Lq.shape[0] - 1
    mats = []
    if shift is not None or stable:
        mats.append(shift_matrix(d, shift or 0.0))
    if bounded and setup.ctrl_max is not None:
        flip = np.diag((-1.0) ** np.arange(d, -1, -1))
        mats.append(shift_matrix(d, -setup.ctrl_max) @ flip)
    if d < 1 or not mats:
        return None
    M = np.vstack([T @ Lq for T in mats])
    return M, np.concatenate([T @ q for T in mats])


@dataclass(frozen=True, eq=False)
class GridBlock:
    """One peak constraint of one model on its frequency grid, in numeric matrices.

    Every closed-loop polynomial is affine in the controller coefficients ``xc``, so
    on the grid ``N(j nu) = (Nr + j Ni) xc + (nr + j ni)`` and likewise ``Delta``.
    The constraint at grid point ``i`` is
    ``(|N_i|^2 - (g M)^2 |Delta_i|^2) / w_i <= 0`` with the fixed weight
    ``w_i = |Delta(x_ref)(j nu_i)|^2``; ``g`` is 1 or, for a soft (scaled) block, the
    variable ``gamma``.

    Parameters
    ----------
    key : {"S", "T", "U", "Tband", "Uhf"}
        The constraint.
    model : int
        Index into ``setup.models``.
    label : str
        The model's label.
    temperature_C : float
        Its temperature [°C].
    nu : numpy.ndarray
        Scaled frequencies.
    N : tuple
        ``(Nr, nr, Ni, ni)``.
    D : tuple
        ``(Dr, dr, Di, di)``.
    w : numpy.ndarray
        The weights.
    bound : float
        ``M``.
    maps : tuple, optional
        ``(Nm, Nc, Dm, Dc)``: ``N = Nm x + Nc``, ``Delta = Dm x + Dc``.
    D_ref : numpy.ndarray, optional
        ``Delta`` at ``x_ref``.
    """

    key: str               # "S", "T", "U", "Tband" or "Uhf"
    model: int             # index into setup.models
    label: str
    temperature_C: float
    nu: np.ndarray         # scaled frequencies
    N: tuple               # (Nr, nr, Ni, ni)
    D: tuple               # (Dr, dr, Di, di)
    w: np.ndarray
    bound: float
    maps: tuple = None     # (Nm, Nc, Dm, Dc): N = Nm x + Nc, Delta = Dm x + Dc
    D_ref: np.ndarray = None

    def polys(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and closed-loop polynomial (scaled) at the decision vector ``x``.

        Parameters
        ----------
        x : numpy.ndarray
            The decision vector.

        Returns
        -------
        N, Delta : numpy.ndarray
        """
        Nm, Nc, Dm, Dc = self.maps
        xc = np.asarray(x, float)[:Nm.shape[1]]
        return Nm @ xc + Nc, Dm @ xc + Dc

    def with_points(self, nu_new: ArrayLike) -> GridBlock:
        """This block with the frequencies ``nu_new`` added (sorted, duplicates dropped).

        Parameters
        ----------
        nu_new : array_like
            Scaled frequencies.

        Returns
        -------
        GridBlock
        """
        nu = np.unique(np.concatenate([self.nu, np.asarray(nu_new, float)]))
        return _block(self.key, self.model, self.label, self.temperature_C, nu, self.maps,
                      self.D_ref, self.bound)

    def ratio(self, x: np.ndarray) -> np.ndarray:
        """``|N| / (M |Delta|)`` at every grid point for the decision vector ``x``.

        Parameters
        ----------
        x : numpy.ndarray
            The decision vector.

        Returns
        -------
        numpy.ndarray
        """
        xc = np.asarray(x, float)[:self.N[0].shape[1]]
        Nr, nr, Ni, ni = self.N
        Dr, dr, Di, di = self.D
        num = np.hypot(Nr @ xc + nr, Ni @ xc + ni)
        den = np.hypot(Dr @ xc + dr, Di @ xc + di)
        return num / (self.bound * np.maximum(den, 1e-300))


def grid_blocks(setup: NLPSetup, x_ref: np.ndarray,
                min_ms_unbounded: bool = True) -> tuple[GridBlock, ...]:
    """Every grid constraint of ``setup`` as :class:`GridBlock` (weights at ``x_ref``).

    Parameters
    ----------
    setup : NLPSetup
        The program's data.
    x_ref : numpy.ndarray
        The decision vector whose ``|Delta|^2`` weights the constraints.
    min_ms_unbounded : bool
        The ``|S|`` block of ``min_Ms`` without an ``Ms_max`` gets the bound 1 (its scale
        is ``gamma`` itself).

    Returns
    -------
    tuple of GridBlock
    """
    nx = setup.n_x
    x_ref = np.asarray(x_ref, float)[:nx]
    closed_loop = closed_loop_maps(setup)
    blocks = []
    for j, (label, T, a, b) in enumerate(setup.models):
        (Dm, Dc), nums = closed_loop(a, b)
        D_ref = Dm @ x_ref + Dc
        rows = {}       # per grid: the closed-loop rows and weights, the same for every key
        for key in PEAK_KEYS:
            nu = {"Tband": setup.bands[j] if setup.bands else (),
                  "Uhf": setup.hf[j] if setup.hf else ()}.get(
                key, setup.grids[j] if setup.grids else setup.nu)
            bound = setup.bound(key, j)
            if key == "S" and bound is None and setup.objective == "min_Ms" and min_ms_unbounded:
                bound = 1.0
            if bound is None or len(nu) == 0:
                continue
            nu = np.asarray(nu, float)
            if id(nu) not in rows:
                rows[id(nu)] = _grid_rows(nu, Dm, Dc, D_ref)
            blocks.append(_block(key, j, label, T, nu, (*nums[key], Dm, Dc), D_ref,
                                 float(bound), rows[id(nu)]))
    return tuple(blocks)


def _grid_rows(nu, Dm, Dc, D_ref):
    """What the blocks of one model and grid share: the powers of ``j nu``, the
    closed-loop rows and the weights ``|Delta_ref|^2``."""
    Vr, Vi = jw_matrices(nu, Dm.shape[0] - 1)
    return ((Vr, Vi), (Vr @ Dm, Vr @ Dc, Vi @ Dm, Vi @ Dc),
            np.maximum(np.abs(np.polyval(D_ref, 1j * nu)) ** 2, 1e-300))


def _block(key, model, label, T, nu, maps, D_ref, bound, rows=None):
    Nm, Nc, Dm, Dc = maps
    (Vr, Vi), D, w = _grid_rows(nu, Dm, Dc, D_ref) if rows is None else rows
    return GridBlock(key=key, model=model, label=label, temperature_C=T, nu=nu,
                     N=(Vr @ Nm, Vr @ Nc, Vi @ Nm, Vi @ Nc), D=D, w=w, bound=bound, maps=maps,
                     D_ref=D_ref)


def scale_plant(plant: Plant, scaling: poly.Scaling) -> tuple[np.ndarray, np.ndarray]:
    """Scaled ``(a, b)``: ``A(w0 p) / w0**n`` (monic) and ``B(w0 p) / w0**n``.

    Parameters
    ----------
    plant : Plant
        The model.
    scaling : Scaling
        The frequency scaling.

    Returns
    -------
    a, b : numpy.ndarray
    """
    n = plant.n
    return scaling.normalize(plant.A, n), scaling.normalize(plant.B, n)


def local_maxima(r: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of ``r`` (end points included, plateaus once).

    Parameters
    ----------
    r : numpy.ndarray
        Values on a grid.

    Returns
    -------
    numpy.ndarray
        Integer indices.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.synthesis._nlp import local_maxima
    >>> local_maxima(np.array([3.0, 1.0, 2.0, 2.0, 0.0])).tolist()
    [0, 2]
    """
    r = np.asarray(r, float)
    if r.size <= 2:
        return np.arange(r.size)
    left = np.r_[True, r[1:] > r[:-1]]
    right = np.r_[r[:-1] >= r[1:], True]
    return np.flatnonzero(left & right)
