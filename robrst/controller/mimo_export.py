"""The multi-axis digital controller: one section set per axis and the decoupler (JSON, C, Python).

Each axis's law ``S_i v_i = T_i r_i - R_i y_i`` runs as the delta-form Tustin sections of
:func:`robrst.controller.digital.digital_controller` (its own states, its own scaling); the
decoupler maps the axis commands to the actuator voltages: ``u = W v`` (static) or the
Tustin image of ``W(s)`` (dynamic, a discrete state space).  Then every ``u_j`` is
clamped to the amplifier range.  With a static decoupler the saturation is fed back to
each axis's anti-windup gain through ``dv = W^+ (u_sat - u)`` (the least-squares axis
increment); a dynamic decoupler's own state has none (keep its loop inside the range).

One step, per sample (``r, y`` in µm, ``u`` in V)::

    v_i = sections_i(r_i, y_i)            every axis, inner to outer section
    u   = W v          (or x_w' = A_w x_w + B_w v,  u = C_w x_w + D_w v)
    u_s = clamp(u, u_min, u_max);  dv = W^+ (u_s - u)
    every section state incremented (delta form), with L_i dv_i

:func:`export_mimo` builds it from a design, :func:`mimo_c_files` and
:func:`mimo_python_module` write it, :meth:`MimoExported.stepper` runs it in numpy (the
twin's closed loop).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robrst import __version__
from robrst.base.errors import SpecError
from robrst.controller.c_code import check_prefix
from robrst.controller.digital import digital_controller
from robrst.controller.export import MAX_LISTED, check_u_range

if TYPE_CHECKING:
    from collections.abc import Callable

    from robrst.certificate.mimo import MimoCertificate
    from robrst.core.mimo_loop import MimoController
    from robrst.design.mimo import MimoDesignResult

__all__ = ["MimoExported", "export_mimo", "mimo_c_files", "mimo_python_module"]


@dataclass(frozen=True, eq=False)
class MimoExported:
    """A multi-axis digital controller ready for a target.

    Parameters
    ----------
    problem : str
    names : tuple of str
        The axes.
    axes : tuple of DigitalController
        One per axis (inputs ``r_i, y_i``, output ``v_i``).
    W : numpy.ndarray or None
        The static decoupler.
    Wd : tuple or None
        The dynamic decoupler's Tustin image ``(A, B, C, D)`` (``x+ = A x + B v``).
    sample_rate_hz : float
    delay_samples : int
    u_range : (float, float)
    certificate : MimoCertificate or None
        The design's multi-axis certificate (``None``: another controller of the problem,
        a comparison design, which its own certificate covers).

    Attributes
    ----------
    certified : bool or None
        The certificate's verdict (``None`` without one).
    """

    problem: str
    names: tuple
    axes: tuple
    W: np.ndarray | None
    Wd: tuple | None
    sample_rate_hz: float
    delay_samples: int
    u_range: tuple[float, float]
    certificate: MimoCertificate | None

    @property
    def certified(self) -> bool | None:
        return None if self.certificate is None else bool(self.certificate.certified)

    def certificate_summary(self) -> dict:
        """The ``certificate`` object of the JSON.

        Returns
        -------
        dict
            ``certified``, ``ratios``, ``worst_sigma_S_sampled`` and ``violations`` (at most
            20 described); without a certificate ``certified = None`` and a ``note``.
        """
        c = self.certificate
        if c is None:
            return {"certified": None, "note": "not the design's answer; see its own certificate"}
        return {"certified": c.certified, "ratios": c.ratios(),
                "worst_sigma_S_sampled": c.worst("sigma_S", "sampled"),
                "violations": [v.describe() for v in c.violations[:MAX_LISTED]]}

    @property
    def n_inputs(self) -> int:
        return self.W.shape[0] if self.W is not None else self.Wd[3].shape[0]

    def aw_matrix(self) -> np.ndarray:
        """``W^+`` (axes x inputs) of a static decoupler; zeros for a dynamic one.

        Returns
        -------
        numpy.ndarray
        """
        if self.W is None:
            return np.zeros((len(self.axes), self.n_inputs))
        return np.linalg.pinv(self.W)

    def stepper(self) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """A step ``f(r, y) -> u`` (numpy, float64) with the states inside, at rest.

        Each axis runs its sections' assembled realisation
        (:meth:`robrst.controller.digital.DigitalController.state_space`), the same law.

        Returns
        -------
        callable
        """
        ss = [dc.state_space() for dc in self.axes]
        xs = [np.zeros(s[0].shape[0]) for s in ss]
        lo, hi = self.u_range
        P = self.aw_matrix()
        xw = None if self.Wd is None else np.zeros(self.Wd[0].shape[0])

        def step(r, y):
            nonlocal xw
            v = np.empty(len(ss))
            for i, ((A, B, C, D, L), x) in enumerate(zip(ss, xs)):
                v[i] = (C @ x)[0] + D[0, 0] * r[i] + D[0, 1] * y[i]
            if self.Wd is None:
                u = self.W @ v
            else:
                Aw, Bw, Cw, Dw = self.Wd
                u = Cw @ xw + Dw @ v
                xw = Aw @ xw + Bw @ v
            us = np.clip(u, lo, hi)
            dv = P @ (us - u)
            for i, ((A, B, C, D, L), x) in enumerate(zip(ss, xs)):
                xs[i] = A @ x + B[:, 0] * r[i] + B[:, 1] * y[i] + L * dv[i]
            return us

        return step

    def as_dict(self) -> dict:
        """The JSON of the multi-axis export.

        Returns
        -------
        dict
            ``kind = "mimo"``, the rate, delay, range, one section set per axis (as the
            single-loop export writes them), the decoupler, its anti-windup map and the
            certificate's summary.
        """
        dec = ({"kind": "static", "W": self.W.tolist(), "aw_pinv": self.aw_matrix().tolist()}
               if self.W is not None else
               {"kind": "dynamic_tustin", **{k: np.asarray(x).tolist()
                                             for k, x in zip("ABCD", self.Wd)}})
        return {"kind": "mimo", "problem": self.problem, "robrst_version": __version__,
                "sample_rate_hz": self.sample_rate_hz, "delay_samples": self.delay_samples,
                "discretisation": "tustin", "u_min": self.u_range[0],
                "u_max": self.u_range[1],
                "axes": [{"name": nm, "R_z": dc.R_z.tolist(), "S_z": dc.S_z.tolist(),
                          "T_z": dc.T_z.tolist(), "sections": [s.as_dict() for s in dc.sections],
                          "feedthrough": dc.D.tolist(), "n_states": dc.n_states,
                          "controller_s": dc.ctrl.as_dict()}
                         for nm, dc in zip(self.names, self.axes)],
                "decoupler": dec, "certificate": self.certificate_summary()}


def _tustin(A, B, C, D, fs):
    """The Tustin image of a continuous state space (physical time)."""
    n = A.shape[0]
    if not n:
        return A, B, C, D
    h = 1.0 / fs
    M = np.eye(n) - 0.5 * h * A
    Ad = np.linalg.solve(M, np.eye(n) + 0.5 * h * A)
    Bd = np.linalg.solve(M, h * B)
    Cd = np.linalg.solve(M.T, C.T).T
    Dd = D + 0.5 * C @ Bd
    return Ad, Bd, Cd, Dd


def export_mimo(result: MimoDesignResult, controller: MimoController | None = None,
                u_range: tuple[float, float] | None = None) -> MimoExported:
    """The multi-axis digital controller of a design (its sampling rate and delay).

    Parameters
    ----------
    result : MimoDesignResult
        The design (its problem names the rate; its certificate is summarised).
    controller : MimoController, optional
        Another controller of the same problem (a comparison design); its certificate is
        then not the result's and the summary says ``certified: null``.
    u_range : (float, float), optional
        The amplifier range [V] (default ``(-inf, inf)``: a bipolar amplifier, no
        saturation; the single-loop default, the paper's 0-150 V, is not a mirror's).

    Returns
    -------
    MimoExported

    Raises
    ------
    SpecError
        A problem without ``sample_rate_hz``.
    """
    specs = result.problem.specs
    if not specs.sampled:
        raise SpecError(f"{result.problem.name}: the export needs [mimo.specs] sample_rate_hz"
                        " (the rate the controller runs at, certified)")
    fs = specs.sample_rate_hz
    ctrl = controller or result.controller
    axes = tuple(digital_controller(c, fs) for c in ctrl.axes)
    W = Wd = None
    if ctrl.dynamic:
        Wd = _tustin(*ctrl.decoupler_ss, fs)
    else:
        W = ctrl.decoupler
    return MimoExported(result.problem.name, tuple(ctrl.names), axes, W, Wd, fs,
                        specs.delay_samples,
                        check_u_range((-np.inf, np.inf) if u_range is None else u_range),
                        result.certificate if controller is None else None)


def _lit(v):
    v = float(v)
    if math.isinf(v):
        return "(HUGE_VAL)" if v > 0 else "(-HUGE_VAL)"
    return repr(v)


def mimo_c_files(exp: MimoExported, name: str = "robrst_mimo",
                 prefix: str = "robrst_mimo") -> tuple[str, str]:
    """C99 header and source of a multi-axis controller (no allocation, ``<math.h>`` only).

    Parameters
    ----------
    exp : MimoExported
    name : str
        File stem (the source includes ``"<name>.h"``).
    prefix : str
        Prefix of the C names.

    Returns
    -------
    header, source : str

    Raises
    ------
    SpecError
        A prefix that is not a C identifier.
    """
    check_prefix(prefix)
    P = prefix.upper()
    m, k = len(exp.axes), exp.n_inputs
    nst = [dc.n_states for dc in exp.axes]
    nw = 0 if exp.Wd is None else exp.Wd[0].shape[0]
    lo, hi = exp.u_range
    head = f"""/* {name}.h: multi-axis digital RST controller of problem "{exp.problem}" (generated by robrst).
 *
 * {m} axes ({", ".join(exp.names)}), one RST law each (delta-form Tustin sections), then the
 * {"static decoupler u = W v" if exp.W is not None else "dynamic decoupler (Tustin state space)"};
 * u clamped to [{P}_U_MIN, {P}_U_MAX]{" with anti-windup dv = W^+ (u_sat - u)" if exp.W is not None else ""}.
 * Tustin at {exp.sample_rate_hz:g} Hz; the certificate assumes {exp.delay_samples} sample(s) of
 * computation delay.  Certified: {exp.certified}.
 * Units: r, y in um; u in V.
 */
#ifndef {P}_H
#define {P}_H

#ifndef {P}_REAL
#define {P}_REAL double
#endif
#ifndef {P}_U_MIN
#define {P}_U_MIN {_lit(lo)}
#endif
#ifndef {P}_U_MAX
#define {P}_U_MAX {_lit(hi)}
#endif
#define {P}_N_AXES {m}
#define {P}_N_INPUTS {k}
#define {P}_SAMPLE_RATE_HZ {exp.sample_rate_hz!r}

typedef {P}_REAL {prefix}_real;

typedef struct {{
    {prefix}_real x[{max(sum(nst), 1)}];   /* every axis's section states */
    {prefix}_real xw[{max(nw, 1)}];  /* the dynamic decoupler's states */
}} {prefix}_state;

void {prefix}_init({prefix}_state *s);

/* One sample: references r[{m}] and measurements y[{m}] in, saturated commands u[{k}] out. */
void {prefix}_step({prefix}_state *s, const {prefix}_real *r, const {prefix}_real *y,
                   {prefix}_real *u);

#endif /* {P}_H */
"""
    R = lambda v: f"(({prefix}_real){_lit(v)})"   # noqa: E731
    L = [f"/* {name}.c: see {name}.h (generated by robrst). */", "#include <math.h>",
         f'#include "{name}.h"', "",
         f"void {prefix}_init({prefix}_state *s)", "{", "    int i;",
         f"    for (i = 0; i < {max(sum(nst), 1)}; ++i) s->x[i] = ({prefix}_real)0;",
         f"    for (i = 0; i < {max(nw, 1)}; ++i) s->xw[i] = ({prefix}_real)0;", "}", "",
         f"void {prefix}_step({prefix}_state *s, const {prefix}_real *r, const {prefix}_real *y,",
         f"                   {prefix}_real *u)", "{",
         f"    {prefix}_real *x = s->x;",
         f"    const {prefix}_real lo = ({prefix}_real)({P}_U_MIN), hi = ({prefix}_real)({P}_U_MAX);",
         f"    {prefix}_real v[{m}], du[{k}], dv[{m}], w;", "    int j;", "    (void)x;"]
    base = 0
    secw = []
    for a, dc in enumerate(exp.axes):
        L.append(f"    /* axis {a + 1} ({exp.names[a]}): {len(dc.sections)} section(s) */")
        L.append(f"    w = ({prefix}_real)0;")
        i = base
        outs = []
        for q, s in enumerate(dc.sections):
            ix = list(range(i, i + s.order))
            H = s.H.ravel()
            L.append(f"    {prefix}_real w{a}_{q} = " + " + ".join(
                f"{R(h)} * x[{j}]" for h, j in zip(H, ix)) + f" + {R(s.J[0])} * w"
                f" + {R(s.J[1])} * r[{a}] + {R(s.J[2])} * y[{a}];")
            outs.append((f"w{a}_{q}", "w", ix, s))
            L.append(f"    {prefix}_real p{a}_{q} = w;  w = w{a}_{q};")
            i += s.order
        L.append(f"    v[{a}] = w + {R(dc.D[0])} * r[{a}] + {R(dc.D[1])} * y[{a}];")
        secw.append((a, base, dc))
        base = i
    if exp.W is not None:
        for j in range(k):
            L.append(f"    u[{j}] = " + " + ".join(f"{R(exp.W[j, a])} * v[{a}]"
                                                  for a in range(m)) + ";")
    else:
        Aw, Bw, Cw, Dw = exp.Wd
        for j in range(k):
            terms = [f"{R(Cw[j, q])} * s->xw[{q}]" for q in range(nw)] + \
                [f"{R(Dw[j, a])} * v[{a}]" for a in range(m)]
            L.append(f"    u[{j}] = " + " + ".join(terms) + ";")
        L.append("    {")
        L.append(f"        {prefix}_real xn[{max(nw, 1)}];")
        for q in range(nw):
            terms = [f"{R(Aw[q, c])} * s->xw[{c}]" for c in range(nw)] + \
                [f"{R(Bw[q, a])} * v[{a}]" for a in range(m)]
            L.append(f"        xn[{q}] = " + " + ".join(terms) + ";")
        L.append(f"        for (j = 0; j < {nw}; ++j) s->xw[j] = xn[j];")
        L.append("    }")
    L.append(f"    for (j = 0; j < {k}; ++j) {{")
    L.append(f"        const {prefix}_real us = u[j] < lo ? lo : (u[j] > hi ? hi : u[j]);")
    L.append("        du[j] = us - u[j];  u[j] = us;")
    L.append("    }")
    Pw = exp.aw_matrix()
    for a in range(m):
        L.append(f"    dv[{a}] = " + " + ".join(f"{R(Pw[a, j])} * du[{j}]" for j in range(k))
                 + ";")
    for a, b0, dc in secw:
        i = b0
        for q, s in enumerate(dc.sections):
            ix = list(range(i, i + s.order))
            L.append("    {")
            for rr in range(s.order):
                terms = " + ".join(f"{R(s.F[rr, c])} * x[{xc}]" for c, xc in enumerate(ix))
                L.append(f"        const {prefix}_real d{rr} = {terms} + {R(s.G[rr, 0])} *"
                         f" p{a}_{q} + {R(s.G[rr, 1])} * r[{a}] + {R(s.G[rr, 2])} * y[{a}]"
                         f" + {R(s.L[rr])} * dv[{a}];")
            for rr, xi in enumerate(ix):
                L.append(f"        x[{xi}] = x[{xi}] + d{rr};")
            L.append("    }")
            i += s.order
    L += ["}", ""]
    return head, "\n".join(L)


_PY = '''"""Multi-axis digital RST controller of problem {problem!r} (generated by robrst {version}).

{m} axes ({names}), delta-form Tustin sections per axis at {fs!r} Hz, then the decoupler;
u clamped to [U_MIN, U_MAX].  Certified: {certified}.

    ctrl = Controller()
    u = ctrl.step(r, y)        # lists of {m} references and measurements [um] -> {k} commands [V]
"""

SAMPLE_RATE_HZ = {fs!r}
DELAY_SAMPLES = {delay!r}
U_MIN, U_MAX = {lo}, {hi}
AXES = {axes!r}
W = {W!r}
W_PINV = {P!r}
WD = {Wd!r}


class Controller:
    """The states and the step (plain Python floats)."""

    def __init__(self, u_min=U_MIN, u_max=U_MAX):
        self.u_min, self.u_max = float(u_min), float(u_max)
        self.reset()

    def reset(self):
        self.x = [[[0.0] * len(sec["H"]) for sec in ax["sections"]] for ax in AXES]
        self.xw = [0.0] * (len(WD["A"]) if WD else 0)

    def step(self, r, y):
        v, inputs = [], []
        for ax, xa, ri, yi in zip(AXES, self.x, r, y):
            w, vin = 0.0, []
            for sec, x in zip(ax["sections"], xa):
                vin.append((w, float(ri), float(yi)))
                wk = sum(h * xi for h, xi in zip(sec["H"], x))
                J = sec["J"]
                w = wk + J[0] * w + J[1] * ri + J[2] * yi
            inputs.append(vin)
            v.append(w + ax["D"][0] * ri + ax["D"][1] * yi)
        if WD:
            u = [sum(c * x for c, x in zip(row, self.xw)) + sum(d * vi for d, vi in zip(drow, v))
                 for row, drow in zip(WD["C"], WD["D"])]
            self.xw = [sum(a * x for a, x in zip(row, self.xw)) + sum(b * vi for b, vi in
                                                                      zip(brow, v))
                       for row, brow in zip(WD["A"], WD["B"])]
        else:
            u = [sum(wj * vi for wj, vi in zip(row, v)) for row in W]
        us = [min(max(x, self.u_min), self.u_max) for x in u]
        du = [a - b for a, b in zip(us, u)]
        dv = [sum(p * d for p, d in zip(row, du)) for row in W_PINV]
        for ax, xa, vin, dva in zip(AXES, self.x, inputs, dv):
            for sec, x, vv in zip(ax["sections"], xa, vin):
                inc = [sum(f * xj for f, xj in zip(sec["F"][i], x)) + sec["G"][i][0] * vv[0]
                       + sec["G"][i][1] * vv[1] + sec["G"][i][2] * vv[2] + sec["L"][i] * dva
                       for i in range(len(x))]
                for i in range(len(x)):
                    x[i] = x[i] + inc[i]
        return us
'''


def mimo_python_module(exp: MimoExported) -> str:
    """A standalone Python module of a multi-axis controller (no dependency).

    Parameters
    ----------
    exp : MimoExported

    Returns
    -------
    str
    """
    axes = [{"name": nm, "D": dc.D.tolist(),
             "sections": [{"F": s.F.tolist(), "G": s.G.tolist(), "H": s.H.ravel().tolist(),
                           "J": s.J.tolist(), "L": s.L.tolist()} for s in dc.sections]}
            for nm, dc in zip(exp.names, exp.axes)]
    Wd = None if exp.Wd is None else {k: np.asarray(x).tolist() for k, x in zip("ABCD", exp.Wd)}
    lo, hi = exp.u_range

    def lit(v):
        v = float(v)
        return repr(v) if math.isfinite(v) else f'float("{v}")'
    return _PY.format(problem=exp.problem, version=__version__, m=len(exp.axes),
                      k=exp.n_inputs, names=", ".join(exp.names), fs=exp.sample_rate_hz,
                      certified=exp.certified, delay=exp.delay_samples,
                      lo=lit(lo), hi=lit(hi), axes=axes,
                      W=None if exp.W is None else exp.W.tolist(),
                      P=exp.aw_matrix().tolist(), Wd=Wd)
