"""Validation on withheld effects: twin data with one hidden effect, varied excitation.

:func:`make_case` draws, from one seed, a twin with exactly one effect switched on
(its parameters drawn around the paper's values, so the suite does not reward a
single tuning), plus sensor noise and quantisation, and four records: two for
training and two for testing with *different* excitation (steps, sines,
multisines, triangles), amplitudes, temperatures (constant or ramps) and noise
levels.  ``"none"`` cases have no effect at all.  The cases are every effect the twin
can hide (:data:`CASES`); :data:`ANSWER` maps a twin effect to the diagnosis's name for
it (a Prandtl–Ishlinskii hysteresis is ``hysteresis``).  :func:`confusion` tallies
diagnoses against the truth.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robrst.diagnose._effects import FORMS, SENSOR_EFFECTS
from robrst.twin.config import EFFECTS as TWIN_EFFECTS
from robrst.twin.config import default_twin
from robrst.twin.simulate import simulate

if TYPE_CHECKING:
    from robrst.data.dataset import Dataset

__all__ = ["CASES", "ANSWER", "excitation", "make_case", "confusion", "truth_params"]

CASES = tuple(e for e in TWIN_EFFECTS if e not in SENSOR_EFFECTS) + ("none",)
ANSWER = {c: FORMS.get(c, c) for c in CASES}      # the diagnosis's name of each case
KINDS = ("steps", "sine", "multisine", "triangle")


def excitation(kind: str, n: int, fs: float, lo: float, hi: float,
               rng: np.random.Generator) -> np.ndarray:
    """A commanded-voltage profile [V] of ``n`` samples between ``lo`` and ``hi``.

    Parameters
    ----------
    kind : str
        One of ``KINDS`` (steps, sine, multisine, triangle, ...).
    n : int
        Samples.
    fs : float
        Sampling rate [Hz].
    lo, hi : float
        The voltage range [V].
    rng : numpy.random.Generator
        The seeded generator.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    ValueError
        An unknown kind.
    """
    t = np.arange(n) / fs
    mid, amp = (lo + hi) / 2, (hi - lo) / 2
    if kind == "steps":
        u, k = np.empty(n), 0
        while k < n:
            m = int(rng.uniform(0.3, 1.5) * fs)
            u[k:k + m] = rng.uniform(lo, hi)
            k += m
        u[: int(0.05 * fs)] = lo
        return u
    if kind == "sine":
        f = rng.uniform(0.5, 8.0)
        return mid - amp * np.cos(2 * np.pi * f * t)
    if kind == "triangle":
        f = rng.uniform(0.3, 3.0)
        return lo + (hi - lo) * (1 - np.abs(2 * ((f * t) % 1.0) - 1))
    if kind == "multisine":
        fr = np.geomspace(0.5, 200.0, 24)
        ph = rng.uniform(0, 2 * np.pi, fr.size)
        s = np.sum(np.sin(2 * np.pi * fr[:, None] * t[None, :] + ph[:, None]) / np.sqrt(fr)[:, None],
                   axis=0)
        s = s / np.max(np.abs(s))
        ramp = np.minimum(t / 0.2, 1.0)
        return lo + amp * ramp * (1 + s)
    raise ValueError(f"unknown excitation {kind!r}; expected {KINDS}")


def truth_params(effect: str, rng: np.random.Generator) -> dict:
    """Effect parameters drawn around the paper's values (overrides for ``with_effects``).

    Parameters
    ----------
    effect : str
        The hidden effect (``"none"``: none).
    rng : numpy.random.Generator
        The seeded generator.

    Returns
    -------
    dict
    """
    j = lambda v, s=0.3: float(v * rng.uniform(1 - s, 1 + s))  # noqa: E731
    if effect == "hysteresis":
        b = j(0.0045)
        return {"A": j(0.45, 0.2), "B": b, "Gamma": b * rng.uniform(0.5, 1.0)}
    if effect == "creep":
        return {"per_decade": j(0.012), "per_K": j(0.05)}
    if effect == "thermal_drift":
        return {"lag_s": j(3.0), "gain_V_per_K": j(0.9), "B": j(0.1)}
    if effect == "thermal_dynamics":
        return {"gain_per_K": j(0.003), "resonance_per_K": j(-0.0005), "damping_per_K": j(0.01)}
    if effect == "delay":
        return {"seconds": float(rng.integers(2, 7)) / 5000.0}
    if effect == "saturation":
        return {"u_min": float(rng.uniform(0, 15)), "u_max": float(rng.uniform(105, 130))}
    if effect == "slew":
        return {"V_per_s": float(rng.uniform(1.0e4, 3.0e4))}
    if effect == "input_nonlinearity":
        return {"dead_zone_V": float(rng.uniform(3.0, 8.0)), "center_V": float(rng.uniform(40, 80)),
                "quadratic_per_V": float(rng.uniform(-1.0, 1.0) * 1e-3)}
    if effect == "output_nonlinearity":
        return {"center_um": float(rng.uniform(20.0, 60.0)),
                "quadratic_per_um": float(rng.choice([-1, 1]) * rng.uniform(1e-3, 3e-3))}
    if effect == "stiffness_nonlinearity":
        return {"cubic_per_um2": float(rng.uniform(1.5e-6, 3e-6))}
    if effect == "pi_hysteresis":
        return {"thresholds_V": tuple(float(v * rng.uniform(0.7, 1.3)) for v in (5, 15, 30, 50)),
                "weights": tuple(float(w * rng.uniform(0.7, 1.3)) for w in (0.06, 0.05, 0.04, 0.03))}
    return {}


def _temperature(n, fs, rng, ramp):
    if ramp:
        a, b = rng.uniform(28, 34), rng.uniform(40, 45)
        if rng.random() < 0.5:
            a, b = b, a
        t = np.arange(n) / fs
        frac = np.clip((t - 0.1 * t[-1]) / (0.6 * t[-1]), 0, 1)
        return a + (b - a) * frac
    return np.full(n, rng.uniform(28, 45))


def make_case(effect: str, seed: int, fs: float = 5000.0,
              duration_s: float = 8.0) -> tuple[list[Dataset], list[Dataset], dict]:
    """Train/test records from a twin with only ``effect`` on (``"none"``: no effect).

    Parameters
    ----------
    effect : str
        The hidden effect.
    seed : int
        Seed of the draws (parameters, noise, excitations).
    fs : float
        Sampling rate [Hz].
    duration_s : float
        Length of each record [s].

    Returns
    -------
    train, test : list of Dataset
        Two records each, different excitations.
    truth : dict
        The effect, its drawn parameters, the noise level and each record's excitation.
    """
    rng = np.random.default_rng(seed)
    params = truth_params(effect, rng)
    sigma = float(rng.uniform(0.003, 0.02))
    on = ["noise", "quantization"] + ([effect] if effect != "none" else [])
    over = {"noise": {"sigma_um": sigma}}
    if params:
        over[effect] = params
    cfg = replace(default_twin().with_effects(only=on, **over), sample_rate_hz=float(fs),
                  name=f"withheld_{effect}_{seed}")
    n = int(duration_s * fs)
    kinds = list(rng.permutation(KINDS))
    if effect == "slew":  # steps (fast edges) in one training and one test record
        kinds = ["steps", "multisine", "steps", "triangle"]
    records, meta = [], []
    for i in range(4):
        kind = kinds[i]
        lo = float(rng.uniform(0, 20))
        hi = float(rng.uniform(90, 150)) if i % 2 == 0 else float(rng.uniform(60, 150))
        if effect == "saturation":  # every record must reach the (hidden) limits
            hi = float(rng.uniform(140, 150))
        u = excitation(kind, n, fs, lo, hi, rng)
        ramp = i in (0, 3) or effect in ("thermal_drift", "thermal_dynamics")
        temp = _temperature(n, fs, rng, ramp)
        res = simulate(cfg, temp, u=u, seed=int(rng.integers(2 ** 31)))
        records.append(res.to_dataset())
        meta.append({"kind": str(kind), "u_range_V": [lo, hi], "temp_C": [float(temp[0]), float(temp[-1])]})
    truth = {"effect": effect, "params": params, "noise_sigma_um": sigma, "records": meta}
    train = [replace(d, source=f"{effect}-{seed}-train{i}") for i, d in enumerate(records[:2])]
    test = [replace(d, source=f"{effect}-{seed}-test{i}") for i, d in enumerate(records[2:])]
    return train, test, truth


def confusion(pairs: Iterable[tuple[str, str]],
              labels: Sequence[str] = CASES + ("linear", "cannot_tell")) -> dict[str, dict[str, int]]:
    """Confusion matrix ``{truth: {diagnosed: count}}`` from (truth, diagnosed) pairs.

    Parameters
    ----------
    pairs : iterable of (str, str)
        ``(hidden effect, diagnosed cause)``.
    labels : sequence of str
        The columns.

    Returns
    -------
    dict

    Examples
    --------
    >>> from robrst.diagnose.validation import confusion
    >>> m = confusion([("creep", "creep"), ("creep", "none")])
    >>> m["creep"]["creep"], m["creep"]["none"]
    (1, 1)
    """
    pairs = list(pairs)
    labels = tuple(dict.fromkeys(tuple(labels) + tuple(d for _, d in pairs)))
    m = {t: {d: 0 for d in labels} for t in CASES}
    for t, d in pairs:
        m[t][d] = m[t].get(d, 0) + 1
    return m


def run_suite(seeds, cases=CASES, progress=None):
    """Diagnose every (case, seed); return rows ``{case, seed, cause, shrink, ...}``."""
    from robrst.diagnose._diagnosis import diagnose

    rows = []
    for case in cases:
        for seed in seeds:
            train, test, truth = make_case(case, seed)
            d = diagnose(train, test)
            w = d.winner
            rows.append({"case": case, "seed": seed, "cause": d.cause,
                         "shrink": w.shrink if w else None, "gap_before": d.gap_before,
                         "noise_floor": d.noise_floor, "band_hz": d.where.frequency_band_hz,
                         "windows": len(d.where.time_windows),
                         "dominant_regime": d.where.regime.dominant if d.where.regime else None})
            if progress:
                progress(f"{case:<17} seed {seed}: {d.cause}")
    return rows


def confusion_markdown(rows):
    """Markdown confusion matrix (rows: hidden effect; columns: diagnosis)."""
    m = confusion([(r["case"], r["cause"]) for r in rows])
    cols = [c for c in CASES + ("linear", "cannot_tell")
            if any(m[t].get(c, 0) for t in CASES) or c in CASES]
    lines = ["| hidden \\ diagnosed | " + " | ".join(cols) + " |",
             "|---|" + "---|" * len(cols)]
    for t in CASES:
        if sum(m[t].values()) == 0:
            continue
        lines.append(f"| {t} | " + " | ".join(str(m[t].get(c, 0)) or "" for c in cols) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    import sys

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    res = run_suite(range(100, 100 + n), progress=lambda s: print(s, file=sys.stderr))
    print(confusion_markdown(res))
    shr = [r["shrink"] for r in res if r["shrink"] is not None]
    print(f"\n{len(res)} cases; held-out shrink of the named effect: min {min(shr):.3f},"
          f" median {float(np.median(shr)):.4f}")
