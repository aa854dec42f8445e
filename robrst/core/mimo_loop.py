"""The decentralised multi-axis RST controller and its closed loop with a MIMO plant.

**The controller** (:class:`MimoController`): one RST law per axis,
``S_i(s) v_i = T_i(s) r_i - R_i(s) y_i`` (:class:`robrst.core.rst.RSTController`), and a
decoupler from the axis commands ``v`` to the actuator voltages ``u``: static,
``u = W v`` (a real matrix), or dynamic, ``u = W(s) v`` (a stable state space).  With
``K = W diag(R_i / S_i)`` the feedback law is ``u = K_r r - K y``.

**The loop** (:func:`mimo_loop`): plant ``y = G (u + d_i) + d_o``, measurement
``y + n``.  One realisation with the exogenous inputs ``[r, n, d_o, d_i]`` and the
outputs ``[y, u]`` gives every closed-loop transfer matrix (``S_o = (I + G K)^-1``):

========  ==============================  =========================================
name      transfer                        from -> to
========  ==============================  =========================================
``S``     ``S_o``                         output disturbance ``d_o`` -> ``y``
``T``     ``G K S_o``                     measurement noise ``n`` -> ``-y``
``U``     ``K S_o`` (controller sens.)    output disturbance ``d_o`` -> ``-u``
``Sd``    ``S_o G``                       input disturbance ``d_i`` -> ``y``
``Tr``    ``S_o G W diag(T_i / S_i)``     reference ``r`` -> ``y`` (tracking, crosstalk)
``Ti``    ``K G (I + K G)^-1``            input disturbance ``d_i`` -> ``-u`` (input
                                          complementary sensitivity: input-gain sector)
========  ==============================  =========================================

Every computation is on the state space (physical time); the closed loop's stability is
the spectrum of its ``A``.  The loop is well posed when ``I + D_K D_G`` is invertible
(a biproper sampled plant behind a biproper controller).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.core import lti, poly
from robrst.core.mimo import MimoPlant
from robrst.core.rst import RSTController, as_controller

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["MimoController", "MimoLoop", "mimo_loop", "LOOP_TRANSFERS", "WELL_POSED_COND"]

#: the closed-loop transfer matrices of :class:`MimoLoop`
LOOP_TRANSFERS = ("S", "T", "U", "Sd", "Tr", "Ti")
#: ``I + D_K D_G`` with a condition number above this is not a well-posed loop
WELL_POSED_COND = 1e12


def _axis_realisation(ctrl: RSTController) -> tuple[np.ndarray, ...]:
    """``v = [T/S, -R/S] [r; y]`` of one axis in physical time: ``(A, Br, By, C, Dr, Dy)``.

    The observable form of ``1/S`` in the scaled variable of the controller
    (:func:`robrst.core.lti.companion_outputs` of ``T`` and ``-R`` over ``S``, transposed),
    unscaled.
    """
    S = poly.trim(ctrl.S)
    sc = poly.Scaling.natural(ctrl.S, ctrl.R)
    if len(S) == 1:          # a static law
        T, R = poly.trim(ctrl.T), poly.trim(ctrl.R)
        return (np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((0, 1)), np.zeros((1, 0)),
                np.array([[T[-1] / S[0]]]), np.array([[-R[-1] / S[0]]]))
    A, B, C, d = lti.companion_outputs([ctrl.T, -np.asarray(ctrl.R)], S, sc)
    # dual: x' = A' x + C' [r, y], v = B' x + d [r, y]
    w0 = sc.w0
    At, Bt, Ct = w0 * A.T, w0 * C.T, B.T
    return At, Bt[:, :1], Bt[:, 1:], Ct, np.array([[d[0]]]), np.array([[d[1]]])


@dataclass(frozen=True, eq=False)
class MimoController:
    """A decentralised RST controller per axis and a decoupler (module docstring).

    Parameters
    ----------
    axes : sequence of RSTController
        One law per axis (python-control SISO controllers are accepted, as
        :func:`robrst.core.rst.as_controller` reads them).
    decoupler : array_like, optional
        Static decoupler ``W`` (``inputs x axes``): ``u = W v``; default the identity.
    decoupler_ss : tuple of array_like, optional
        A dynamic decoupler ``(A, B, C, D)`` (physical time, ``axes`` inputs, plant inputs
        outputs), instead of ``decoupler``; it must be stable.
    names : sequence of str, optional
        The axes' names (default ``"axis1"``, ...).

    Attributes
    ----------
    n_axes, n_inputs : int
        Axes (plant outputs) and actuator inputs.

    Raises
    ------
    SpecError
        No axis, a decoupler of the wrong shape or with non-finite entries, both decoupler
        forms, or an unstable dynamic decoupler.
    """

    axes: tuple
    decoupler: np.ndarray | None = None
    decoupler_ss: tuple | None = None
    names: tuple = field(default=())

    def __post_init__(self):
        axes = tuple(as_controller(c, f"axis {i + 1}") for i, c in enumerate(self.axes))
        if not axes:
            raise SpecError("a multi-axis controller needs at least one axis")
        m = len(axes)
        object.__setattr__(self, "axes", axes)
        if self.decoupler is not None and self.decoupler_ss is not None:
            raise SpecError("decoupler: give a static matrix or a state space, not both")
        if self.decoupler_ss is not None:
            A, B, C, D = (np.atleast_2d(np.asarray(x, float)) for x in self.decoupler_ss)
            n = A.shape[0] if A.size else 0
            if A.size == 0:
                A, B, C = np.zeros((0, 0)), np.zeros((0, m)), np.zeros((D.shape[0], 0))
            if not all(np.all(np.isfinite(x)) for x in (A, B, C, D)):
                raise SpecError("decoupler: entries must be finite numbers")
            if A.shape != (n, n) or B.shape != (n, m) or C.shape[1] != n or \
                    D.shape != (C.shape[0], m):
                raise SpecError(f"decoupler: a state space from {m} axes expected; got A"
                                f" {A.shape}, B {B.shape}, C {C.shape}, D {D.shape}")
            if n:
                lam = np.linalg.eigvals(A)
                if np.any(lam.real >= 0):
                    worst = lam[np.argmax(lam.real)]
                    raise SpecError(f"decoupler: unstable (pole {complex(worst):.6g} rad/s);"
                                    " a dynamic decoupler must be stable: an unstable one"
                                    " would be cancelled inside the loop")
            object.__setattr__(self, "decoupler_ss", (A, B, C, D))
        else:
            W = np.eye(m) if self.decoupler is None else np.atleast_2d(
                np.asarray(self.decoupler, float))
            if W.ndim != 2 or W.shape[1] != m or not np.all(np.isfinite(W)):
                raise SpecError(f"decoupler: expected a finite matrix with {m} columns (one"
                                f" per axis), got shape {np.shape(self.decoupler)}")
            object.__setattr__(self, "decoupler", W)
        names = tuple(self.names) or tuple(f"axis{i + 1}" for i in range(m))
        if len(names) != m:
            raise SpecError(f"names: {len(names)} given for {m} axes")
        object.__setattr__(self, "names", names)

    @property
    def n_axes(self) -> int:
        return len(self.axes)

    @property
    def n_inputs(self) -> int:
        return (self.decoupler_ss[3].shape[0] if self.decoupler_ss is not None
                else self.decoupler.shape[0])

    @property
    def dynamic(self) -> bool:
        return self.decoupler_ss is not None

    def decoupler_gain(self) -> np.ndarray:
        """The decoupler's static gain ``W(0)`` (the matrix itself when static).

        Returns
        -------
        numpy.ndarray
        """
        if not self.dynamic:
            return self.decoupler
        A, B, C, D = self.decoupler_ss
        return D - C @ np.linalg.solve(A, B) if A.size else D

    def realisation(self) -> tuple[np.ndarray, ...]:
        """The whole law ``u = K_r r + K_y y`` in physical time.

        Returns
        -------
        A, Br, By, C, Dr, Dy : numpy.ndarray
            ``x' = A x + Br r + By y``, ``u = C x + Dr r + Dy y`` (``K_y = -K``).
        """
        from scipy.linalg import block_diag

        parts = [_axis_realisation(c) for c in self.axes]
        A = block_diag(*[p[0] for p in parts])
        n = A.shape[0]
        m = self.n_axes
        Br, By = np.zeros((n, m)), np.zeros((n, m))
        row = 0
        for i, p in enumerate(parts):
            k = p[0].shape[0]
            Br[row:row + k, i], By[row:row + k, i] = p[1][:, 0], p[2][:, 0]
            row += k
        C = block_diag(*[p[3] for p in parts]) if n else np.zeros((m, 0))
        C = C.reshape(m, n)
        Dr = np.diag([p[4][0, 0] for p in parts])
        Dy = np.diag([p[5][0, 0] for p in parts])
        if not self.dynamic:
            W = self.decoupler
            return A, Br, By, W @ C, W @ Dr, W @ Dy
        Aw, Bw, Cw, Dw = self.decoupler_ss
        nw = Aw.shape[0]
        # v -> decoupler: x_w' = Aw x_w + Bw v, u = Cw x_w + Dw v
        At = np.block([[A, np.zeros((n, nw))], [Bw @ C, Aw]])
        return (At, np.vstack([Br, Bw @ Dr]), np.vstack([By, Bw @ Dy]),
                np.hstack([Dw @ C, Cw]), Dw @ Dr, Dw @ Dy)

    def freqresp(self, w: ArrayLike) -> np.ndarray:
        """The feedback law ``K(jw) = W(jw) diag(R_i / S_i)(jw)``, ``(F, inputs, axes)``.

        Parameters
        ----------
        w : array_like
            Frequencies [rad/s].

        Returns
        -------
        numpy.ndarray
            Complex.
        """
        w = np.atleast_1d(np.asarray(w, float))
        kd = np.stack([poly.eval_jw(c.R, w) / poly.eval_jw(c.S, w) for c in self.axes], -1)
        if not self.dynamic:
            return self.decoupler[None] * kd[:, None, :]
        Aw, Bw, Cw, Dw = self.decoupler_ss
        Wj = MimoPlant(Aw, Bw, Cw, Dw, "decoupler").freqresp(w)
        return Wj * kd[:, None, :]

    @classmethod
    def from_dict(cls, d: dict) -> MimoController:
        """The controller of :meth:`as_dict` (a saved design's ``controller``).

        Parameters
        ----------
        d : dict
            ``axes`` (each ``name, R, S, T``) and ``decoupler``.

        Returns
        -------
        MimoController

        Raises
        ------
        SpecError
            A malformed dict.
        """
        try:
            axes = [RSTController(a["R"], a["S"], a["T"]) for a in d["axes"]]
            names = tuple(a.get("name", f"axis{i + 1}") for i, a in enumerate(d["axes"]))
            dec = d.get("decoupler", {"kind": "static", "W": np.eye(len(axes)).tolist()})
            if dec.get("kind") == "dynamic":
                return cls(axes, decoupler_ss=tuple(dec[k] for k in "ABCD"), names=names)
            return cls(axes, dec["W"], names=names)
        except (KeyError, TypeError) as exc:
            raise SpecError(f"not a multi-axis controller ({exc!r} missing or malformed)"
                            ) from None

    def as_dict(self) -> dict:
        """The controller as JSON-ready lists.

        Returns
        -------
        dict
            ``axes`` (names and ``R, S, T`` in s, highest power first) and the decoupler
            (``W`` or ``A, B, C, D``).
        """
        out = {"axes": [{"name": nm, **c.as_dict()} for nm, c in zip(self.names, self.axes)]}
        if self.dynamic:
            out["decoupler"] = {"kind": self.decoupler_kind, **{
                k: np.asarray(x).tolist() for k, x in zip("ABCD", self.decoupler_ss)}}
        else:
            out["decoupler"] = {"kind": self.decoupler_kind, "W": self.decoupler.tolist()}
        return out

    @property
    def decoupler_kind(self) -> str:
        """``"dynamic"`` (a state-space decoupler) or ``"static"`` (a matrix ``W``)."""
        return "dynamic" if self.dynamic else "static"


@dataclass(frozen=True, eq=False)
class MimoLoop:
    """The closed loop of :func:`mimo_loop`: one realisation, every transfer matrix.

    Parameters
    ----------
    A : numpy.ndarray
        The closed-loop matrix (plant states first).
    B : numpy.ndarray
        Inputs ``[r, n, d_o, d_i]`` (``m, m, m, k`` columns).
    C : numpy.ndarray
        Outputs ``[y, u]`` (``m, k`` rows).
    D : numpy.ndarray
    m, k : int
        Outputs (axes) and plant inputs.
    n_plant : int
        How many of the states are the plant's.
    label : str
        The plant's label.

    Attributes
    ----------
    poles : numpy.ndarray
        Eigenvalues of ``A``.
    spectral_abscissa : float
        Their largest real part.
    stable : bool
        All in the open left half-plane.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    m: int
    k: int
    n_plant: int
    label: str = ""

    @property
    def poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.A) if self.A.size else np.zeros(0, complex)

    @property
    def spectral_abscissa(self) -> float:
        p = self.poles
        return float(np.max(p.real)) if p.size else -np.inf

    @property
    def stable(self) -> bool:
        return self.spectral_abscissa < 0

    def _cols(self, what):
        m, k = self.m, self.k
        start = {"r": 0, "n": m, "do": 2 * m, "di": 3 * m}[what]
        return slice(start, start + (k if what == "di" else m))

    def _rows(self, what):
        return slice(0, self.m) if what == "y" else slice(self.m, self.m + self.k)

    def transfer(self, name: str, i: int | None = None,
                 j: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One transfer matrix (or its entry ``(i, j)``) as ``(A, B, C, D)``.

        Parameters
        ----------
        name : {"S", "T", "U", "Sd", "Tr", "Ti"}
            See the module docstring.
        i, j : int, optional
            Output and input of one entry (0-based).

        Returns
        -------
        A, B, C, D : numpy.ndarray

        Raises
        ------
        ValueError
            An unknown name.
        """
        where = {"S": ("do", "y", 1.0), "T": ("n", "y", -1.0), "U": ("do", "u", -1.0),
                 "Sd": ("di", "y", 1.0), "Tr": ("r", "y", 1.0), "Ti": ("di", "u", -1.0)}
        if name not in where:
            raise ValueError(f"unknown closed-loop transfer {name!r}; expected one of"
                             f" {', '.join(LOOP_TRANSFERS)}")
        col, row, sign = where[name]
        B = self.B[:, self._cols(col)]
        C = sign * self.C[self._rows(row)]
        D = sign * self.D[self._rows(row), self._cols(col)]
        if i is not None:
            C, D = C[i:i + 1], D[i:i + 1]
        if j is not None:
            B, D = B[:, j:j + 1], D[:, j:j + 1]
        return self.A, B, C, D

    def freqresp(self, name: str, w: ArrayLike) -> np.ndarray:
        """``(F, rows, cols)`` of one transfer matrix at ``w`` [rad/s].

        Parameters
        ----------
        name : str
            As :meth:`transfer`.
        w : array_like
            Frequencies [rad/s].

        Returns
        -------
        numpy.ndarray
        """
        A, B, C, D = self.transfer(name)
        return MimoPlant(A, B, C, D, name).freqresp(w)


def mimo_loop(plant: MimoPlant, ctrl: MimoController) -> MimoLoop:
    """The closed loop of ``plant`` under ``ctrl`` (module docstring).

    Parameters
    ----------
    plant : MimoPlant
        Continuous, or the w-plane plant of a sampled loop
        (:func:`robrst.core.mimo.sampled_mimo`).
    ctrl : MimoController
        As many axes as the plant has outputs, as many decoupler outputs as it has inputs.

    Returns
    -------
    MimoLoop

    Raises
    ------
    SpecError
        Sizes that do not match, or a loop that is not well posed.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoPlant
    >>> from robrst.core.mimo_loop import MimoController, mimo_loop
    >>> from robrst.core.rst import RSTController
    >>> G = MimoPlant(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2)))
    >>> K = MimoController([RSTController([1.0], [1.0, 0.0], [1.0])] * 2)
    >>> bool(mimo_loop(G, K).stable)
    True
    """
    m, k = plant.n_out, plant.n_in
    if ctrl.n_axes != m:
        raise SpecError(f"controller of {ctrl.n_axes} axes for a plant of {m} outputs: one"
                        " axis per output")
    if ctrl.n_inputs != k:
        raise SpecError(f"the decoupler drives {ctrl.n_inputs} inputs; the plant has {k}")
    Ap, Bp, Cp, Dp = plant.A, plant.B, plant.C, plant.D
    Ac, Bcr, Bcy, Cc, Dcr, Dcy = ctrl.realisation()
    n, nc = Ap.shape[0], Ac.shape[0]
    M = np.eye(k) - Dcy @ Dp
    if np.linalg.cond(M) > WELL_POSED_COND:
        raise SpecError(f"plant {plant.label!r}: the loop is not well posed (I + D_K D_G is"
                        " singular: the controller's and the plant's feedthroughs cancel)")
    E = np.linalg.inv(M)
    Z = lambda r, c: np.zeros((r, c))  # noqa: E731
    # u = Cu X + Du w, X = [x; xc], w = [r, n, d_o, d_i]
    Cu = E @ np.hstack([Dcy @ Cp, Cc])
    Du = E @ np.hstack([Dcr, Dcy, Dcy, Dcy @ Dp])
    Cy = np.hstack([Cp, Z(m, nc)]) + Dp @ Cu
    Dy = Dp @ Du + np.hstack([Z(m, m), Z(m, m), np.eye(m), Dp])
    A0 = np.block([[Ap, Z(n, nc)], [Bcy @ Cp, Ac]])
    Bu = np.vstack([Bp, Bcy @ Dp])
    Bw = np.block([[Z(n, m), Z(n, m), Z(n, m), Bp], [Bcr, Bcy, Bcy, Bcy @ Dp]])
    A = A0 + Bu @ Cu
    B = Bw + Bu @ Du
    return MimoLoop(A=A, B=B, C=np.vstack([Cy, Cu]), D=np.vstack([Dy, Du]), m=m, k=k,
                    n_plant=n, label=plant.label)
