"""The controller's fixed factors: does a controller have the structure its problem asks for?

A problem fixes factors of the controller (:class:`~robrst.problem.records.ControllerStructure`):
``S = S_fixed S'`` with the integrator ``s`` (and the roll-off ``(s/wc + 1)**order``),
``R = R_fixed R'``.  A synthesised controller has them by construction; a controller read
back from a file (a saved design edited by hand, another design certified on this problem)
need not.  Its peaks and stability are still what the certificate computes, but figures
whose premise is a factor (the integral gain is ``lim s R/S`` only with the integrator; a
step's zero static error) and the problem's intent are not: :func:`structure_violations`
names each fixed factor the controller lacks, and :func:`robrst.certificate.proof.certify_problem`
adds them to the certificate (kind ``"structure"``: never certified).

A factor's roots at ``s = 0`` are counted by :func:`robrst.core.poly.origin_roots` (zero
within rounding); its other roots by the remainder of the division by the factor, in the
variable scaled at the factor's roots, relative to the polynomial (``REMAINDER_RTOL``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robrst.core import poly
from robrst.certificate.models import Violation

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from robrst.core.rst import RSTController
    from robrst.problem.records import ControllerStructure

__all__ = ["structure_violations", "REMAINDER_RTOL", "STRUCTURE"]

REMAINDER_RTOL = 1e-9     # a factor divides when the remainder is below this (scaled, relative)
STRUCTURE = "structure"   # the violations' kind


def _remainder(c, f):
    """Relative remainder of ``c`` divided by ``f`` (no root at 0), in ``p = s / w`` with
    ``w`` the geometric mean modulus of ``f``'s roots."""
    w = poly.natural_scale(f)
    cs, fs = poly.to_scaled(c, w), poly.to_scaled(f, w)
    if len(cs) < len(fs):
        return np.inf
    _, rem = np.polydiv(cs / np.max(np.abs(cs)), fs / np.max(np.abs(fs)))
    return float(np.max(np.abs(rem))) if rem.size else 0.0


def _missing(c: ArrayLike, factor: ArrayLike) -> str | None:
    """Why ``factor`` does not divide ``c`` (``None`` when it does)."""
    c, f = poly.trim(c), poly.trim(factor)
    if len(f) <= 1:
        return None
    j = poly.origin_roots(f, 0.0)                 # the factor's integrators: exact zeros
    k = poly.origin_roots(c)
    if k < j:
        what = "the integrator s" if j == 1 else f"s^{j} ({j} roots at s = 0)"
        return (f"lacks {what}: {'its value at s = 0 is' if k == 0 else 'it has'}"
                + (f" {c[-1]:.6g}" if k == 0 else f" {k} root(s) at 0"))
    f0 = f[:len(f) - j]
    c0 = c[:len(c) - j] if j else c
    if len(f0) > 1:
        rel = _remainder(c0, f0)
        if not rel <= REMAINDER_RTOL:
            roots = ", ".join(f"{r:.4g}" for r in np.roots(f0))
            return (f"is not divisible by the fixed factor (roots {roots} rad/s): relative"
                    f" remainder {rel:.3g}")
    return None


def structure_violations(structure: ControllerStructure,
                         ctrl: RSTController) -> list[Violation]:
    """The fixed factors of ``structure`` that ``ctrl`` lacks, as certificate violations.

    Parameters
    ----------
    structure : ControllerStructure
        The problem's controller structure: ``S_total`` (``S_fixed`` with the integrator,
        times the roll-off) must divide ``S``, ``R_fixed`` must divide ``R``.
    ctrl : RSTController
        The controller (its feedback polynomials ``R`` and ``S``).

    Returns
    -------
    list of Violation
        One per polynomial lacking its factor: label ``"controller"``, kind
        ``"structure"``, the reason in ``quantity``; empty when the controller has the
        structure.

    Examples
    --------
    >>> from robrst.core.rst import RSTController
    >>> from robrst.problem.records import ControllerStructure
    >>> bad = RSTController([2.0, 1.0], [1.0, 3.0, 5.0], [1.0])      # S(0) = 5: no integrator
    >>> [v.kind for v in structure_violations(ControllerStructure(), bad)]
    ['structure']
    """
    out = []
    for name, c, f, key in (("S", ctrl.S, structure.S_total, "S_fixed"),
                            ("R", ctrl.R, structure.R_fixed, "R_fixed")):
        why = _missing(c, f)
        if why is not None:
            out.append(Violation(
                "controller", float("nan"),
                f"controller structure: {name} {why}; the problem fixes {key}"
                + (" with the roll-off" if name == "S" and structure.roll_off_order else "")
                + f" = {[float(x) for x in poly.trim(f)]} ({name} = {key} {name}'): this"
                " controller is not of the problem's structure", 0.0, 0.0, None,
                kind=STRUCTURE))
    return out
