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

__all__ = ["NLPSetup", "build_and_solve", "conv_matrix", "jw_matrices", "routh_column"]


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


def _am_symbolic(setup, wn, zeta, degree):
    dom = ca.vertcat(1, 2 * zeta * wn, wn ** 2)
    for r in setup.n_dom_real:
        dom = _conv(dom, ca.vertcat(1, -r))
    aux = ca.DM([1.0])
    for _ in range(degree - 2 - len(setup.n_dom_real)):
        aux = _conv(aux, ca.vertcat(1, setup.aux_factor * wn))
    return _conv(dom, aux)


def _conv(a, b):
    a, b = ca.vertcat(a), ca.vertcat(b)
    n, m = a.numel(), b.numel()
    terms = [0] * (n + m - 1)
    for i in range(n):
        for j in range(m):
            terms[i + j] = terms[i + j] + a[i] * b[j]
    return ca.vertcat(*terms)


def build_and_solve(setup, x0, ipopt_opts):
    """Build the NLP for ``setup``, solve from ``x0``; return (x, stats, labels, g, lbg, ubg)."""
    ks, kr = setup.ks, setup.kr
    nx = ks + kr + 1
    free_poles = setup.Am_fixed is None
    X = ca.SX.sym("x", nx + (2 if free_poles else 0) + (1 if setup.objective == "min_Ms" else 0))
    sp = ca.vertcat(1, X[:ks])                 # S' monic
    rp = X[ks:nx]
    S = ca.mtimes(ca.DM(conv_matrix(setup.Sf, ks + 1)), sp)
    R = ca.mtimes(ca.DM(conv_matrix(setup.Rf, kr + 1)), rp)
    g, lbg, ubg, labels = [], [], [], []

    def add(expr, lo, hi, label):
        g.append(expr)
        n = expr.numel()
        lbg.extend([lo] * n)
        ubg.extend([hi] * n)
        labels.extend(label(i) for i in range(n))

    # Diophantine equality at the nominal model
    _, _, a0, b0 = setup.models[setup.ref]
    Delta0 = _padd(ca.mtimes(ca.DM(conv_matrix(a0, S.numel())), S),
                   ca.mtimes(ca.DM(conv_matrix(b0, R.numel())), R))
    deg = Delta0.numel() - 1
    if free_poles:
        wn, zeta = X[nx], X[nx + 1]
        Am = _am_symbolic(setup, wn, zeta, deg)
    else:
        Am = ca.DM(setup.Am_fixed)
    add(Delta0[1:] - Am[1:], 0.0, 0.0, lambda i: ("diophantine", None, None, i))
    gamma = X[-1] if setup.objective == "min_Ms" else None

    x0 = np.asarray(x0, float)
    for mi, (label, T, a, b) in enumerate(setup.models):
        AS = ca.mtimes(ca.DM(conv_matrix(a, S.numel())), S)
        BR = ca.mtimes(ca.DM(conv_matrix(b, R.numel())), R)
        AR = ca.mtimes(ca.DM(conv_matrix(a, R.numel())), R)
        D = _padd(AS, BR)
        dD = D.numel() - 1
        # fixed weights |Delta(x0)(j nu)|^2 normalise each constraint
        fD = ca.Function("fD", [X], [D])
        D0 = np.array(fD(x0)).ravel()
        for key, N, nu in (("S", AS, setup.nu), ("T", BR, setup.nu), ("U", AR, setup.nu),
                           ("Tband", BR, setup.nu_band)):
            bound = setup.bounds.get(key)
            if (bound is None and not (key == "S" and gamma is not None)) or len(nu) == 0:
                continue
            Vr, Vi = jw_matrices(nu, dD)
            w = np.abs(np.polyval(D0, 1j * nu)) ** 2
            Npad = _pad_to(N, dD + 1)
            nr, ni = ca.mtimes(ca.DM(Vr), Npad), ca.mtimes(ca.DM(Vi), Npad)
            dr, di = ca.mtimes(ca.DM(Vr), D), ca.mtimes(ca.DM(Vi), D)
            M2 = gamma ** 2 if (key == "S" and gamma is not None) else bound ** 2
            expr = (nr ** 2 + ni ** 2 - M2 * (dr ** 2 + di ** 2)) / ca.DM(w)
            add(expr, -ca.inf, 0.0, lambda i, k=key, nu=nu, lab=label, t=T: (k, lab, t, float(nu[i])))
            if key == "S" and gamma is not None and bound is not None:
                add(gamma, -ca.inf, bound, lambda i: ("gamma", None, None, None))
        # stability: Routh first column > 0 (scaled: O(1) entries)
        add(routh_column(D / D[0]), 1e-9, ca.inf, lambda i, lab=label, t=T: ("routh", lab, t, i))
    if setup.stable_controller:
        Sq = sp if len(setup.Sf) == 2 else S[:-1]
        add(routh_column(Sq / Sq[0]), 1e-9, ca.inf, lambda i: ("controller_routh", None, None, i))
    # objective
    q0 = ca.mtimes(ca.DM(conv_matrix(setup.Sf[:-1], ks + 1)), sp)[-1]  # (S/s)(0)
    if setup.objective == "max_integral_gain":
        add(ca.vertcat(rp[-1], q0), 1e-12, ca.inf, lambda i: ("positivity", None, None, i))
        f = -(ca.log(R[-1]) - ca.log(q0))
    elif setup.objective == "min_Ms":
        f = gamma
    else:
        f = ca.SX(0.0)
    lbx = -np.inf * np.ones(X.numel())
    ubx = np.inf * np.ones(X.numel())
    if free_poles:
        (wl, wh), (zl, zh) = setup.pole_bounds
        lbx[nx:nx + 2] = [wl, zl]
        ubx[nx:nx + 2] = [wh, zh]
    nlp = {"x": X, "f": f, "g": ca.vertcat(*g)}
    opts = {"ipopt": dict(ipopt_opts), "print_time": False, "show_eval_warnings": False}
    solver = ca.nlpsol("rst", "ipopt", nlp, opts)
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    gval = np.array(sol["g"]).ravel()
    return np.array(sol["x"]).ravel(), stats, labels, gval, np.array(lbg), np.array(ubg)


def _padd(a, b):
    n = max(a.numel(), b.numel())
    return _pad_to(a, n) + _pad_to(b, n)


def _pad_to(a, n):
    k = a.numel()
    return a if k == n else ca.vertcat(ca.DM.zeros(n - k, 1), a)


def scale_plant(plant, w0):
    """Scaled ``(a, b)``: ``A(w0 p) / w0**n`` (monic) and ``B(w0 p) / w0**n``."""
    n = plant.n
    return (poly.to_scaled(plant.A, w0) / w0 ** n, poly.to_scaled(plant.B, w0) / w0 ** n)
