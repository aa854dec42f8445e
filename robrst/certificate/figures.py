"""The certificate's typed records: the figures of one loop, and of one model.

A model of the family is checked in its continuous loop and, when the specs name a
sampling rate, in its sampled loop (:mod:`robrst.core.sampled`): one
:class:`ModelRecord` holds both as two :class:`LoopFigures` (the same record type, used
twice).  The records carry no suffixed keys: a loop is a field (``record.sampled.Ms``) or an
argument (``record.value("Ms", "sampled")``).  The published names (``"Ms"``,
``"Ms_sampled"``, ...) of the JSON contract are produced at the edge only
(:mod:`robrst.design.contract`; :func:`figure_key` names the keys of
:meth:`robrst.certificate.proof.Certificate.ratios` and of the refinement's margins).
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["StepFigures", "LoopFigures", "ModelRecord", "LOOPS", "figure_key", "parse_key"]

LOOPS = ("continuous", "sampled")
_SUFFIX = {"continuous": "", "sampled": "_sampled"}


def figure_key(name: str, loop: str = "continuous") -> str:
    """The published name of figure ``name`` of ``loop`` (``"Ms"``, ``"Ms_sampled"``).

    Parameters
    ----------
    name : str
        A figure of :class:`LoopFigures` (``"Ms"``, ``"overshoot_pct"``, ...).
    loop : str
        ``"continuous"`` or ``"sampled"``.

    Returns
    -------
    str
    """
    return name + _SUFFIX[loop]


def parse_key(key: str) -> tuple[str, str]:
    """``(figure, loop)`` of a published name (the inverse of :func:`figure_key`).

    Parameters
    ----------
    key : str
        A published name (``"Ms_sampled"``).

    Returns
    -------
    (str, str)

    Examples
    --------
    >>> parse_key("Ms_sampled"), parse_key("Ms")
    (('Ms', 'sampled'), ('Ms', 'continuous'))
    """
    if key.endswith(_SUFFIX["sampled"]):
        return key[:-len(_SUFFIX["sampled"])], "sampled"
    return key, "continuous"


@dataclass(frozen=True)
class StepFigures:
    """Reference-step figures of one loop (proved upper bounds,
    :mod:`robrst.certificate.steps`).

    Parameters
    ----------
    overshoot_pct : float
        Overshoot [%].
    settling_time_s : float
        2 % settling time [s].
    step_u_peak_V : float
        The largest ``|u|`` [V] for a reference step of ``specs.step_um``.
    """

    overshoot_pct: float
    settling_time_s: float
    step_u_peak_V: float

    NAMES = ("overshoot_pct", "settling_time_s", "step_u_peak_V")

    def items(self) -> list[tuple[str, float]]:
        """``(name, value)`` pairs in the published order.

        Returns
        -------
        list of (str, float)
        """
        return [(k, getattr(self, k)) for k in self.NAMES]


@dataclass(frozen=True)
class LoopFigures:
    """Every figure the certificate computes for one closed loop of one model.

    Parameters
    ----------
    spectral_abscissa : float
        Largest real part of the closed-loop roots [rad/s] (of the loop's own variable:
        the bilinear variable for a sampled loop; ``inf`` for a sampled loop that lost
        degree, a pole at ``z = -1``).
    stable : bool
    distance_to_instability : float or None
        Relative distance of ``A S + B R`` to a polynomial with an imaginary-axis root.
    closed_loop_degree : int
    Ms, Mt, Mu : float
        Exact global peaks of ``|S|``, ``|T|``, ``|U|`` [V/µm].
    Ms_freq_rad_s, Mt_freq_rad_s, Mu_freq_rad_s : float or None
        Where they are (physical frequency; ``None``: at infinity).
    Mt_resonance_band, Mt_resonance_band_freq_rad_s : float or None
        The peak of ``|T|`` over the resonance band (when the specs bound it).
    Mu_hf : float or None
        The peak of ``|U|`` above the corner of ``Mu_hf_max`` (when bounded).
    step : StepFigures or None
        Reference-step figures (time-domain specs, stable loops).
    Msd, Msd_freq_rad_s : float or None
        Exact peak of the input-disturbance sensitivity ``|B S / Delta|`` [µm/V] (when
        ``Msd_max`` bounds it).
    Mry, Mry_freq_rad_s : float or None
        Exact peak of the reference-to-output ``|B T / Delta|`` (when ``Mry_max`` bounds it).
    damping, decay_rad_s : float or None
        Least damping and least decay rate ``-Re p`` [rad/s] of the loop's poles (a sampled
        loop's mapped to s by ``fs ln z``), when a pole region is checked.
    Msd_rel : float or None
        ``Msd`` over the loop's open-loop peak ``open_loop_peak`` (when ``Msd_rel_max``
        bounds it).
    open_loop_peak : float or None
        The exact peak of the loop's own plant ``|B / A|`` [µm/V] (the zero-order-hold
        plant's in the sampled loop; ``inf`` for a plant with a pole on the axis).
    """

    spectral_abscissa: float
    stable: bool
    distance_to_instability: float | None
    closed_loop_degree: int
    Ms: float
    Ms_freq_rad_s: float | None
    Mt: float
    Mt_freq_rad_s: float | None
    Mu: float
    Mu_freq_rad_s: float | None
    Mt_resonance_band: float | None = None
    Mt_resonance_band_freq_rad_s: float | None = None
    Mu_hf: float | None = None
    step: StepFigures | None = None
    Msd: float | None = None
    Msd_freq_rad_s: float | None = None
    Mry: float | None = None
    Mry_freq_rad_s: float | None = None
    damping: float | None = None
    decay_rad_s: float | None = None
    Msd_rel: float | None = None
    open_loop_peak: float | None = None

    def value(self, name: str) -> float | bool | None:
        """Figure ``name`` (a field, or a step figure).

        Parameters
        ----------
        name : str
            The figure.

        Returns
        -------
        float, bool or None
            ``None`` when not computed.
        """
        if name in StepFigures.NAMES:
            return None if self.step is None else getattr(self.step, name)
        return getattr(self, name, None)


@dataclass(frozen=True, eq=False)
class ModelRecord:
    """One checked model: its continuous loop and (with a sampling rate) its sampled loop.

    Parameters
    ----------
    label : str
    temperature_C : float
    continuous : LoopFigures
    sampled : LoopFigures or None
        The exact sampled loop's figures (``None``: no sampling rate in the specs).
    extra : dict
        Figures of the certificate's extra checks (``checks`` hooks), by name.
    margins : dict
        ``{name: (value, limit)}`` of the hooks, refined over the interval like the others.
    family_member : bool or None
        True for a member of the family, false for a sweep or refinement point
        (``None``: a record not placed by :func:`robrst.certificate.proof.certify`).
    steps_checked_after : bool
        The step figures were computed after the certificate's sweep, on its checked
        points (:func:`robrst.certificate.completion.with_time_domain`); they are published after
        ``family_member``, where that path has always put them.
    actuator : int
        The actuator the model belongs to: 0 the nominal one, ``k`` further actuator ``k``
        of a fleet design (:func:`robrst.certificate.proof.certify_families`; published
        as ``"actuator"`` only then).
    """

    label: str
    temperature_C: float
    continuous: LoopFigures
    sampled: LoopFigures | None = None
    extra: dict = field(default_factory=dict)
    margins: dict = field(default_factory=dict)
    family_member: bool | None = None
    steps_checked_after: bool = False
    actuator: int = 0

    def loop(self, loop: str) -> LoopFigures | None:
        """The figures of ``loop``.

        Parameters
        ----------
        loop : {"continuous", "sampled"}
            Which loop.

        Returns
        -------
        LoopFigures or None
        """
        return self.continuous if loop == "continuous" else self.sampled

    def loops(self) -> list[tuple[str, LoopFigures]]:
        """``(loop name, LoopFigures)`` of every loop checked.

        Returns
        -------
        list of (str, LoopFigures)
        """
        return [(k, lf) for k, lf in (("continuous", self.continuous),
                                      ("sampled", self.sampled)) if lf is not None]

    @property
    def stable(self) -> bool:
        """True when every loop checked is stable."""
        return all(lf.stable for _, lf in self.loops())

    def value(self, name: str, loop: str = "continuous") -> float | bool | None:
        """Figure ``name`` of ``loop`` (a hook's figure by its own name).

        Parameters
        ----------
        name : str
            The figure.
        loop : {"continuous", "sampled"}
            Which loop.

        Returns
        -------
        float, bool or None
            ``None`` when not computed.
        """
        lf = self.loop(loop)
        got = None if lf is None else lf.value(name)
        return self.extra.get(figure_key(name, loop)) if got is None else got
