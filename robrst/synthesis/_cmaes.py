"""A small CMA-ES (covariance matrix adaptation evolution strategy) in the unit box.

Hansen's (mu/mu_w, lambda)-CMA-ES ("The CMA Evolution Strategy: A Tutorial",
arXiv:1604.00772, the default parameters of its table 1) on ``[0, 1]^d``: samples that
leave the box are reflected back into it.  On request the covariance update is *active*
(the tutorial's negative weights, Jastrebski and Arnold 2006): the worse half of the
population shrinks the variance along its directions.  Ranked by feasibility first, the
infeasible samples thus teach the distribution the constraints' normals, and it stretches
along the boundary where a constrained optimum lies (Arnold and Hansen 2012 use the same
update for constraint handling); the plain update only learns where the good samples
are, and a run on a constraint's ridge creeps.  Only the *ranking* of the candidates
enters the update, so the strategy is invariant to monotone transformations of the
objective, and the adapted covariance makes it invariant to rotations and scalings of the
search space: a badly conditioned landscape costs evaluations, not failure.  Constraints
enter through the ranking (the caller orders the population, e.g. by Deb's feasibility
rules: feasible candidates by objective, then the others by violation).

The strategy is driven by the caller: :meth:`CMAES.ask` returns a population,
:meth:`CMAES.tell` takes its ranking.  So a search loop evaluates a whole population at
once (vectorised, or on a cluster), and can stop after any generation.  Every random
number comes from the generator it is given.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CMAES"]


class CMAES:
    """One run of the strategy (module docstring).

    Parameters
    ----------
    mean : numpy.ndarray
        The initial mean, in ``[0, 1]^d``.
    sigma : float
        The initial step size (a share of the box).
    rng : numpy.random.Generator
        The random numbers.
    popsize : int, optional
        ``lambda`` (default ``4 + floor(3 ln d)``).
    active : bool, optional
        The active covariance update (module docstring); false: the plain rank-mu update.

    Attributes
    ----------
    sigma : float
        The current step size.
    mean : numpy.ndarray
        The current mean.
    generation : int
        Generations told so far.
    """

    def __init__(self, mean: np.ndarray, sigma: float, rng: np.random.Generator,
                 popsize: int | None = None, active: bool = False) -> None:
        d = len(mean)
        self.d, self.rng = d, rng
        self.lam = int(popsize or 4 + int(3 * np.log(d)))
        self.mu = self.lam // 2
        w = np.log(self.mu + 0.5) - np.log(np.arange(1, self.mu + 1))
        self.w = w / w.sum()
        self.mueff = 1.0 / np.sum(self.w ** 2)
        mueff = self.mueff
        self.cc = (4 + mueff / d) / (d + 4 + 2 * mueff / d)
        self.cs = (mueff + 2) / (d + mueff + 5)
        self.c1 = 2 / ((d + 1.3) ** 2 + mueff)
        self.cmu = min(1 - self.c1, 2 * (mueff - 2 + 1 / mueff) / ((d + 2) ** 2 + mueff))
        self.damps = 1 + 2 * max(0.0, np.sqrt((mueff - 1) / (d + 1)) - 1) + self.cs
        # the rank-mu weights of every place: the mean's, then (active) the tutorial's
        # negative ones, scaled so that the update keeps C positive definite (its eq. 53)
        neg = np.log((self.lam + 1) / 2) - np.log(np.arange(self.mu + 1, self.lam + 1))
        if active:          # (lambda >= 4: mu >= 2 places below the mean's, all negative)
            mueff_neg = neg.sum() ** 2 / np.sum(neg ** 2)
            scale = min(1 + self.c1 / self.cmu, 1 + 2 * mueff_neg / (mueff + 2),
                        (1 - self.c1 - self.cmu) / (d * self.cmu))
            neg = neg * scale / np.abs(neg).sum()
        else:
            neg = np.zeros(self.lam - self.mu)
        self.weights = np.concatenate([self.w, neg])
        self.chi = np.sqrt(d) * (1 - 1 / (4 * d) + 1 / (21 * d * d))
        self.mean = np.clip(np.asarray(mean, float), 0.0, 1.0)
        self.sigma = float(sigma)
        self.C, self.pc, self.ps = np.eye(d), np.zeros(d), np.zeros(d)
        self.generation = 0
        self._B, self._D = np.eye(d), np.ones(d)
        self._root = np.eye(d)

    def ask(self) -> np.ndarray:
        """A population, ``(lambda, d)`` in ``[0, 1]^d`` (reflected at the faces).

        Returns
        -------
        numpy.ndarray
        """
        z = self.rng.standard_normal((self.lam, self.d))
        # the symmetric square root B D B' of the covariance, not B D: the same distribution,
        # but unique where eigenvalues repeat (C = I at first, and after a rank-mu update
        # most of its eigenvalues are equal), so the samples do not hang on which
        # eigenvectors the LAPACK build returns for a repeated eigenvalue
        x = self.mean + self.sigma * z @ self._root
        x = np.abs(x) % 2.0
        return np.where(x > 1.0, 2.0 - x, x)

    def tell(self, X: np.ndarray, order: np.ndarray) -> None:
        """Update the distribution from the population ``X`` ranked by ``order`` (indices,
        best first).

        Parameters
        ----------
        X : numpy.ndarray
            The population :meth:`ask` returned.
        order : numpy.ndarray
            Its indices from the best candidate to the worst.
        """
        d, cs, cc = self.d, self.cs, self.cc
        old = self.mean
        ys = (X[np.asarray(order)] - old) / self.sigma          # every place, best first
        yw = self.w @ ys[:self.mu]
        self.mean = old + self.sigma * yw
        inv = self._B @ np.diag(1.0 / self._D) @ self._B.T
        self.ps = (1 - cs) * self.ps + np.sqrt(cs * (2 - cs) * self.mueff) * inv @ yw
        self.generation += 1
        norm = np.linalg.norm(self.ps) / np.sqrt(1 - (1 - cs) ** (2 * self.generation))
        hs = norm / self.chi < 1.4 + 2 / (d + 1)
        self.pc = (1 - cc) * self.pc + hs * np.sqrt(cc * (2 - cc) * self.mueff) * yw
        # a negative weight acts on the sample's Mahalanobis direction at length sqrt(d)
        # (the tutorial's w_i o): a far outlier does not take the variance away
        w = self.weights.copy()
        neg = w < 0
        if neg.any():
            z = ys[neg] @ inv
            w[neg] *= d / np.maximum(np.sum(z * z, axis=1), 1e-300)
        self.C = ((1 - self.c1 - self.cmu * self.weights.sum()) * self.C
                  + self.c1 * (np.outer(self.pc, self.pc) + (1 - hs) * cc * (2 - cc) * self.C)
                  + self.cmu * (ys.T * w) @ ys)
        self.sigma *= np.exp((cs / self.damps) * (np.linalg.norm(self.ps) / self.chi - 1))
        self.sigma = min(self.sigma, 0.5)
        self.C = (self.C + self.C.T) / 2
        ev, self._B = np.linalg.eigh(self.C)
        self._D = np.sqrt(np.maximum(ev, 1e-20))
        self._root = (self._B * self._D) @ self._B.T

    @property
    def spread(self) -> float:
        """The largest standard deviation of the search distribution (box units).

        Returns
        -------
        float
        """
        return float(self.sigma * np.max(self._D))
