"""Stacked linear recurrences by repeated doubling: the propagation kernel of
:mod:`robrst.certificate._stepgrid`.

``x[k + 1] = Phi x[k] + G`` is advanced by doubling (``x[k + m] = Phi**m x[k] + S_m``,
``S_m = sum_{i<m} Phi**i G``): a handful of matrix products for many steps, stacked over
many ``Phi`` (:func:`propagate`); whole powers by binary powering (:func:`power`,
:func:`power_all`).
"""

import numpy as np

__all__ = ["propagate", "power", "power_all"]


def propagate(Phi, G, x0, n):
    """States ``x[0..n]`` of ``x[k+1] = Phi x[k] + G`` by doubling, stacked.

    Parameters
    ----------
    Phi, G, x0 : ndarray
        Shapes ``(J, m, m)``, ``(J, m)``, ``(J, m)``.
    n : int
        Number of steps.

    Returns
    -------
    ndarray
        Shape ``(J, m, n + 1)``: the states as columns.
    """
    X = np.empty(x0.shape + (n + 1,))
    X[..., 0] = x0
    P, S, m = Phi, G[..., None], 1     # P = Phi**m, S = sum_{i<m} Phi**i G
    while m <= n:
        k = min(m, n + 1 - m)
        X[..., m:m + k] = P @ X[..., :k] + S
        S = P @ S + S
        P = P @ P
        m *= 2
    return X


def power(Phi, G, m, of):
    """``(Phi**m, sum_{i<m} Phi**i G)`` by binary powering, for several powers of each of
    stacked ``Phi``.

    The powers ``Phi**(2**b)`` are computed once per slice of ``Phi`` (stacked); each
    requested power is then the product of those of its bits, lowest first.

    Parameters
    ----------
    Phi, G : ndarray
        Shapes ``(K, n, n)`` and ``(K, n)``.
    m : sequence of int
        The requested powers (``>= 1``).
    of : sequence of int
        For each, its slice of ``Phi`` and ``G``.

    Returns
    -------
    P, S : ndarray
        Shapes ``(J, n, n)`` and ``(J, n)``, one per requested power.
    """
    m, of = [int(v) for v in m], [int(k) for k in of]
    table = [(Phi, G[..., None])]      # Phi**(2**b), sum_{i<2**b} Phi**i G
    for _ in range(max(m).bit_length() - 1):
        Pk, Sk = table[-1]
        table.append((Pk @ Pk, Pk @ Sk + Sk))
    P, S = [], []
    for mj, k in zip(m, of):
        b = (mj & -mj).bit_length() - 1          # the lowest bit: Pk @ I, Pk @ 0 + Sk
        Pj, Sj = table[b][0][k], table[b][1][k]
        mj >>= b + 1
        while mj:
            b += 1
            if mj & 1:
                Pk, Sk = table[b][0][k], table[b][1][k]
                Pj, Sj = Pk @ Pj, Pk @ Sj + Sk
            mj >>= 1
        P.append(Pj)
        S.append(Sj[:, 0])
    return np.stack(P), np.stack(S)


def power_all(Phi, G, m):
    """``(Phi**m, sum_{i<m} Phi**i G)`` of every slice of stacked ``Phi`` for one power
    ``m >= 1``, by binary powering.

    Parameters
    ----------
    Phi, G : ndarray
        Shapes ``(K, n, n)`` and ``(K, n)``.
    m : int

    Returns
    -------
    P, S : ndarray
        Of the shapes of ``Phi`` and ``G``.
    """
    P = S = None
    base, bS = Phi, G
    while m:
        if m & 1:       # the powers commute: (base, bS) after (P, S)
            P, S = (base, bS) if P is None else (base @ P, (base @ S[..., None])[..., 0] + bS)
        m >>= 1
        if m:
            bS, base = (base @ bS[..., None])[..., 0] + bS, base @ base
    return P, S
