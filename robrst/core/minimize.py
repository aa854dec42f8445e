"""One-dimensional minimisation without derivatives: golden-section search.

Used where a scalar function is cheap to bracket but has no gradient: the refinement of a
clipping limit (:mod:`robrst.diagnose._thermal`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["golden_section"]


def golden_section(f: Callable[[float], float], a: float, b: float,
                   n: int) -> tuple[float, float]:
    """Golden-section search of ``f`` on ``[a, b]`` with ``n`` evaluations.

    Parameters
    ----------
    f : callable
        The function to minimise (unimodal on ``[a, b]`` for the minimum to be found).
    a, b : float
        The interval, ``a <= b``.
    n : int
        Evaluations of ``f`` (at least 2).

    Returns
    -------
    (float, float)
        The better of the last two points and its value.

    Examples
    --------
    >>> x, fx = golden_section(lambda x: (x - 0.3) ** 2, 0.0, 1.0, 30)
    >>> round(x, 4)
    0.3
    """
    r = (np.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = b - r * (b - a), a + r * (b - a)
    f1, f2 = f(x1), f(x2)
    for _ in range(max(n - 2, 0)):
        if f1 <= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - r * (b - a)
            f1 = f(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + r * (b - a)
            f2 = f(x2)
    return (float(x1), f1) if f1 <= f2 else (float(x2), f2)
