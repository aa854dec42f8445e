"""What a certificate proved over the temperature interval, and its bounds: typed records.

:class:`IntervalRecord` is the certificate's ``interval``: how stability and the peaks
were established between the checked temperatures (a proof per segment,
:class:`IntervalProof` of :class:`SegmentProof`, or a refined sweep), at what resolution,
and what the pole region's verdict covers (:class:`PoleRegionStatement`).
:class:`Bound` is one bound the certificate checked; :class:`ControllerPoles` the
controller's own poles (``controller_damping_min``).  The JSON contract writes them
(:mod:`robrst.design.contract`); the fields are listed in the documentation's *What a
certificate proves*.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SegmentProof", "IntervalProof", "PoleRegionStatement", "IntervalRecord", "Bound",
           "ControllerPoles"]


@dataclass(frozen=True)
class SegmentProof:
    """The proof on one segment of the temperature interval.

    Parameters
    ----------
    range_C : tuple of float
        The segment ``(a, b)`` [°C].
    proved : bool
        No closed-loop root crosses the boundary on it.
    test : str, optional
        The region test (``"damping"``, ``"decay"``) of a pole-region proof.
    nodes : int, optional
        The Chebyshev nodes the proof used (``None``: not attempted, the end polynomials'
        degrees differ).
    candidate_C : float, optional
        A temperature where a crossing could not be excluded (then checked).
    """

    range_C: tuple
    proved: bool
    test: str | None = None
    nodes: int | None = None
    candidate_C: float | None = None


@dataclass(frozen=True)
class IntervalProof:
    """A proof over the interval, segment by segment (the guardian map of the closed-loop
    polynomial, or of the pole region's shifted and rotated polynomials).

    Parameters
    ----------
    proved : bool
        Every segment proved.
    parts : tuple of SegmentProof, optional
        The segments (``None``: not attempted).
    skipped : str, optional
        Why the proof was not attempted.
    """

    proved: bool
    parts: tuple | None = ()
    skipped: str | None = None


@dataclass(frozen=True)
class PoleRegionStatement:
    """What the certificate established about the closed-loop pole region.

    Parameters
    ----------
    damping_min : float or None
        The damping floor checked.
    damping_source : {"specs", "default"}
        Given, or the default floor.
    decay_min : float or None
        The decay rate checked [rad/s].
    proved_between_points : bool
        Proved between the checked temperatures (continuous loop).
    statement : str
        The verdict in one sentence.
    """

    damping_min: float | None
    damping_source: str
    decay_min: float | None
    proved_between_points: bool
    statement: str


@dataclass(frozen=True)
class IntervalRecord:
    """How the certificate covers the temperature interval.

    Parameters
    ----------
    range_C : tuple of float
        The family's interval [°C].
    stability : str
        ``"single_model"``, ``"segment_crossing"``, ``"guardian_map"`` (proved for every
        temperature) or ``"refined_sweep"``.
    peaks : str
        ``"single_model"`` or ``"refined_sweep"``.
    points : int, optional
        Temperatures checked (``None``: a single model; the fields up to ``statement``
        are then not given).
    max_spacing_C, min_spacing_C : float, optional
        The largest and smallest spacing between checked temperatures [°C].
    refine_ratio : float, optional
        An interval is halved when a figure moves by more than this share of its margin.
    sampled : str, optional
        How the sampled loop is covered (``"refined_sweep"``; ``None``: no sampled loop).
    order_change_C : tuple of tuple, optional
        Intervals across which the closed-loop degree changes.
    guardian : IntervalProof, optional
        The guardian-map proof of a parametric family.
    statement : str, optional
        What was proved, in one sentence.
    pole_region_proof : IntervalProof, optional
        The pole region's proof between the checked temperatures.
    pole_region : PoleRegionStatement, optional
        The pole region's verdict (with a damping or decay bound).
    time_domain : str, optional
        ``"checked points"``: the step figures were computed after the sweep, on its points.
    actuators : int, optional
        The actuators of a fleet certificate.
    """

    range_C: tuple
    stability: str
    peaks: str
    points: int | None = None
    max_spacing_C: float | None = None
    min_spacing_C: float | None = None
    refine_ratio: float | None = None
    sampled: str | None = None
    order_change_C: tuple = ()
    guardian: IntervalProof | None = None
    statement: str | None = None
    pole_region_proof: IntervalProof | None = None
    pole_region: PoleRegionStatement | None = None
    time_domain: str | None = None
    actuators: int | None = None


@dataclass(frozen=True)
class Bound:
    """One bound the certificate checked.

    Parameters
    ----------
    figure : str
        The figure bounded (a field of
        :class:`~robrst.certificate.figures.LoopFigures`, a step figure).
    value : float
        The bound.
    lower : bool
        A lower bound (the figure must stay above it: damping, decay).
    """

    figure: str
    value: float
    lower: bool = False


@dataclass(frozen=True)
class ControllerPoles:
    """The controller's own poles (the roots of S other than its integrators).

    Parameters
    ----------
    damping : float
        Their least damping.
    damping_min : float or None
        The bound ``controller_damping_min``.
    poles_rad_s : tuple of (float, float)
        Their real and imaginary parts [rad/s].
    """

    damping: float
    damping_min: float | None
    poles_rad_s: tuple
