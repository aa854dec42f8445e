"""Step figures bound the whole response, the part after the time grid and the final value
included (fourth round, ``tests/repro/turn4/step_u_final_value_missed/``: ``step_u_peak_V``
120.97587 was the voltage where the grid stopped, below the final value 120.976016517;
``certify`` certified ``step_u_max_V = 120.9759``, which the loop exceeds).

Truth in 50-digit mpmath: the step response of ``N/D`` as its final value plus the
partial-fraction sum over the roots of ``D`` (``mpmath.polyroots``), its supremum over a
dense time grid to many time constants, refined.
"""

import json

import mpmath
import numpy as np
import pytest

from robrst.certificate.steps import step_metrics
from robrst.cli import main


def _poly(c):
    return [mpmath.mpf(float(x)) for x in np.trim_zeros(np.asarray(c, float), "f")]


def _horner(c, s):
    out = mpmath.mpf(0)
    for a in c:
        out = out * s + a
    return out


def truth(N, D, t_end):
    """(final value, supremum of y, supremum of |y|) of the step response of ``N/D``."""
    with mpmath.workdps(50):
        Nm, Dm = _poly(N), _poly(D)
        dD = [a * (len(Dm) - 1 - i) for i, a in enumerate(Dm[:-1])]
        roots = mpmath.polyroots(Dm[::-1], maxsteps=500, extraprec=400, asc=True)
        res = [_horner(Nm, p) / (p * _horner(dD, p)) for p in roots]
        final = Nm[-1] / Dm[-1]

        def y(t):
            return final + mpmath.re(mpmath.fsum(r * mpmath.exp(p * t) for r, p in zip(res, roots)))

        ts = np.concatenate([np.linspace(0, t_end, 4001), np.geomspace(1e-9, t_end, 1001)])
        ts.sort()
        vals = np.array([float(y(mpmath.mpf(float(t)))) for t in ts])
        out = []
        for v in (vals, np.abs(vals)):
            i = int(np.argmax(v))
            a, b = ts[max(i - 1, 0)], ts[min(i + 1, len(ts) - 1)]
            f = (lambda t: y(t)) if v is vals else (lambda t: abs(y(t)))
            best = mpmath.mpf(float(v[i]))
            for _ in range(60):                  # golden section on [a, b]
                c1, c2 = a + 0.382 * (b - a), a + 0.618 * (b - a)
                f1, f2 = f(mpmath.mpf(c1)), f(mpmath.mpf(c2))
                best = max(best, f1, f2)
                a, b = (a, c2) if f1 > f2 else (c1, b)
            out.append(max(float(best), abs(float(final)) if v is not vals else float(final)))
        return float(final), out[0], out[1]


def test_the_final_value_missed_is_not_certified(repro_dir, capsys):
    folder = repro_dir / "turn4" / "step_u_final_value_missed"
    rc = main(["certify", str(folder / "D.json"), "--problem", str(folder / "single.toml"),
               "--json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 1 and d["certified"] is False
    (v,) = d["certificate"]["violations"]
    assert v["quantity"] == "step_u_peak_V" and v["kind"] == "exceeds"
    ctrl = d["controller"]
    (m,) = d["models"]
    A = np.array(m["A"])
    Dl = np.polyadd(np.polymul(A, ctrl["S"]), np.polymul(m["B"], ctrl["R"]))
    Nu = np.polymul(A, ctrl["T"])
    step = d["specs"]["step_um"]
    final, _, sup_abs = truth(Nu, Dl, 400.0)
    assert final * step == pytest.approx(120.976016517, abs=2e-9)       # truth.txt
    assert sup_abs * step == pytest.approx(120.976016521, abs=2e-9)
    (rec,) = d["certificate"]["models"]
    got = rec["step_u_peak_V"]
    assert sup_abs * step <= got <= sup_abs * step * (1 + 1e-8), (got, sup_abs * step)


def _near_cancelled(seed):
    """A loop with a slow mode of large residue: a first-order plant under a PI whose zero
    almost cancels a slow closed-loop pole (the class of the reproducer)."""
    rng = np.random.default_rng(seed)
    a, k = rng.uniform(1, 10), rng.uniform(0.1, 1)
    eps = 10 ** rng.uniform(-4, -2)
    R = np.array([rng.uniform(1, 20), rng.uniform(1, 20) * eps])     # slow zero at -eps
    S = np.array([1.0, 0.0])
    T = np.array([R[-1]])
    D = np.polyadd(np.polymul([1.0, a], S), np.polymul([k], R))
    return {"y": (np.polymul([k], T), D), "u": (np.polymul([1.0, a], T), D)}


@pytest.mark.parametrize("seed", range(6))
def test_step_figures_bound_the_tail(seed):
    for name, (N, D) in _near_cancelled(seed).items():
        m = step_metrics(N, D)
        roots = np.roots(D)
        final, sup, sup_abs = truth(N, D, 60.0 / float(np.min(-roots.real)))
        assert m.final == pytest.approx(final, rel=1e-12)
        scale = max(abs(final), sup_abs)
        assert sup_abs - 1e-12 * scale <= m.max_abs <= sup_abs + 1e-8 * scale, (name, m, sup_abs)
        peak = m.peak if final >= 0 else -m.peak
        assert sup - 1e-12 * scale <= peak <= sup + 1e-8 * scale, (name, m, sup)
        assert m.resolved
