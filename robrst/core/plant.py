"""Linear plant models B(s)/A(s) with A monic, and the paper's identified model.

Units: input u [V], output y [µm], s in rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from robrst.core import poly
from robrst.base.errors import SpecError

if TYPE_CHECKING:
    import control
    from numpy.typing import ArrayLike

__all__ = ["Plant", "paper_plant", "named_plant", "NAMED_PLANTS", "as_plant", "is_control_system"]


@dataclass(frozen=True, eq=False)
class Plant:
    """A SISO plant ``B(s)/A(s)``, ``A`` monic, ``deg B <= deg A``.

    Parameters
    ----------
    B, A : array_like
        Numerator and denominator coefficients, highest power first.  ``A`` is
        normalised to be monic (``B`` is divided by the same factor).
    label : str
        Name used in reports.
    temperature_C : float or None
        Temperature [°C] at which the model holds.
    meta : dict
        Free-form facts about the model (``"source"``; ``"sample_rate_hz"`` and
        ``"delay_samples"`` of a model read from a discrete one); not compared.

    Raises
    ------
    SpecError
        Coefficients that are not finite, ``deg A < 1``, ``deg B > deg A`` or ``B = 0``,
        naming the plant's label.

    Examples
    --------
    >>> p = Plant([1.0], [1.0, 2.0])
    >>> float(p.dc_gain)
    0.5
    """

    B: np.ndarray
    A: np.ndarray
    label: str = "plant"
    temperature_C: float = None
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        try:
            B = poly.as_poly(self.B, "B")
            A = poly.as_poly(self.A, "A")
        except ValueError as exc:
            raise SpecError(f"plant {self.label!r}: {exc}") from None
        if len(A) < 2:
            raise SpecError(f"plant {self.label!r}: A must have degree >= 1")
        if len(B) > len(A):
            raise SpecError(
                f"plant {self.label!r}: improper, deg B = {len(B) - 1} > deg A = {len(A) - 1}"
            )
        if np.all(B == 0):
            raise SpecError(f"plant {self.label!r}: B is identically zero")
        lead = A[0]
        object.__setattr__(self, "A", A / lead)
        object.__setattr__(self, "B", B / lead)

    @property
    def n(self):
        """Degree of A."""
        return len(self.A) - 1

    @property
    def m(self):
        """Degree of B."""
        return len(self.B) - 1

    @property
    def dc_gain(self):
        """Static gain B(0)/A(0) [µm/V] (inf for a pole at 0)."""
        return self.B[-1] / self.A[-1] if self.A[-1] != 0 else np.inf

    def poles(self) -> np.ndarray:
        """The roots of ``A`` [rad/s].

        Returns
        -------
        numpy.ndarray
            ``numpy.roots(A)``.
        """
        return np.roots(self.A)

    def zeros(self) -> np.ndarray:
        """The roots of ``B`` [rad/s] (none for a constant numerator).

        Returns
        -------
        numpy.ndarray
        """
        return np.roots(self.B) if self.m > 0 else np.zeros(0)

    def freqresp(self, w: float | ArrayLike) -> complex | np.ndarray:
        """Complex frequency response at ``w`` [rad/s].

        Parameters
        ----------
        w : float or array_like
            Frequencies [rad/s].

        Returns
        -------
        complex or numpy.ndarray
            ``B(jw) / A(jw)`` [µm/V].
        """
        return poly.eval_jw(self.B, w) / poly.eval_jw(self.A, w)

    @classmethod
    def from_zpk(cls, zeros: ArrayLike, poles: ArrayLike, gain: float, **kw: Any) -> Plant:
        """Build from zeros, poles [rad/s] and the leading gain ``k`` of ``k*prod(s-z)/prod(s-p)``.

        Parameters
        ----------
        zeros, poles : array_like
            Roots [rad/s]; complex ones with their conjugates.
        gain : float
            The leading gain ``k``.
        **kw
            ``label``, ``temperature_C``, ``meta`` of :class:`Plant`.

        Returns
        -------
        Plant
        """
        B = float(gain) * poly.from_roots(zeros) if len(zeros) else np.array([float(gain)])
        return cls(B, poly.from_roots(poles), **kw)

    @classmethod
    def from_tf(cls, tf: control.TransferFunction, **kw: Any) -> Plant:
        """Build from a continuous-time SISO ``control.TransferFunction``.

        Parameters
        ----------
        tf : control.TransferFunction
            Continuous (``dt`` 0 or ``None``), one input and one output.
        **kw
            ``label``, ``temperature_C``, ``meta`` of :class:`Plant`.

        Returns
        -------
        Plant

        Raises
        ------
        SpecError
            For a discrete or a MIMO transfer function.
        """
        if getattr(tf, "dt", 0) not in (0, None):
            raise SpecError("from_tf: only continuous-time transfer functions are supported"
                            " (use Plant.from_control for discrete ones)")
        if tf.ninputs != 1 or tf.noutputs != 1:
            raise SpecError("from_tf: only SISO transfer functions are supported")
        num, den = tf.num[0][0], tf.den[0][0]
        return cls(num, den, **kw)

    @classmethod
    def from_control(cls, sys: control.TransferFunction | control.StateSpace,
                     label: str = "plant", temperature_C: float | None = None) -> Plant:
        """Build from a SISO python-control ``TransferFunction`` or ``StateSpace``.

        Continuous systems are taken as they are (a state space through its poles,
        transmission zeros and gain, :func:`robrst.core.lti.ss_to_poly`).  A **discrete**
        system (``dt > 0``) is read as what a controller at ``fs = 1/dt`` sees: the
        zero-order-hold model of a continuous plant, possibly behind ``k`` samples of
        delay (``k`` poles at ``z = 0``).  The plant returned is that continuous plant
        (the exact inverse of the ZOH, :func:`robrst.core.lti.d2c`), with
        ``meta["sample_rate_hz"] = 1/dt`` and ``meta["delay_samples"] = k``: put both
        in :class:`~robrst.problem.records.Specs` and robrst designs and certifies the sampled
        loop, whose plant is then exactly the discrete model given.

        Parameters
        ----------
        sys : control.TransferFunction or control.StateSpace
            A SISO system, continuous or discrete.
        label : str
            Name used in reports.
        temperature_C : float, optional
            Temperature [°C] at which the model holds.

        Returns
        -------
        Plant

        Raises
        ------
        SpecError
            Not SISO, an unspecified sampling period (``dt = True``), or a discrete
            pole with no continuous pre-image (real negative, or zero other than delays).

        Examples
        --------
        >>> import control
        >>> Pd = control.c2d(control.tf([2.0], [1.0, 3.0]), 0.1)    # ZOH at 10 Hz
        >>> p = Plant.from_control(Pd)
        >>> [round(float(c), 9) for c in (*p.B, *p.A)], p.meta["sample_rate_hz"]
        ([2.0, 1.0, 3.0], 10.0)
        """
        import control

        from robrst.core import lti

        if not isinstance(sys, (control.TransferFunction, control.StateSpace)):
            raise SpecError(f"from_control: expected a control.TransferFunction or StateSpace,"
                            f" got {type(sys).__name__}")
        if sys.ninputs != 1 or sys.noutputs != 1:
            raise SpecError(f"from_control: only SISO systems are supported"
                            f" ({sys.ninputs} inputs, {sys.noutputs} outputs)")
        dt = sys.dt
        kw = dict(label=label, temperature_C=temperature_C)
        if dt is True:
            raise SpecError("from_control: discrete system with an unspecified sampling period"
                            " (dt = True); give dt in seconds")
        if dt in (0, None):
            if isinstance(sys, control.TransferFunction):
                return cls(sys.num[0][0], sys.den[0][0], **kw)
            return cls(*lti.ss_to_poly(sys.A, sys.B, sys.C, sys.D), **kw)
        if isinstance(sys, control.StateSpace) and np.all(np.abs(np.linalg.eigvals(sys.A)) > DELAY_TOL):
            A, B, C, d = sys.A, sys.B, sys.C, float(np.asarray(sys.D).ravel()[0])
            k = 0
        else:
            tf = control.tf(sys) if isinstance(sys, control.StateSpace) else sys
            num, den, k = _strip_delay(poly.trim(tf.num[0][0]), poly.trim(tf.den[0][0]))
            A, B, C, d = lti.companion(num, den, poly.Scaling(1.0))
        try:
            Ac, Bc = lti.d2c(A, B, dt)
        except ValueError as exc:
            raise SpecError(f"from_control: {exc}") from None
        plant = cls(*lti.ss_to_poly(Ac, Bc, C, d), **kw)
        meta = {"sample_rate_hz": 1.0 / float(dt), "delay_samples": k,
                "source": "inverse zero-order hold of a discrete model"}
        return Plant(plant.B, plant.A, meta=meta, **kw)

    def to_tf(self) -> control.TransferFunction:
        """Return the model as a ``control.TransferFunction``.

        Returns
        -------
        control.TransferFunction
            ``B(s)/A(s)``, continuous.
        """
        import control

        return control.tf(self.B, self.A)

    def with_label(self, label: str, temperature_C: float | None = None) -> Plant:
        """The same model under another label (and temperature); ``meta`` is kept.

        Parameters
        ----------
        label : str
            The new label.
        temperature_C : float, optional
            The new temperature [°C] (``None``: none).

        Returns
        -------
        Plant
        """
        return Plant(self.B, self.A, label=label, temperature_C=temperature_C, meta=self.meta)


DELAY_TOL = 1e-9   # a discrete pole (or trailing coefficient) this small is a pure delay


def _strip_delay(num, den):
    """``num/den`` in z as ``z^-k num'/den'`` with ``den'(0) != 0``; returns ``(num', den', k)``.

    Trailing coefficients below ``DELAY_TOL`` of the largest count as zero (a delay
    realised in state space comes back with round-off there).
    """
    num, den = (np.where(np.abs(c) <= DELAY_TOL * np.max(np.abs(c)), 0.0, c) for c in (num, den))
    tz = lambda c: len(c) - 1 - int(np.flatnonzero(c)[-1])    # noqa: E731  (roots at z = 0)
    common = min(tz(num), tz(den))
    num, den = num[:len(num) - common], den[:len(den) - common]
    k = tz(den)
    den = den[:len(den) - k]
    if len(num) > len(den):
        raise SpecError("from_control: the discrete model is not a delayed zero-order-hold"
                        " model (its numerator outgrows the denominator once the delay is"
                        " removed)")
    return num, den, k


def is_control_system(obj: object) -> bool:
    """Whether ``obj`` is a python-control ``TransferFunction`` or ``StateSpace``.

    Parameters
    ----------
    obj : object
        Anything (python-control is imported only for objects of its own).

    Returns
    -------
    bool
    """
    if type(obj).__module__.split(".")[0] != "control":
        return False
    import control

    return isinstance(obj, (control.TransferFunction, control.StateSpace))


def as_plant(obj: object, what: str = "plant") -> Plant:
    """``obj`` as a :class:`Plant`: a Plant as it is, a SISO python-control
    ``TransferFunction`` or ``StateSpace`` through :meth:`Plant.from_control` (a discrete
    one is its continuous pre-image, its rate and delay in ``meta``).

    Parameters
    ----------
    obj : Plant or control.TransferFunction or control.StateSpace
    what : str
        Named in the error (the argument's name).

    Returns
    -------
    Plant

    Raises
    ------
    SpecError
        Anything else (a MIMO system, an array, a name), naming ``what`` and the type.

    Examples
    --------
    >>> import control
    >>> as_plant(control.tf([2.0], [1.0, 3.0])).A.tolist()
    [1.0, 3.0]
    """
    if isinstance(obj, Plant):
        return obj
    if is_control_system(obj):
        return Plant.from_control(obj)
    raise SpecError(f"{what}: expected a robrst Plant or a SISO python-control TransferFunction"
                    f" or StateSpace, got {type(obj).__name__}")


def paper_plant() -> Plant:
    """The identified actuator model D(s) of eq. (4) of the paper.

    ``D(s) = 107 (s^2 + 1.4e4 s + 6.1e7) / ((s + 651)(s^2 + 42 s + 1.5e7))``:
    static gain 0.668 µm/V, a lightly damped resonance at sqrt(1.5e7) rad/s
    (616 Hz, damping 0.0054).

    Returns
    -------
    Plant
        Labelled ``"paper_D"``.

    Examples
    --------
    >>> from robrst.core.plant import paper_plant
    >>> round(float(paper_plant().dc_gain), 3)
    0.668
    """
    B = 107.0 * np.array([1.0, 1.4e4, 6.1e7])
    A = poly.pmul([1.0, 651.0], [1.0, 42.0, 1.5e7])
    return Plant(B, A, label="paper_D", meta={"source": "paper eq. (4)"})


NAMED_PLANTS = {"paper": paper_plant}


def named_plant(name: str) -> Plant:
    """Look up a built-in plant by name (``"paper"``).

    Parameters
    ----------
    name : str
        A key of ``NAMED_PLANTS``.

    Returns
    -------
    Plant

    Raises
    ------
    SpecError
        For an unknown name, listing the known ones.
    """
    try:
        return NAMED_PLANTS[name]()
    except KeyError:
        raise SpecError(
            f"unknown plant name {name!r}; expected one of {sorted(NAMED_PLANTS)}"
        ) from None
