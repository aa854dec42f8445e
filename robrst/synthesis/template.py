"""The robust RST program as one CasADi/IPOPT solver, built once per structure.

Everything that depends on the plants, the grid, the bounds and the phase enters as a
*parameter* (the numeric rows of :mod:`robrst.synthesis._nlp`), so one built solver
serves every certification round, every exchange round, both phases (soft goals and
hard specs) and every variant of a problem with the same degrees: only the
:class:`Structure` (degrees, how many constraint slots, which constraint families)
decides what is built.  Unused slots carry zero rows and infinite bounds.

Variables ``X = [xc, (wn, zeta), gamma]``.  Constraints, in order:

1. the Diophantine equality at the nominal model (placement ``fixed``/``dominant``);
2. ``slots`` peak constraints ``(|N|^2 - m2 (sg gamma^2 + 1 - sg) |Delta|^2) / W <= 0``
   with ``W = rho w + (1 - rho) |Delta|^2``: a fixed weight (``rho = 1``, quadratic
   constraints, right when the nominal closed loop is pinned) or the ratio itself
   (``rho = 0``, well scaled wherever the closed-loop poles go);
3. Routh first columns of every model's closed-loop polynomial, by degree group;
4. positivity of ``sign R(0)`` and ``(S/s^k)(0)`` (``max_integral_gain``);
5. Routh columns of the controller polynomials ``(S/s^k)(p - shift)`` and
   ``(S/s^k)(-p - ctrl_max)`` (optional: the controller's poles in a strip);
6. linear rows ``Lm xc + Lg gamma + Lc <= 0`` (optional: the reference-step samples of
   :mod:`robrst.synthesis._timesamples` and the roots near a damping floor of
   :mod:`robrst.synthesis._polerows`, linearised at the round's point).

Objective ``c_gamma gamma + c_ki (-log(sign R(0)) + log((S/s^k)(0))) + c_reg |xc - xref|^2``.

:class:`MappedTemplate` solves the same program over other coordinates (the nominal
closed-loop poles and Youla degrees of :class:`robrst.synthesis.search.PoleSpace`, the
coefficients a CasADi expression of them): ``RunOptions.pole_polish``.  With ``chained``
IPOPT gets its derivatives by the chain rule through the template's own (the program
differentiated once, in the coefficients; the map alone over the poles).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from robrst.base.interrupt import solver_call
from robrst.synthesis._stopping import StopWhenAsked
from robrst.core import poly
from robrst.synthesis._nlp import routh_column

__all__ = ["Structure", "Template", "MappedTemplate", "MappedTemplates", "TINY", "POLE_SCALING"]

TINY = 1e-20           # log clip: its second derivative (1e40) stays finite
POLE_SCALING = "gradient-based"   # IPOPT's scaling of the program over the poles (below)


@dataclass(frozen=True)
class Structure:
    """What a built solver depends on (its cache key).

    Parameters
    ----------
    nx : int
        Controller coefficients in the decision vector.
    placement : {"fixed", "dominant", "free"}
        The nominal pole placement.
    deg_eq : int
        Diophantine rows (``deg Am``), 0 for ``"free"``.
    n_dom_real : int
        Extra dominant real poles.
    groups : tuple
        ``((degree of Delta, capacity), ...)`` of the Routh rows.
    slots : int
        Grid-constraint slots (in steps of 1.5x).
    ctrl_deg : int
        Degree of the controller polynomial under Routh (-1: none).
    ipopt : tuple
        IPOPT options as sorted ``(key, value)`` pairs.
    lin : int
        Slots of linear rows (reference-step samples, roots near a damping floor).
    ctrl_count : int
        How many controller polynomials are under Routh.

    Attributes
    ----------
    n_var : int
        Variables of the program.
    """

    nx: int
    placement: str          # "fixed" | "dominant" | "free"
    deg_eq: int             # Diophantine rows (deg Am), 0 for "free"
    n_dom_real: int
    groups: tuple           # ((degree of Delta, capacity), ...)
    slots: int
    ctrl_deg: int           # degree of the controller polynomial under Routh, -1: none
    ipopt: tuple            # IPOPT options as sorted (key, value) pairs
    ctrl_count: int = 1     # how many controller polynomials are under Routh
    lin: int = 0            # slots of linear rows (reference-step samples)

    @property
    def n_var(self):
        return self.nx + (2 if self.placement == "dominant" else 0) + 1


def _options(st, n_x, n_g):
    """The solver's options (and its stop callback: a signal stops IPOPT at its next
    iteration, :mod:`robrst.base.interrupt`) for structure ``st``."""
    stop = StopWhenAsked(n_x, n_g)
    return stop, {"ipopt": dict(st.ipopt), "print_time": False, "show_eval_warnings": False,
                  "calc_lam_p": False,   # parameter multipliers: unused (and noisy on failure)
                  "iteration_callback": stop}


def _answer(solver, sol, x, lam_x):
    """A solve's outcome as :meth:`Template.solve` returns it (``x``, ``lam_x`` given)."""
    stats = solver.stats()
    return {"status": stats["return_status"], "x": x, "f": float(sol["f"]),
            "g": np.array(sol["g"]).ravel(), "lam_g": np.array(sol["lam_g"]).ravel(),
            "lam_x": lam_x, "iterations": int(stats.get("iter_count", 0))}


def _chained(solver, space, nx, T, rest, P, n_g):
    """The derivatives of the program over ``theta`` by the chain rule through the
    template's own (``solver``'s): with ``x = m(theta)`` and ``J`` the map's Jacobian
    (the identity on the other variables), the gradient ``J' grad f``, the constraints'
    Jacobian ``jac g J`` and the Lagrangian's Hessian ``J' H J + sum_k (grad L)_k hess m_k``.
    The same numbers as CasADi's derivatives through the composed graph, about 4x cheaper
    (the program's rows are differentiated once, in the coefficients, the small map alone
    over ``theta``)."""
    nr = int(rest.numel())
    xc = space.symbolic(T)
    Xb = ca.vertcat(xc, rest)
    J = ca.diagcat(ca.jacobian(xc, T), ca.MX.eye(nr))
    f, grad = solver.get_function("nlp_grad_f")(Xb, P)
    g, jac = solver.get_function("nlp_jac_g")(Xb, P)
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_g)
    hb = ca.triu2symm(solver.get_function("nlp_hess_l")(Xb, P, lam_f, lam_g))
    v = ca.MX.sym("v", nx)
    curvature = ca.Function("map_curvature", [T, v], [ca.hessian(ca.dot(v, xc), T)[0]])
    gl = lam_f * grad + ca.mtimes(jac.T, lam_g)
    H = ca.mtimes([J.T, hb, J]) + ca.diagcat(curvature(T, gl[:nx]), ca.MX(nr, nr))
    X = ca.vertcat(T, rest)
    return {"grad_f": ca.Function("grad_f", [X, P], [f, ca.mtimes(J.T, grad)],
                                  ["x", "p"], ["f", "grad_f_x"]),
            "jac_g": ca.Function("jac_g", [X, P], [g, ca.mtimes(jac, J)],
                                 ["x", "p"], ["g", "jac_g_x"]),
            "hess_lag": ca.Function("hess_lag", [X, P, lam_f, lam_g], [ca.triu(H)],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])}


class Template:
    """One CasADi NLP with parameters (see the module docstring).

    Parameters
    ----------
    structure : Structure
        What the program's shape depends on; the solver is built here, once.
    """

    def __init__(self, structure: Structure) -> None:
        st = self.structure = structure
        nx, K = st.nx, st.slots
        blocks = [(k, (K, nx)) for k in ("NR", "NI", "DR", "DI")]
        blocks += [(k, (K,)) for k in ("nr", "ni", "dr", "di", "w", "m2", "sg")]
        blocks += [("rho", (1,))]
        for i, (deg, cap) in enumerate(st.groups):
            blocks += [(f"Dm{i}", (cap * (deg + 1), nx)), (f"Dc{i}", (cap * (deg + 1),))]
        if st.placement != "free":
            blocks += [("D0m", (st.deg_eq, nx)), ("D0c", (st.deg_eq,))]
            blocks += [("Am", (st.deg_eq,))] if st.placement == "fixed" else \
                [("aux", (1,)), ("domr", (st.n_dom_real,))]
        blocks += [("r0", (nx,)), ("q0", (nx,)), ("q0c", (1,)), ("coef", (3,)), ("xref", (nx,))]
        if st.ctrl_deg >= 0:
            nc = st.ctrl_count * (st.ctrl_deg + 1)
            blocks += [("Cm", (nc, nx)), ("Cc", (nc,))]
        if st.lin:
            blocks += [("Lm", (st.lin, nx)), ("Lg", (st.lin,)), ("Lc", (st.lin,))]
        self.layout, off = {}, 0
        for name, shape in blocks:
            size = int(np.prod(shape))
            self.layout[name] = (off, shape)
            off += size
        self.n_p = off
        P = ca.MX.sym("p", off)
        X = ca.MX.sym("x", st.n_var)
        xc, gamma = X[:nx], X[-1]

        def par(name):
            o, shape = self.layout[name]
            v = P[o:o + int(np.prod(shape))]
            return ca.reshape(v, *shape) if len(shape) == 2 else v

        g = []
        if st.placement != "free":
            if st.placement == "fixed":
                Am = par("Am")
            else:
                Am = self._am(X[nx], X[nx + 1], par("aux"), par("domr"), st.deg_eq)
            g.append(ca.mtimes(par("D0m"), xc) + par("D0c") - Am)
        lin = {k: ca.mtimes(par(k.upper()), xc) + par(k) for k in ("nr", "ni", "dr", "di")}
        scale = par("m2") * (par("sg") * gamma ** 2 + 1 - par("sg"))
        d2 = lin["dr"] ** 2 + lin["di"] ** 2
        rho = par("rho")
        g.append((lin["nr"] ** 2 + lin["ni"] ** 2 - scale * d2) / (rho * par("w") + (1 - rho) * d2))
        for i, (deg, cap) in enumerate(st.groups):
            D = ca.mtimes(par(f"Dm{i}"), xc) + par(f"Dc{i}")
            c = ca.SX.sym("c", deg + 1)
            fn = ca.Function("routh", [c], [routh_column(c / c[0])]).map(cap)
            g.append(ca.vec(fn(ca.reshape(D, deg + 1, cap))))
        r0 = ca.dot(par("r0"), xc)
        q0 = ca.dot(par("q0"), xc) + par("q0c")
        g.append(ca.vertcat(r0, q0))
        if st.ctrl_deg >= 0:
            c = ca.SX.sym("c", st.ctrl_deg + 1)
            fn = ca.Function("routh_c", [c], [routh_column(c / c[0])]).map(st.ctrl_count)
            C = ca.mtimes(par("Cm"), xc) + par("Cc")
            g.append(ca.vec(fn(ca.reshape(C, st.ctrl_deg + 1, st.ctrl_count))))
        if st.lin:
            g.append(ca.mtimes(par("Lm"), xc) + par("Lg") * gamma + par("Lc"))
        coef = par("coef")
        f = (coef[0] * gamma
             + coef[1] * (-ca.log(ca.fmax(r0, TINY)) + ca.log(ca.fmax(q0, TINY)))
             + coef[2] * ca.sumsqr(xc - par("xref")))
        self.n_g = int(sum(e.numel() for e in g))
        g = ca.vertcat(*g)
        # the program as a function of (X, P): a MappedTemplate composes it with a map
        self.program = ca.Function("rst_program", [X, P], [f, g])
        self.stop, opts = _options(st, int(X.numel()), self.n_g)
        self.solver = ca.nlpsol("rst", "ipopt", {"x": X, "p": P, "f": f, "g": g}, opts)

    @staticmethod
    def _am(wn, zeta, aux, domr, degree):
        dom = [1, 2 * zeta * wn, wn ** 2]
        for i in range(domr.numel()):
            dom = poly.conv_generic(dom, [1, -domr[i]])
        am = dom
        for _ in range(degree - 2 - domr.numel()):
            am = poly.conv_generic(am, [1, aux * wn])
        return ca.vertcat(*am[1:])

    def pack(self, values: dict[str, np.ndarray]) -> np.ndarray:
        """The parameter vector from a dict of arrays (missing blocks are zero).

        Parameters
        ----------
        values : dict
            Parameter block name -> array of that block's shape.

        Returns
        -------
        numpy.ndarray

        Raises
        ------
        ValueError
            A block of the wrong shape (naming it).
        """
        p = np.zeros(self.n_p)
        for name, v in values.items():
            o, shape = self.layout[name]
            a = np.asarray(v, float)
            if a.shape != tuple(shape):
                raise ValueError(f"parameter {name}: shape {a.shape}, expected {shape}")
            p[o:o + a.size] = a.ravel(order="F")
        return p

    def solve(self, values: dict[str, np.ndarray], x0: np.ndarray, lbx: np.ndarray, ubx: np.ndarray,
              lbg: np.ndarray, ubg: np.ndarray) -> dict:
        """Solve with parameters ``values``; returns IPOPT's raw outcome as a dict.

        Parameters
        ----------
        values : dict
            The parameter blocks (:meth:`pack`).
        x0 : numpy.ndarray
            The start.
        lbx, ubx : numpy.ndarray
            Bounds of the variables.
        lbg, ubg : numpy.ndarray
            Bounds of the constraints.

        Returns
        -------
        dict
            ``status, x, f, g, lam_g, lam_x, iterations`` (``lam_g``, ``lam_x``: IPOPT's
            multipliers of the constraints and of the variable bounds).
        """
        with solver_call():     # a signal inside stops IPOPT, then raises Interrupted
            sol = self.solver(x0=x0, p=self.pack(values), lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        return _answer(self.solver, sol, np.array(sol["x"]).ravel(),
                       np.array(sol["lam_x"]).ravel())


class MappedTemplate:
    """A :class:`Template`'s program over other coordinates: the controller coefficients
    ``xc = space.symbolic(theta)`` (the nominal closed-loop poles and the Youla degrees of
    :class:`robrst.synthesis.search.PoleSpace`), ``theta`` within ``[lo, hi]``; every
    other variable, the parameters, the constraints and the objective are the template's.

    It answers like a template (:meth:`pack`, :meth:`solve`, :attr:`layout`): the exchange
    and its rows see coefficient vectors, the solver moves the poles.  In these
    coordinates the nominal closed loop stays stable and its poles move in steps of their
    own size, where the coefficients' trust regions fail.

    Parameters
    ----------
    base : Template
        The program.
    space : PoleSpace
        The map (``dim``, ``symbolic``, ``controllers``, ``point``).
    lo, hi : numpy.ndarray
        The box of ``theta``.
    memo : dict
        Coefficient vectors (bytes) -> the ``theta`` that gave them, shared by the
        templates of one solve, so a round starts at the previous round's exact point.
    chained : bool, optional
        IPOPT's derivatives by the chain rule through the template's own (the same
        numbers, about 4x cheaper; the paths differ by rounding) instead of CasADi's
        through the composed program (default).
    """

    def __init__(self, base: Template, space: object, lo: np.ndarray, hi: np.ndarray,
                 memo: dict, chained: bool = False) -> None:
        st = self.structure = base.structure
        self.layout, self.n_p, self.n_g = base.layout, base.n_p, base.n_g
        self.base, self.space, self.memo = base, space, memo
        self.lo, self.hi = np.asarray(lo, float), np.asarray(hi, float)
        T = ca.MX.sym("theta", space.dim)
        rest = ca.MX.sym("rest", st.n_var - st.nx)
        P = ca.MX.sym("p", base.n_p)
        f, g = base.program(ca.vertcat(space.symbolic(T), rest), P)
        X = ca.vertcat(T, rest)
        self.stop, opts = _options(st, int(X.numel()), self.n_g)
        if chained:
            opts.update(_chained(base.solver, space, st.nx, T, rest, P, self.n_g))
        # the map's derivatives span decades (a lightly damped pair's frequency against a
        # real pole's): IPOPT scales every row and the objective by its gradient at the
        # start.  Unscaled, the exchange's later rounds (each started outside the points it
        # adds) ended at the iteration limit in about half of the solves; in the
        # coefficients (the template's own program) the same scaling lost optima.
        opts["ipopt"]["nlp_scaling_method"] = POLE_SCALING
        self.solver = ca.nlpsol("rst_poles", "ipopt", {"x": X, "p": P, "f": f, "g": g}, opts)

    def pack(self, values: dict[str, np.ndarray]) -> np.ndarray:
        """The parameter vector (:meth:`Template.pack`).

        Parameters
        ----------
        values : dict
            Parameter block name -> array.

        Returns
        -------
        numpy.ndarray
        """
        return self.base.pack(values)

    def solve(self, values: dict[str, np.ndarray], x0: np.ndarray, lbx: np.ndarray, ubx: np.ndarray,
              lbg: np.ndarray, ubg: np.ndarray) -> dict:
        """Solve over ``theta`` (:meth:`Template.solve`'s arguments and answer, in
        coefficients; the coefficients' bounds give way to the box of ``theta``).

        Parameters
        ----------
        values : dict
            The parameter blocks.
        x0 : numpy.ndarray
            The start (coefficients first).
        lbx, ubx : numpy.ndarray
            Bounds of the variables (those of the coefficients unused).
        lbg, ubg : numpy.ndarray
            Bounds of the constraints.

        Returns
        -------
        dict
            As :meth:`Template.solve`; ``x`` in coefficients (its ``theta`` in
            ``memo``), ``lam_x`` ``None`` (the bounds' multipliers are those of ``theta``).
        """
        nx, x0 = self.structure.nx, np.asarray(x0, float)
        th0 = self.memo.get(x0[:nx].tobytes())
        if th0 is None:
            th0 = self.space.point(x0[:nx])
            th0 = (self.lo + self.hi) / 2 if th0 is None else th0
        th0 = np.clip(th0, self.lo, self.hi)
        with solver_call():
            sol = self.solver(x0=np.concatenate([th0, x0[nx:]]), p=self.pack(values),
                              lbx=np.concatenate([self.lo, lbx[nx:]]),
                              ubx=np.concatenate([self.hi, ubx[nx:]]), lbg=lbg, ubg=ubg)
        z = np.array(sol["x"]).ravel()
        th = z[:self.space.dim]
        xc = self.space.controllers(th[None])[0]
        self.memo[xc.tobytes()] = th
        return _answer(self.solver, sol, np.concatenate([xc, z[th.size:]]), None)


class MappedTemplates:
    """A cache of :class:`MappedTemplate` by structure, for
    :func:`robrst.synthesis.exchange.solve_exchange`'s ``templates`` (each built from the
    shared cache's template of that structure).

    Parameters
    ----------
    base : dict
        The shared cache of built templates (structure -> :class:`Template`).
    space : PoleSpace
        The map.
    lo, hi : numpy.ndarray
        The box of ``theta``.
    chained : bool, optional
        Derivatives by the chain rule (:class:`MappedTemplate`).
    """

    def __init__(self, base: dict, space: object, lo: np.ndarray, hi: np.ndarray,
                 chained: bool = False) -> None:
        self.base, self.space, self.lo, self.hi, self.chained = base, space, lo, hi, chained
        self.built, self.memo = {}, {}

    def __contains__(self, st: Structure) -> bool:
        return True

    def __getitem__(self, st: Structure) -> MappedTemplate:
        if st not in self.built:
            if st not in self.base:
                self.base[st] = Template(st)
            self.built[st] = MappedTemplate(self.base[st], self.space, self.lo, self.hi,
                                            self.memo, self.chained)
        return self.built[st]
