"""Multi-input multi-output plants: one state space per model, and families of them.

A multi-axis actuator (three piezo stacks under one mirror: three voltages in, three
displacements out) is a transfer matrix whose polynomials, at the orders identified
models have (28 poles per channel), would not fit in double precision; robrst keeps it as
a state space, in physical time (inputs V, outputs µm, s in rad/s):

* :class:`MimoPlant` — ``G(s) = C (sI - A)^-1 B + D``, built from arrays, from a
  python-control ``StateSpace`` or ``TransferFunction`` (:meth:`MimoPlant.from_control`),
  from a transfer matrix of polynomials (:meth:`MimoPlant.from_transfer_matrix`) or from
  the modal form ``robrst identify`` writes (:meth:`MimoPlant.from_modal`: one real block
  per pole, of the residue's rank: a minimal realisation);
* :class:`MimoFamily` — the models over a parameter (temperature in °C, or the excitation
  level of an amplitude-dependent actuator: one identified model per level).  Between two
  neighbouring models the family holds every convex combination of their transfer
  matrices, ``G(s; lam) = (1 - lam) G_a(s) + lam G_b(s)`` (:meth:`MimoFamily.at`): the
  frequency responses between the measured ones, with a realisation affine in ``lam``;
* :func:`sampled_mimo` — the plant of the sampled loop (ZOH plant, ``delay_samples`` of
  computation delay) in the w-plane of the Tustin controller, the exact map that
  :mod:`robrst.core.sampled` uses for one loop: every continuous-loop computation then
  applies to the sampled loop unchanged (physical frequency ``w`` below Nyquist at
  ``nu = 2 fs tan(w / 2 fs)``, Nyquist at ``nu = inf``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from robrst.base.errors import SpecError
from robrst.core import lti, poly
from robrst.core.plant import is_control_system
from robrst.core.sampled import w_plane_matrices
from robrst.core.sigma import natural_scale

if TYPE_CHECKING:
    import control
    from numpy.typing import ArrayLike

__all__ = ["MimoPlant", "ModalResponse", "MimoFamily", "as_mimo_plant", "combination",
           "sampled_mimo", "PARAMETERS", "RANK_RTOL"]

#: the parameters a family runs over, with their unit
PARAMETERS = {"temperature_C": "°C", "level": ""}
#: singular values of a residue below this share of its largest are rounding (rank)
RANK_RTOL = 1e-12


def _matrix(x, name, shape=None):
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 and shape is not None and 0 in shape:
        a = np.zeros(shape)
    a = np.atleast_2d(a) if a.size else np.zeros(shape or (0, 0))
    if not np.all(np.isfinite(a)):
        raise SpecError(f"{name}: entries must be finite numbers")
    return a


@dataclass(frozen=True, eq=False)
class ModalResponse:
    """A plant's frequency response at many frequencies at once, from one decomposition
    (:meth:`MimoPlant.modal_response`): ``G(jw) = D + C V diag(1 / (jw/sc - lam)) V^-1 B /
    sc`` when the scaled ``A / sc`` is diagonalisable with a well-conditioned ``V``, else
    one batched solve of ``(jw/sc I - A/sc) X = B/sc``.

    Parameters
    ----------
    scale : float
        ``sc``, the plant's natural frequency scale [rad/s].
    As, Bs : numpy.ndarray
        ``A / sc``, ``B / sc``.
    C, D : numpy.ndarray
    lam, CV, ViB : numpy.ndarray or None
        The eigenvalues of ``A / sc``, ``C V`` and ``V^-1 B / sc`` (``None``: solves).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoPlant
    >>> g = MimoPlant(-np.eye(1) * 10.0, np.eye(1) * 10.0, np.eye(1), np.zeros((1, 1)))
    >>> r = g.modal_response()
    >>> bool(np.allclose(r(np.array([0.0, 10.0]))[:, 0, 0], [1.0, 10 / (10 + 10j)]))
    True
    """

    scale: float
    As: np.ndarray
    Bs: np.ndarray
    C: np.ndarray
    D: np.ndarray
    lam: np.ndarray | None = None
    CV: np.ndarray | None = None
    ViB: np.ndarray | None = None

    def __call__(self, w: ArrayLike) -> np.ndarray:
        """The response ``(F, outputs, inputs)`` at the finite frequencies ``w`` [rad/s].

        Parameters
        ----------
        w : array_like
            ``F`` frequencies [rad/s].

        Returns
        -------
        numpy.ndarray
            Complex.
        """
        w = np.atleast_1d(np.asarray(w, float))
        n = self.As.shape[0]
        if not n:
            return np.broadcast_to(self.D, (w.size,) + self.D.shape).astype(complex)
        p = 1j * w / self.scale
        if self.lam is not None:
            return (self.CV[None] / (p[:, None] - self.lam)[:, None, :]) @ self.ViB + self.D
        X = np.linalg.solve(p[:, None, None] * np.eye(n) - self.As,
                            np.broadcast_to(self.Bs.astype(complex), (w.size,) + self.Bs.shape))
        return self.C @ X + self.D


@dataclass(frozen=True, eq=False)
class MimoPlant:
    """``G(s) = C (sI - A)^-1 B + D``: ``k`` inputs [V], ``m`` outputs [µm], s in rad/s.

    Parameters
    ----------
    A, B, C, D : array_like
        ``(n, n)``, ``(n, k)``, ``(m, n)``, ``(m, k)``.
    label : str
        The model's name (reports, violations).
    value : float, optional
        Where the model holds on its family's parameter (a temperature [°C] or a level).
    meta : dict
        Free information (a sampled plant's ``fs_hz`` and ``delay_samples``).

    Attributes
    ----------
    n_in, n_out, n_states : int
        ``k``, ``m`` and ``n``.
    w0 : float
        Frequency scale [rad/s] (geometric mean of the pole moduli).

    Raises
    ------
    SpecError
        Inconsistent shapes or entries that are not finite.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoPlant
    >>> G = MimoPlant(-np.eye(2), np.eye(2), [[1.0, 0.1], [0.2, 1.0]], np.zeros((2, 2)))
    >>> G.freqresp([0.0])[0].real.tolist()
    [[1.0, 0.1], [0.2, 1.0]]
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    label: str = "plant"
    value: float | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        D = _matrix(self.D, f"plant {self.label!r}: D")
        m, k = D.shape
        A = _matrix(self.A, f"plant {self.label!r}: A")
        n = A.shape[0] if A.size else 0
        A = A if n else np.zeros((0, 0))
        B = _matrix(self.B, f"plant {self.label!r}: B", (n, k)) if n else np.zeros((0, k))
        C = _matrix(self.C, f"plant {self.label!r}: C", (m, n)) if n else np.zeros((m, 0))
        if n and B.shape == (1, n) and k == 1:
            B = B.T                           # one input given as a row
        if n and C.shape == (n, 1) and m == 1:
            C = C.T
        if A.shape != (n, n) or B.shape != (n, k) or C.shape != (m, n):
            raise SpecError(f"plant {self.label!r}: inconsistent state space: A {A.shape},"
                            f" B {B.shape}, C {C.shape}, D {D.shape}; expected (n, n),"
                            " (n, inputs), (outputs, n), (outputs, inputs)")
        for k_, v in (("A", A), ("B", B), ("C", C), ("D", D)):
            object.__setattr__(self, k_, v)
        if self.value is not None:
            object.__setattr__(self, "value", float(self.value))

    @property
    def n_in(self) -> int:
        return self.D.shape[1]

    @property
    def n_out(self) -> int:
        return self.D.shape[0]

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def w0(self) -> float:
        return natural_scale(self.A)

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` [rad/s].

        Returns
        -------
        numpy.ndarray
        """
        return np.linalg.eigvals(self.A) if self.n_states else np.zeros(0, complex)

    def is_stable(self) -> bool:
        """Every pole strictly in the left half-plane.

        Returns
        -------
        bool
        """
        return bool(np.all(self.poles().real < 0))

    def freqresp(self, w: ArrayLike) -> np.ndarray:
        """Frequency response ``(F, m, k)`` at ``w`` [rad/s] (``inf``: ``D``).

        Parameters
        ----------
        w : array_like
            ``F`` frequencies [rad/s].

        Returns
        -------
        numpy.ndarray
            Complex, ``(F, m, k)``.
        """
        w = np.atleast_1d(np.asarray(w, float))
        out = np.empty((w.size, self.n_out, self.n_in), complex)
        if not self.n_states:
            out[:] = self.D
            return out
        r = self.modal_response()
        if r.lam is not None:
            for i, x in enumerate(w):
                out[i] = self.D if not np.isfinite(x) else \
                    (r.CV / (1j * x / r.scale - r.lam)) @ r.ViB + self.D
            return out
        eye = np.eye(self.n_states)
        for i, x in enumerate(w):
            out[i] = self.D if not np.isfinite(x) else \
                self.C @ np.linalg.solve(1j * x / r.scale * eye - r.As, r.Bs) + self.D
        return out

    def modal_response(self) -> ModalResponse:
        """The decomposition :meth:`freqresp` evaluates, kept: the response at many
        frequencies at once, each set of frequencies without a new decomposition (a search's
        candidates' own frequencies, population after population).

        Returns
        -------
        ModalResponse
        """
        sc = self.w0 if self.n_states else 1.0
        As, Bs = self.A / sc, self.B / sc
        lam = CV = ViB = None
        if self.n_states:
            # one eigen-decomposition when A is diagonalisable and well conditioned, else solves
            ev, V = np.linalg.eig(As)
            if np.linalg.cond(V) < 1e8:
                lam, CV, ViB = ev, self.C @ V, np.linalg.solve(V, Bs)
        return ModalResponse(scale=sc, As=As, Bs=Bs, C=self.C, D=self.D, lam=lam, CV=CV,
                             ViB=ViB)

    def dc_gain(self) -> np.ndarray:
        """Static gain ``(m, k)``.

        Returns
        -------
        numpy.ndarray
            Real; ``inf`` entries with a pole at ``s = 0``.
        """
        with np.errstate(all="ignore"):
            G = self.freqresp([0.0])[0]
        return G.real

    def with_label(self, label: str, value: float | None = None) -> MimoPlant:
        """The same model under another label (and parameter value).

        Parameters
        ----------
        label : str
        value : float, optional
            Default: unchanged.

        Returns
        -------
        MimoPlant
        """
        return MimoPlant(self.A, self.B, self.C, self.D, label,
                         self.value if value is None else value, dict(self.meta))

    def without_modes_below(self, w_rad_s: float) -> MimoPlant:
        """The model with its modes slower than ``w_rad_s`` removed (truncated).

        A mode below the lowest frequency a record excites is not identified: its pole and
        residue are an extrapolation that sets the static gain (identified models of the
        measured mirror carry a real pole at 0.3-5 rad/s whose DC gain changes sign from
        one level to the next, while the responses agree across the excited band).
        Removing it keeps the response wherever the other modes dominate; the static gain
        becomes that of the remaining modes.

        The poles are separated by an ordered real Schur form (slow ones first) and a
        Sylvester equation that decouples the two blocks (no eigenvectors: defective or
        clustered poles are fine); the fast block is returned, ``D`` unchanged.

        Parameters
        ----------
        w_rad_s : float
            Modes with ``|pole| < w_rad_s`` are removed.

        Returns
        -------
        MimoPlant
            Same label, value and meta (``meta["removed_poles"]`` lists what went).

        Raises
        ------
        SpecError
            A negative ``w_rad_s``.

        Examples
        --------
        >>> import numpy as np
        >>> G = MimoPlant(np.diag([-0.5, -1000.0]), np.ones((2, 1)), np.ones((1, 2)),
        ...               np.zeros((1, 1)))
        >>> [round(float(p.real), 6) for p in G.without_modes_below(10.0).poles()]
        [-1000.0]
        """
        if not w_rad_s >= 0:
            raise SpecError(f"plant {self.label!r}: modes below {w_rad_s!r} rad/s: a"
                            " frequency >= 0 expected")
        n = self.n_states
        slow = np.abs(self.poles()) < w_rad_s if n else np.zeros(0, bool)
        if not slow.any():
            return self
        sc = self.w0
        T22, B2, C2, _ = lti.split_modes(self.A / sc, self.B, self.C,
                                     lambda re, im: np.hypot(re, im) < w_rad_s / sc)
        A2 = T22 * sc
        meta = dict(self.meta, removed_poles=[complex(p) for p in self.poles()[slow]])
        return MimoPlant(A2, B2, C2, self.D, self.label, self.value, meta)

    def to_control(self) -> control.StateSpace:
        """The model as a continuous python-control ``StateSpace``.

        Returns
        -------
        control.StateSpace
        """
        import control

        return control.ss(self.A, self.B, self.C, self.D)

    @classmethod
    def from_control(cls, sys: control.StateSpace | control.TransferFunction,
                     label: str = "plant", value: float | None = None) -> MimoPlant:
        """A continuous python-control system (state space or transfer matrix).

        Parameters
        ----------
        sys : control.StateSpace or control.TransferFunction
            Continuous (``dt = 0``); any number of inputs and outputs.
        label : str
        value : float, optional

        Returns
        -------
        MimoPlant

        Raises
        ------
        SpecError
            Not a python-control system, or a discrete one.
        """
        import control

        if not is_control_system(sys):
            raise SpecError(f"plant {label!r}: expected a python-control StateSpace or"
                            f" TransferFunction, got {type(sys).__name__}")
        if sys.dt not in (0, None):
            raise SpecError(f"plant {label!r}: a discrete python-control system (dt ="
                            f" {sys.dt}); give the continuous plant (robrst samples it with"
                            " a zero-order hold at the controller's rate)")
        if isinstance(sys, control.StateSpace):
            return cls(sys.A, sys.B, sys.C, sys.D, label, value)
        num = [[poly.trim(sys.num[i][j]) for j in range(sys.ninputs)]
               for i in range(sys.noutputs)]
        den = [[poly.trim(sys.den[i][j]) for j in range(sys.ninputs)]
               for i in range(sys.noutputs)]
        return cls.from_transfer_matrix(num, den, label, value)

    @classmethod
    def from_transfer_matrix(cls, num: Sequence[Sequence[ArrayLike]],
                             den: Sequence[Sequence[ArrayLike]] | ArrayLike,
                             label: str = "plant", value: float | None = None) -> MimoPlant:
        """A transfer matrix ``G_ij = num[i][j] / den[i][j]`` (polynomials in s, highest
        power first); ``den`` may be one polynomial common to every entry.

        Realised column by column over the column's common denominator (the product of
        its distinct denominators) with :func:`robrst.core.lti.companion_outputs`, in the
        scaled variable: ``sum_j deg(den_j)`` states.

        Parameters
        ----------
        num : sequence of sequences of array_like
            ``m x k`` numerators.
        den : sequence of sequences of array_like, or array_like
            ``m x k`` denominators, or one common denominator.
        label : str
        value : float, optional

        Returns
        -------
        MimoPlant

        Raises
        ------
        SpecError
            Ragged matrices, a zero denominator or an improper entry.
        """
        m = len(num)
        if not m or any(len(r) != len(num[0]) for r in num) or not len(num[0]):
            raise SpecError(f"plant {label!r}: num must be a non-empty m x k matrix of"
                            " polynomials")
        k = len(num[0])
        common = not (isinstance(den, (list, tuple)) and den and isinstance(den[0], (list, tuple))
                      and den[0] and np.ndim(den[0][0]) == 1)
        if not common and (len(den) != m or any(len(r) != k for r in den)):
            raise SpecError(f"plant {label!r}: den must be {m} x {k} like num, or one"
                            " polynomial")
        blocks = []
        for j in range(k):
            dens = [poly.trim(den if common else den[i][j]) for i in range(m)]
            nums = [poly.trim(num[i][j]) for i in range(m)]
            if any(not d.any() for d in dens):
                raise SpecError(f"plant {label!r}: a zero denominator in column {j + 1}")
            uniq, which = [], []
            for d in dens:
                q = next((q for q, u in enumerate(uniq) if len(d) == len(u) and np.allclose(
                    d / d[0], u / u[0], rtol=1e-13, atol=0)), None)
                if q is None:
                    q = len(uniq)
                    uniq.append(d)
                which.append(q)
            Dj = poly.pprod(*uniq)
            Ns = []
            for i, (N, d, q) in enumerate(zip(nums, dens, which)):
                # N / d = N (u_q[0] / d[0]) prod_{r != q} u_r / Dj
                Ni = poly.pprod(N, *[u for r, u in enumerate(uniq) if r != q]) \
                    * (uniq[q][0] / d[0])
                if len(poly.trim(Ni)) > len(Dj):
                    raise SpecError(f"plant {label!r}: entry ({i + 1}, {j + 1}) is improper"
                                    " (deg num > deg den)")
                Ns.append(Ni)
            sc = poly.Scaling.natural(Dj)
            if len(Dj) == 1:
                blocks.append((np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((m, 0)),
                               np.array([N[-1] / Dj[0] for N in Ns])))
                continue
            A, B, C, d = lti.companion_outputs(Ns, Dj, sc)
            blocks.append((sc.w0 * A, sc.w0 * B, C, d))
        from scipy.linalg import block_diag

        A = block_diag(*[b[0] for b in blocks]) if blocks else np.zeros((0, 0))
        n = A.shape[0]
        B = np.zeros((n, k))
        row = 0
        for j, b in enumerate(blocks):
            B[row:row + b[0].shape[0], j] = b[1][:, 0]
            row += b[0].shape[0]
        C = np.hstack([b[2] for b in blocks]) if n else np.zeros((m, 0))
        D = np.column_stack([b[3] for b in blocks])
        return cls(A, B, C, D, label, value)

    @classmethod
    def from_modal(cls, poles: ArrayLike, residues: ArrayLike, D: ArrayLike,
                   label: str = "plant", value: float | None = None) -> MimoPlant:
        """The modal form ``G(s) = sum_p R_p / (s - p) (+ conjugates) + D`` of
        ``robrst identify`` (:class:`robrst.identify.modal.ModalModel`'s arrays).

        A real pole with a residue of rank ``r`` gives ``r`` states, a stored complex pole
        (its conjugate implied) ``2 r``: the residue ``R = U S V^H`` (singular values above
        :data:`RANK_RTOL` of the largest) enters as ``U S^(1/2)`` and ``S^(1/2) V^H``, so
        the realisation is minimal and its inputs and outputs balanced.

        Parameters
        ----------
        poles : array_like
            Stored poles [rad/s] (real, or the member with positive imaginary part).
        residues : array_like
            ``(n_poles, m, k)`` residue matrices.
        D : array_like
            ``(m, k)``.
        label : str
        value : float, optional

        Returns
        -------
        MimoPlant

        Raises
        ------
        SpecError
            Shapes that do not match.
        """
        p = np.asarray(poles, complex).ravel()
        R = np.asarray(residues, complex)
        D = np.atleast_2d(np.asarray(D, float))
        if R.ndim != 3 or R.shape[0] != p.size or R.shape[1:] != D.shape:
            raise SpecError(f"plant {label!r}: residues must be (n_poles, outputs, inputs) ="
                            f" ({p.size}, {D.shape[0]}, {D.shape[1]}), got {R.shape}")
        m, k = D.shape
        As, Bs, Cs = [], [], []
        for pk, Rk in zip(p, R):
            U, s, Vh = np.linalg.svd(Rk)
            r = int(np.sum(s > RANK_RTOL * s[0])) if s.size and s[0] > 0 else 0
            if r == 0:
                continue
            Us, Vs = U[:, :r] * np.sqrt(s[:r]), np.sqrt(s[:r])[:, None] * Vh[:r]
            if pk.imag > 0:
                sig, om = pk.real, pk.imag
                for c in range(r):
                    As.append(np.array([[sig, -om], [om, sig]]))
                    Bs.append(np.vstack([Vs[c].real, Vs[c].imag]))
                    Cs.append(np.column_stack([2.0 * Us[:, c].real, -2.0 * Us[:, c].imag]))
            else:
                Ur, sr, Vr = np.linalg.svd(Rk.real)
                rr = int(np.sum(sr > RANK_RTOL * sr[0])) if sr[0] > 0 else 0
                for c in range(rr):
                    As.append(np.array([[pk.real]]))
                    Bs.append((np.sqrt(sr[c]) * Vr[c]).reshape(1, k))
                    Cs.append((np.sqrt(sr[c]) * Ur[:, c]).reshape(m, 1))
        from scipy.linalg import block_diag

        if not As:
            return cls(np.zeros((0, 0)), np.zeros((0, k)), np.zeros((m, 0)), D, label, value)
        return cls(block_diag(*As), np.vstack(Bs), np.hstack(Cs), D, label, value)


def as_mimo_plant(obj: object, label: str = "plant", value: float | None = None) -> MimoPlant:
    """``obj`` as a :class:`MimoPlant` (itself, or a python-control system).

    Parameters
    ----------
    obj : MimoPlant or control.StateSpace or control.TransferFunction
    label : str
        The label of a converted system.
    value : float, optional
        Its parameter value.

    Returns
    -------
    MimoPlant

    Raises
    ------
    SpecError
        Anything else.
    """
    if isinstance(obj, MimoPlant):
        return obj
    if is_control_system(obj):
        return MimoPlant.from_control(obj, label, value)
    raise SpecError(f"{label}: expected a MimoPlant or a python-control StateSpace or"
                    f" TransferFunction, got {type(obj).__name__}")


@dataclass(frozen=True, eq=False)
class MimoFamily:
    """Models of one multi-axis actuator over a parameter (temperature or excitation level).

    Parameters
    ----------
    models : tuple of MimoPlant
        Sorted by ``value``; every one with the same inputs and outputs.
    parameter : {"temperature_C", "level"}
        What ``value`` is.
    unit : str
        The parameter's unit (``"°C"``, ``"mV"``).
    reference : int
        Index of the nominal model.

    Attributes
    ----------
    range : (float, float)
        The parameter interval the family spans.
    n_in, n_out : int

    Raises
    ------
    SpecError
        No model, models of different sizes, values missing or repeated, an unknown
        parameter.
    """

    models: tuple
    parameter: str = "temperature_C"
    unit: str = "°C"
    reference: int = 0

    def __post_init__(self):
        ms = tuple(self.models)
        if not ms:
            raise SpecError("a multi-axis family needs at least one model")
        if self.parameter not in PARAMETERS:
            raise SpecError(f"family parameter {self.parameter!r}: expected one of"
                            f" {', '.join(PARAMETERS)}")
        shape = (ms[0].n_out, ms[0].n_in)
        for mdl in ms:
            if (mdl.n_out, mdl.n_in) != shape:
                raise SpecError(f"model {mdl.label!r}: {mdl.n_out} x {mdl.n_in}; every model"
                                f" of the family must be {shape[0]} x {shape[1]}")
        if len(ms) > 1:
            vals = [mdl.value for mdl in ms]
            if any(v is None for v in vals):
                raise SpecError("every model of a multi-axis family needs its parameter value"
                                f" ({self.parameter})")
            order = np.argsort(vals, kind="stable")
            ms = tuple(ms[i] for i in order)
            if len(set(vals)) != len(vals):
                raise SpecError(f"two models at the same {self.parameter}"
                                f" {sorted(vals)}")
        object.__setattr__(self, "models", ms)
        if not 0 <= self.reference < len(ms):
            raise SpecError(f"family reference index {self.reference} out of range")

    @property
    def n_in(self) -> int:
        return self.models[0].n_in

    @property
    def n_out(self) -> int:
        return self.models[0].n_out

    @property
    def range(self) -> tuple[float, float]:
        v = [m.value for m in self.models]
        if v[0] is None:
            return (0.0, 0.0)
        return (float(v[0]), float(v[-1]))

    @property
    def reference_model(self) -> MimoPlant:
        return self.models[self.reference]

    def segments(self) -> list[tuple[MimoPlant, MimoPlant]]:
        """Neighbouring models ``(a, b)``, in order.

        Returns
        -------
        list of (MimoPlant, MimoPlant)
        """
        return list(zip(self.models[:-1], self.models[1:]))

    def at(self, value: float) -> MimoPlant:
        """The family's model at ``value``: a member, or between neighbours ``a, b`` the
        convex combination ``(1 - lam) G_a + lam G_b`` (``lam`` linear in ``value``),
        realised in parallel (states of both; ``C`` and ``D`` affine in ``lam``).

        Parameters
        ----------
        value : float
            Within :attr:`range`.

        Returns
        -------
        MimoPlant
            ``meta["segment"] = (i, lam)`` between members ``i`` and ``i + 1``.

        Raises
        ------
        SpecError
            Outside the range.
        """
        lo, hi = self.range
        v = float(value)
        if not lo <= v <= hi:
            raise SpecError(f"{self.parameter} {v:g} is outside the family's range"
                            f" [{lo:g}, {hi:g}]")
        for mdl in self.models:
            if mdl.value == v or len(self.models) == 1:
                return mdl
        i = int(np.searchsorted([m.value for m in self.models], v)) - 1
        a, b = self.models[i], self.models[i + 1]
        lam = (v - a.value) / (b.value - a.value)
        return combination(a, b, lam, label=f"{self.parameter}={v:.6g}", value=v,
                           meta={"segment": (i, lam)})


def combination(a: MimoPlant, b: MimoPlant, lam: float, label: str | None = None,
                value: float | None = None, meta: dict | None = None) -> MimoPlant:
    """``(1 - lam) G_a + lam G_b`` realised in parallel (``A = diag(A_a, A_b)``).

    Parameters
    ----------
    a, b : MimoPlant
        Of the same size.
    lam : float
        The weight of ``b``.
    label : str, optional
    value : float, optional
    meta : dict, optional

    Returns
    -------
    MimoPlant
    """
    from scipy.linalg import block_diag

    A = block_diag(a.A, b.A)
    B = np.vstack([a.B, b.B])
    C = np.hstack([(1.0 - lam) * a.C, lam * b.C])
    D = (1.0 - lam) * a.D + lam * b.D
    return MimoPlant(A, B, C, D, label or f"{a.label}~{b.label}@{lam:.4g}", value,
                     dict(meta or {}))



def sampled_mimo(plant: MimoPlant, sample_rate_hz: float, delay_samples: int = 0) -> MimoPlant:
    """The plant of the sampled loop in the w-plane (module docstring).

    The exact zero-order hold of the state space (:func:`robrst.core.lti.zoh_matrices`, in
    the plant's scaled time), mapped by :func:`robrst.core.sampled.w_plane_matrices`; each
    input then passes ``delay_samples`` all-pass sections ``(1 - s/2fs)/(1 + s/2fs)``
    (the w-plane image of ``z^-1``).

    Parameters
    ----------
    plant : MimoPlant
        The continuous plant.
    sample_rate_hz : float
        The controller's rate [Hz].
    delay_samples : int
        Whole samples of computation delay.

    Returns
    -------
    MimoPlant
        In the loop variable ``s`` of the w-plane; label ``"<label>@<fs>Hz"``, the same
        value, ``meta`` ``{"fs_hz", "delay_samples", "continuous_label"}``.

    Raises
    ------
    SpecError
        A rate that is not > 0, or a delay that is not a whole number >= 0.
    """
    fs = float(sample_rate_hz)
    if not (np.isfinite(fs) and fs > 0):
        raise SpecError(f"sampling rate must be a finite number > 0 Hz, got {sample_rate_hz}")
    if int(delay_samples) != delay_samples or delay_samples < 0:
        raise SpecError(f"delay_samples must be a whole number >= 0, got {delay_samples}")
    n, k = plant.n_states, plant.n_in
    if n:
        w0 = plant.w0
        As, Bs = plant.A / w0, plant.B / w0
        h = w0 / fs
        Ad, Gamma, Bd = lti.zoh_matrices(As, Bs, h)
        Aw, Bw, Cw, Dw = w_plane_matrices(As, Gamma, Ad, Bd, plant.C, plant.D, h)
        A, B, C, D = w0 * Aw, w0 * Bw, Cw, Dw
    else:
        A, B, C, D = plant.A, plant.B, plant.C, plant.D
    for _ in range(int(delay_samples)):      # u -> (1 - s/2fs)/(1 + s/2fs) u, per input
        a = -2.0 * fs
        Ad_ = a * np.eye(k)
        Bd_, Cd_, Dd_ = np.eye(k), 4.0 * fs * np.eye(k), -np.eye(k)
        # series: delay first, then the plant
        nA = A.shape[0]
        A = np.block([[A, B @ Cd_], [np.zeros((k, nA)), Ad_]])
        B = np.vstack([B @ Dd_, Bd_])
        C = np.hstack([C, D @ Cd_])
        D = D @ Dd_
    return MimoPlant(A, B, C, D, f"{plant.label}@{fs:g}Hz", plant.value,
                     {"fs_hz": fs, "delay_samples": int(delay_samples),
                      "continuous_label": plant.label})
