"""The robust RST nonlinear program in CasADi (solved by IPOPT).

Everything is posed in the scaled variable ``p = s / w0``.  Plant polynomials are
divided by ``w0**deg A`` and the controller by ``w0**deg S``, which keeps every
closed-loop ratio unchanged while bringing coefficients to O(1).  Decision
variables: the free coefficients of ``S'`` and ``R'`` (``S = Sf S'``, ``R = Rf R'``)
and optionally the dominant pole parameters ``(wn, zeta)``.  Every closed-loop
polynomial is *affine* in the controller coefficients, so on a frequency grid each
peak constraint ``|N(jw)|^2 <= M^2 |Delta(jw)|^2`` (denominators cleared, divided by
a fixed weight ``|Delta_0(jw)|^2``) is a quadratic in the variables.
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from robrst import poly
from robrst.synthesis.outcome import SolveResult

__all__ = ["GridBlock", "NLPSetup", "build_and_solve", "grid_blocks", "conv_matrix",
           "jw_matrices", "routh_column", "scale_plant"]


def conv_matrix(c, n):
    """Matrix ``M`` with ``M @ x == np.convolve(c, x)`` for ``len(x) == n``."""
    c = np.asarray(c, dtype=float)
    M = np.zeros((len(c) + n - 1, n))
    for j in range(n):
        M[j:j + len(c), j] = c
    return M


def jw_matrices(nu, deg):
    """Real and imaginary parts of ``[ (j nu)^deg, ..., 1 ]`` (highest power first)."""
    k = np.arange(deg, -1, -1)
    z = (1j * np.asarray(nu, float)[:, None]) ** k[None, :]
    return z.real, z.imag


def routh_column(c):
    """First column of the Routh array of a polynomial with symbolic coefficients.

    All entries > 0 (with ``c[0] > 0``) is the Hurwitz condition.
    """
    n = c.numel() - 1
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
    return ca.vertcat(*col)


@dataclass(frozen=True, eq=False)
class NLPSetup:
    """Numeric data of one NLP instance (all polynomials scaled)."""

    w0: float
    models: tuple          # ((label, T, a, b), ...) scaled plant polynomials
    ref: int               # index of the nominal model in ``models``
    Sf: np.ndarray         # scaled fixed factor of S (monic)
    Rf: np.ndarray         # scaled fixed factor of R
    ks: int                # degree of S'
    kr: int                # degree of R'
    nu: np.ndarray         # scaled frequency grid
    nu_band: np.ndarray    # scaled resonance-band grid (may be empty)
    bounds: dict           # {"S": Ms, "T": Mt, "U": Mu(scaled), "Tband": ...}
    objective: str
    Am_fixed: np.ndarray   # scaled monic Am, or None when the poles are free
    pole_bounds: tuple     # ((wn_lo, wn_hi), (z_lo, z_hi)) scaled, or None
    aux_factor: float
    n_dom_real: tuple      # extra dominant real poles (scaled), fixed
    stable_controller: bool
    bands: tuple = ()      # per model, its scaled resonance-band grid (default: nu_band)
    rates: tuple = ()      # (label, sample rate [Hz]) of the sampled-loop models


def _am_symbolic(setup, wn, zeta, degree):
    dom = [1, 2 * zeta * wn, wn ** 2]
    for r in setup.n_dom_real:
        dom = poly.conv_generic(dom, [1, -r])
    aux = [1.0]
    for _ in range(degree - 2 - len(setup.n_dom_real)):
        aux = poly.conv_generic(aux, [1, setup.aux_factor * wn])
    return ca.vertcat(*poly.conv_generic(dom, aux))


def _affine_controller(setup):
    """Numeric maps ``S = Ls x + s0`` and ``R = Lr x`` of the decision vector ``x``."""
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


def _routh_function(deg):
    c = ca.SX.sym("c", deg + 1)
    return ca.Function("routh", [c], [routh_column(c / c[0])])


@dataclass(frozen=True, eq=False)
class GridBlock:
    """One peak constraint of one model on its frequency grid, in numeric matrices.

    Every closed-loop polynomial is affine in the controller coefficients ``xc``, so
    on the grid ``N(j nu) = (Nr + j Ni) xc + (nr + j ni)`` and likewise ``Delta``.
    The constraint at grid point ``i`` is
    ``(|N_i|^2 - M^2 |Delta_i|^2) / w_i <= 0`` with the fixed weight
    ``w_i = |Delta(x_ref)(j nu_i)|^2``; ``bound`` is ``M`` (``None``: the variable
    ``gamma`` of the ``min_Ms`` objective).
    """

    key: str               # "S", "T", "U" or "Tband"
    model: int             # index into setup.models
    label: str
    temperature_C: float
    nu: np.ndarray         # scaled frequencies
    N: tuple               # (Nr, nr, Ni, ni)
    D: tuple               # (Dr, dr, Di, di)
    w: np.ndarray
    bound: object

    def ratio(self, x, gamma=None):
        """``|N| / (M |Delta|)`` at every grid point for the decision vector ``x``."""
        xc = np.asarray(x, float)[:self.N[0].shape[1]]
        Nr, nr, Ni, ni = self.N
        Dr, dr, Di, di = self.D
        num = np.hypot(Nr @ xc + nr, Ni @ xc + ni)
        den = np.hypot(Dr @ xc + dr, Di @ xc + di)
        M = gamma if self.bound is None else self.bound
        return num / (M * np.maximum(den, 1e-300))


def _closed_loop_maps(setup):
    """``closed_loop(a, b) -> ((Dm, Dc), {key: (Nm, Nc)})`` affine maps of ``xc``."""
    Ls, s0, Lr = _affine_controller(setup)
    zero_r = np.zeros(Lr.shape[0])

    def closed_loop(a, b):
        n_out = max(len(a) + Ls.shape[0], len(b) + Lr.shape[0]) - 1
        AS = _product(a, Ls, s0, n_out)
        BR = _product(b, Lr, zero_r, n_out)
        AR = _product(a, Lr, zero_r, n_out)
        D = (AS[0] + BR[0], AS[1] + BR[1])
        return D, {"S": AS, "T": BR, "U": AR, "Tband": BR}

    return closed_loop


def grid_blocks(setup, x_ref):
    """Every grid constraint of ``setup`` as :class:`GridBlock` (weights at ``x_ref``)."""
    nx = setup.ks + setup.kr + 1
    x_ref = np.asarray(x_ref, float)[:nx]
    closed_loop = _closed_loop_maps(setup)
    min_ms = setup.objective == "min_Ms"
    blocks = []
    for j, (label, T, a, b) in enumerate(setup.models):
        (Dm, Dc), nums = closed_loop(a, b)
        dD = Dm.shape[0] - 1
        D_ref = Dm @ x_ref + Dc
        for key in ("S", "T", "U", "Tband"):
            band = setup.bands[j] if setup.bands else setup.nu_band
            nu = band if key == "Tband" else setup.nu
            bound = setup.bounds.get(key)
            if key == "S" and min_ms:
                bound = None
            elif bound is None:
                continue
            if len(nu) == 0:
                continue
            Vr, Vi = jw_matrices(nu, dD)
            Nm, Nc = nums[key]
            blocks.append(GridBlock(
                key=key, model=j, label=label, temperature_C=T, nu=np.asarray(nu, float),
                N=(Vr @ Nm, Vr @ Nc, Vi @ Nm, Vi @ Nc), D=(Vr @ Dm, Vr @ Dc, Vi @ Dm, Vi @ Dc),
                w=np.abs(np.polyval(D_ref, 1j * nu)) ** 2, bound=bound))
    return tuple(blocks)


def build_and_solve(setup, x0, ipopt_opts, blocks=None, active=None):
    """Build the NLP for ``setup`` and solve it from ``x0``; return a :class:`SolveResult`.

    The grid constraints are assembled from numeric matrices (every closed-loop
    polynomial is affine in the controller coefficients), so the CasADi graph is a
    handful of matrix products whatever the number of models and frequencies:
    construction is cheap and derivatives are exact.

    Parameters
    ----------
    blocks : tuple of GridBlock, optional
        The grid constraints (default: :func:`grid_blocks` weighted at ``x0``).
    active : sequence of index arrays, optional
        Per block, the grid points to impose (default: all of them); the
        exchange method (:mod:`robrst.synthesis.exchange`) passes a subset.
    """
    ks, kr = setup.ks, setup.kr
    nx = ks + kr + 1
    free_poles = setup.Am_fixed is None
    n_var = nx + (2 if free_poles else 0) + (1 if setup.objective == "min_Ms" else 0)
    X = ca.MX.sym("x", n_var)
    xc = X[:nx]
    x0 = np.asarray(x0, float)
    if blocks is None:
        blocks = grid_blocks(setup, x0)
    Ls, s0, Lr = _affine_controller(setup)
    closed_loop = _closed_loop_maps(setup)
    g, lbg, ubg, labels = [], [], [], []

    def add(expr, lo, hi, label):
        g.append(expr)
        n = expr.numel()
        lbg.extend([lo] * n)
        ubg.extend([hi] * n)
        labels.extend(label(i) for i in range(n))

    # Diophantine equality at the nominal model
    _, _, a0, b0 = setup.models[setup.ref]
    (D0m, D0c), _ = closed_loop(a0, b0)
    deg = D0m.shape[0] - 1
    if free_poles:
        wz = ca.SX.sym("wz", 2)
        am_fn = ca.Function("Am", [wz], [_am_symbolic(setup, wz[0], wz[1], deg)])
        Am = am_fn(X[nx:nx + 2])
    else:
        Am = ca.DM(setup.Am_fixed)
    add(ca.mtimes(ca.DM(D0m[1:]), xc) + ca.DM(D0c[1:]) - Am[1:], 0.0, 0.0,
        lambda i: ("diophantine", None, None, i))
    gamma = X[-1] if setup.objective == "min_Ms" else None
    for k, blk in enumerate(blocks):
        idx = np.arange(len(blk.nu)) if active is None else np.asarray(active[k], int)
        if idx.size == 0:
            continue
        nr, dr, ni, di = (ca.mtimes(ca.DM(M[idx]), xc) + ca.DM(c[idx])
                          for M, c in (blk.N[:2], blk.D[:2], blk.N[2:], blk.D[2:]))
        M2 = gamma ** 2 if blk.bound is None else blk.bound ** 2
        expr = (nr ** 2 + ni ** 2 - M2 * (dr ** 2 + di ** 2)) / ca.DM(blk.w[idx])
        nu = blk.nu[idx]
        add(expr, -ca.inf, 0.0,
            lambda i, b=blk, nu=nu: (b.key, b.label, b.temperature_C, float(nu[i])))
    if gamma is not None and setup.bounds.get("S") is not None:
        add(gamma, -ca.inf, setup.bounds["S"], lambda i: ("gamma", None, None, None))
    # stability: Routh first column > 0 (scaled: O(1) entries)
    routh = {}
    for label, T, a, b in setup.models:
        (Dm, Dc), _ = closed_loop(a, b)
        dD = Dm.shape[0] - 1
        D = ca.mtimes(ca.DM(Dm), xc) + ca.DM(Dc)
        if dD not in routh:
            routh[dD] = _routh_function(dD)
        add(routh[dD](D), 1e-9, ca.inf, lambda i, lab=label, t=T: ("routh", lab, t, i))
    sp = ca.vertcat(1, X[:ks])                 # S' monic
    rp = X[ks:nx]
    if setup.stable_controller:
        Sq = sp if len(setup.Sf) == 2 else ca.mtimes(ca.DM(Ls), xc)[:-1] + ca.DM(s0[:-1])
        add(_routh_function(Sq.numel() - 1)(Sq), 1e-9, ca.inf,
            lambda i: ("controller_routh", None, None, i))
    # objective
    q0 = ca.mtimes(ca.DM(conv_matrix(setup.Sf[:-1], ks + 1)), sp)[-1]  # (S/s)(0)
    R_0 = ca.mtimes(ca.DM(Lr[-1:]), xc)
    if setup.objective == "max_integral_gain":
        add(ca.vertcat(rp[-1], q0), 1e-12, ca.inf, lambda i: ("positivity", None, None, i))
        f = -(ca.log(R_0) - ca.log(q0))
    elif setup.objective == "min_Ms":
        f = gamma
    else:
        f = ca.MX(0.0)
    lbx = -np.inf * np.ones(n_var)
    ubx = np.inf * np.ones(n_var)
    if free_poles:
        (wl, wh), (zl, zh) = setup.pole_bounds
        lbx[nx:nx + 2] = [wl, zl]
        ubx[nx:nx + 2] = [wh, zh]
    nlp = {"x": X, "f": f, "g": ca.vertcat(*g)}
    opts = {"ipopt": dict(ipopt_opts), "print_time": False, "show_eval_warnings": False}
    solver = ca.nlpsol("rst", "ipopt", nlp, opts)
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    return SolveResult(status=stats["return_status"], x=np.array(sol["x"]).ravel(),
                       objective=float(sol["f"]), iterations=int(stats.get("iter_count", 0)),
                       g=np.array(sol["g"]).ravel(), lbg=np.array(lbg, float),
                       ubg=np.array(ubg, float), lam_g=np.array(sol["lam_g"]).ravel(),
                       labels=tuple(labels), w0=setup.w0, rates=dict(setup.rates))


def scale_plant(plant, scaling):
    """Scaled ``(a, b)``: ``A(w0 p) / w0**n`` (monic) and ``B(w0 p) / w0**n``."""
    n = plant.n
    return scaling.normalize(plant.A, n), scaling.normalize(plant.B, n)
