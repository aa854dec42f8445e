"""Synthetic worlds for the forward selection: the gap of any set of candidates, by
construction, so the selection's logic (:func:`robrst.diagnose._select.select_effects`) and
the verdict (:func:`robrst.diagnose._verdict.decide`) run in milliseconds on seeded
multi-effect cases.

A world has a noise floor, a linear model error the linear re-fit removes, and *true*
effects, each with its share of the gap.  A candidate explains a true effect fully when it
is that effect, or a share ``q`` of it when it stands in for it (``q = 1``: the records
cannot tell the two apart, a tie).  The held-out gap of a set ``S`` is

    sqrt(floor^2 + sum_e c_e^2 (1 - cover_S(e)))

(``cover_S(e)`` the largest share any member of ``S`` explains), times a small seeded
factor per set (a fit's own scatter); the training gap likewise.  Screens are the same
gaps with a larger scatter (first order).  Some sets' fits from the smaller set's start
are stuck (a training gap three times too high) until fitted again from fresh starts
(``stuck_on_top``: only from every effect's first screen, not from the screen on top of
the stuck set).
"""

from dataclasses import dataclass, field
from types import SimpleNamespace
import zlib

import numpy as np

from robrst.diagnose.candidates import Scored

LIBRARY = ("hysteresis", "creep", "thermal_drift", "saturation", "input_nonlinearity",
           "slew", "delay", "output_offset", "output_nonlinearity",
           "amplitude_dependent_dynamics", "stiffness_nonlinearity")


@dataclass
class World:
    floor: float
    linear_error: float
    true: dict                       # effect -> its gap component
    stands_in: dict                  # (candidate, effect) -> share of it explained
    scatter: float = 0.01            # a fit's own scatter (relative)
    screen_scatter: float = 0.05
    stuck: frozenset = frozenset()   # sets whose fit from the smaller set is stuck
    seed: int = 0
    stuck_on_top: frozenset = frozenset()   # ... and from the screen on top of it too

    def cover(self, S, e):
        return max([1.0 if e in S else 0.0] + [self.stands_in.get((c, e), 0.0) for c in S])

    def _noise(self, S, what, size):
        key = zlib.crc32(("|".join(sorted(S)) + what).encode()) ^ self.seed
        return 1.0 + size * np.random.default_rng(key).uniform(-1, 1)

    def gap(self, S, what="test", size=None):
        left = sum(c * c * (1.0 - self.cover(S, e)) ** 2 for e, c in self.true.items())
        g = np.sqrt(self.floor ** 2 + left)
        return float(g * self._noise(S, what, self.scatter if size is None else size))

    def before(self, what="test"):
        """The model as given: the linear error on top of every effect."""
        return float(np.sqrt(self.gap((), what, 0.0) ** 2 + self.linear_error ** 2))

    def info(self):
        """What :func:`robrst.diagnose._verdict.decide` reads of a diagnosis."""
        return {"before": self.before(), "floor": self.floor,
                "before_train": self.before("train"), "floor_train": self.floor,
                "band": None, "regime": {}, "train_levels": [], "duration_s": 6.0}


def random_world(seed):
    """A seeded world: 0-3 true effects, stand-ins (some exact: ties), stuck fits."""
    rng = np.random.default_rng(seed)
    n_true = int(rng.integers(0, 4))
    true = {str(e): float(rng.uniform(0.005, 0.3))
            for e in rng.choice(LIBRARY[:8], size=n_true, replace=False)}
    stands_in = {}
    for e in true:
        for c in rng.choice(LIBRARY, size=int(rng.integers(0, 3)), replace=False):
            if c != e:
                stands_in[(str(c), e)] = float(rng.choice([1.0, rng.uniform(0.3, 0.95)]))
    if "saturation" in true and rng.random() < 0.7:        # the general map covers it
        stands_in[("input_nonlinearity", "saturation")] = 1.0
    if "output_offset" in true and rng.random() < 0.7:
        stands_in[("output_nonlinearity", "output_offset")] = 1.0
    stuck = frozenset(frozenset(rng.choice(list(true), size=2, replace=False))
                      for _ in range(int(rng.integers(0, 2))) if len(true) >= 2)
    return World(floor=float(rng.uniform(0.002, 0.02)),
                 linear_error=float(rng.uniform(0.0, 0.2)), true=true, stands_in=stands_in,
                 stuck=stuck, seed=seed)


def _scored(keys, gap, train_gap, form="input"):
    keys = tuple(sorted(keys))
    return Scored(name="+".join(keys) or "linear", fit=SimpleNamespace(n_eval=1), gap=gap,
                  train_gap=train_gap, residuals=[], fit_s=0.0, keys=keys, form=form)


@dataclass
class FakeFits:
    """The methods of :class:`robrst.diagnose.candidates.CandidateFits` on a world."""

    world: World
    fitted: dict = field(default_factory=dict)
    calls: list = field(default_factory=list)

    def __post_init__(self):
        w = self.world
        self.floor = w.floor
        self.linear = _scored((), w.gap(()), w.gap((), "train"))   # the re-fit: no linear error
        self.keys = list(LIBRARY)

    def _screen(self, S):
        w = self.world
        return SimpleNamespace(gap=w.gap(S, "screen", w.screen_scatter),
                               train_gap=w.gap(S, "screen-train", w.screen_scatter), beta={})

    def alone(self):
        return {k: self._screen((k,)) for k in self.keys}

    def start_of(self, key):
        return {f"{key}:first": 1.0}

    def first(self, pool):
        base = self._screen(())
        return ({k: self._screen((k,)) for k in pool}, {k: base for k in pool},
                {k: {} for k in pool})

    def on_top(self, state, pool):
        S = state.keys
        # the screen on top of a set starts where its fit is (a stuck fit's gap)
        base = SimpleNamespace(gap=state.gap, train_gap=state.train_gap, beta={})
        return ({k: self._screen(S + (k,)) for k in pool}, {k: base for k in pool},
                {k: {f"{k}:on_top": 1.0} for k in pool})

    def _fit(self, keys, stuck_ok):
        w = self.world
        S = tuple(sorted(keys))
        g, t = w.gap(S), w.gap(S, "train")
        if stuck_ok and frozenset(S) in w.stuck:
            g, t = 2.0 * g, 3.0 * t
        return _scored(S, g, t)

    def fit(self, keys, start, form=None):
        ks = tuple(sorted(keys))
        self.calls.append(("fit", ks))
        if ks not in self.fitted:
            self.fitted[ks] = self._fit(ks, True)
        return self.fitted[ks]

    def fit_many(self, jobs):
        return [self.fit(*j) for j in jobs]

    def refit(self, keys, start, form=None):
        self.calls.append(("refit", tuple(sorted(keys))))
        # a start from the screen on top of the stuck set lies in its basin (stuck_on_top)
        on_top = any(k.endswith(":on_top") for k in start)
        return self._fit(keys, on_top and frozenset(keys) in self.world.stuck_on_top)

    def converge(self, sc):
        self.fitted[tuple(sorted(sc.keys))] = sc
        return sc

    def remember(self, sc):
        self.fitted[tuple(sorted(sc.keys))] = sc
