"""The digital controller: direct form and sections against independent computations.

References: python-control's Tustin ``c2d`` of the time-scaled controller (direct form),
the controller polynomials evaluated at the Tustin points (sections), the sections'
own state space through python-control (one realisation, two evaluations).
"""

import control
import numpy as np
import pytest

from robrst.controller.digital import aw_poles, digital_controller, exact_response
from robrst.base.errors import SpecError
from robrst.controller.implementation import frequency_grid
from robrst.core.rst import RSTController, tustin_polynomials

FS = 20000.0


def _python_control_tustin(ctrl, fs):
    """``R_z, S_z, T_z`` from ``control.c2d(..., 'tustin')`` of the time-scaled R/S, T/S."""
    w0 = 1e4                                          # any O(1)-making scale
    n = len(ctrl.S) - 1
    k = w0 ** -np.arange(n + 1)
    pad = lambda c: np.concatenate([np.zeros(n + 1 - len(c)), c]) * k   # noqa: E731
    out = []
    for num in (ctrl.R, ctrl.T):
        d = control.c2d(control.tf(pad(num), pad(ctrl.S)), w0 / fs, "tustin")
        num_z, den_z = d.num[0][0], d.den[0][0]
        num_z = np.concatenate([np.zeros(len(den_z) - len(num_z)), num_z])
        out.append((num_z / den_z[0], den_z / den_z[0]))
    return out[0][0], out[0][1], out[1][0]


def random_controller(rng, n_real=2, n_pairs=1, integrators=1, spread=3.0, biproper=False):
    """A random proper controller: roots of S spread over ``10**spread`` rad/s."""
    roots = [0.0] * integrators
    roots += list(-10 ** rng.uniform(1, 1 + spread, n_real))
    for _ in range(n_pairs):
        w = 10 ** rng.uniform(1, 1 + spread)
        z = rng.uniform(0.05, 0.95)
        roots += [-z * w + 1j * w * np.sqrt(1 - z * z), -z * w - 1j * w * np.sqrt(1 - z * z)]
    S = np.real(np.poly(roots))
    n = len(S) - 1
    R = np.real(np.poly(-10 ** rng.uniform(1, 1 + spread, n - 1 + biproper)))
    R = R * 10 ** rng.uniform(0, 6)
    T = np.array([R[-1]])
    return RSTController(R, S, T)


def _exact_tustin(ctrl, fs):
    """``R_z, S_z, T_z`` in exact rational arithmetic from the controller's (binary,
    hence exact) coefficients: ``s = 2 fs (1 - q^-1)/(1 + q^-1)`` times ``(1 + q^-1)^n``,
    each normalised by the exact ``S_z[0]``; with, per coefficient, the sum of the
    magnitudes of the terms that form it (the same normalisation): a floating-point
    evaluation is exact to a few ulps of that sum, not of the coefficient (cancellation)."""
    from fractions import Fraction
    from math import comb
    n = len(ctrl.S) - 1
    c = Fraction(2.0 * fs)
    exact, size = [], []
    for P in (ctrl.R, ctrl.S, ctrl.T):
        a = [Fraction(float(v)) for v in np.concatenate([np.zeros(n + 1 - len(P)), P])[::-1]]
        z, m = [Fraction(0)] * (n + 1), [Fraction(0)] * (n + 1)
        for j, aj in enumerate(a):
            conv = np.convolve([comb(j, i) * (-1) ** i for i in range(j + 1)],
                               [comb(n - j, i) for i in range(n - j + 1)])
            for k, v in enumerate(conv):
                term = aj * c ** j * int(v)
                z[k] += term
                m[k] += abs(term)
        exact.append(z)
        size.append(m)
    lead = exact[1][0]
    return ([np.array([float(v / lead) for v in z]) for z in exact],
            [np.array([float(v / abs(lead)) for v in m]) for m in size])


# the continuous-only robust design (10-20 s, no other default test needs it): -m slow
SHIPPED = ["paper", "paper_robust",
           pytest.param("paper_robust_continuous", marks=pytest.mark.slow)]


@pytest.mark.parametrize("name", SHIPPED)
def test_direct_form_matches_python_control_tustin(designs, name):
    """Against the exact rational substitution to 64 ulps of the terms that form each
    coefficient (its documented accuracy), and against python-control's ``c2d`` (a
    state-space route, its own rounding) to 1e-8 of the largest coefficient: a
    ``paper_robust`` design tried on 2026-12-07 (edge runs, a longer polish chain), a lag
    at 15 rad/s at 20 kHz (a pole at ``z = 0.99925``), differed from python-control by
    2.7e-9 relative, from the exact coefficients by less than its bound."""
    ctrl = designs(name).controller
    R_z, S_z, T_z = tustin_polynomials(ctrl, FS)
    R_pc, S_pc, T_pc = _python_control_tustin(ctrl, FS)
    exact, size = _exact_tustin(ctrl, FS)
    assert S_z[0] == 1.0
    for mine, ref, ex, m in zip((R_z, S_z, T_z), (R_pc, S_pc, T_pc), exact, size):
        assert np.all(np.abs(mine - ex) <= 64 * np.finfo(float).eps * m), (mine - ex) / m
        np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-8 * np.max(np.abs(ref)))
    assert abs(np.sum(S_z)) < 1e-12                  # the integrator: S_z(1) = 0


@pytest.mark.parametrize("name", SHIPPED)
def test_sections_reproduce_the_controller(designs, name):
    """Sections vs the polynomials at the Tustin points: relative 1e-12 on both channels."""
    ctrl = designs(name).controller
    dc = digital_controller(ctrl, FS)
    th = frequency_grid(2000)
    # up to 1e-4 below Nyquist, where theta itself is known to 1e-12 relative in pi - theta
    th = th[th < np.pi * (1 - 1e-4)]
    ref = exact_response(ctrl, th, FS)
    # T/S has a 4- or 5-fold zero at Nyquist: its error is measured against 1e-6 of its peak
    scale = np.maximum(np.abs(ref), [1e-6 * np.max(np.abs(ref[:, 0])), 0.0])
    assert np.max(np.abs(dc.freqresp(th) - ref) / scale) < 1e-11
    lead = [c[0] / ctrl.S[0] if len(c) == len(ctrl.S) else 0.0 for c in (ctrl.T, -ctrl.R)]
    np.testing.assert_allclose(dc.freqresp(np.pi)[0].real, lead, rtol=1e-12,
                               atol=1e-12 * np.max(np.abs(ref[:, 1])))
    # the same realisation through python-control's evaluation of its state space
    sys = dc.to_ss()
    z = np.exp(1j * th[::50])
    pc = np.array([np.asarray(sys(zz)).ravel()[1] for zz in z])
    ref = exact_response(ctrl, th[::50], FS)[:, 1]
    assert np.max(np.abs(pc - ref) / np.abs(ref)) < 1e-8   # python-control: z - 1 cancels
    # integrator section: F = 0 exactly; the feedthrough equals the direct form's
    assert any(s.pole_rad_s == 0 and np.all(s.F == 0) for s in dc.sections)
    A, B, C, D, L = dc.state_space()
    np.testing.assert_allclose(D.ravel(), [dc.T_z[0], -dc.R_z[0]], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("seed", range(6))
def test_sections_on_random_controllers(seed):
    """Repeated and clustered roots, poles near z = 1 (fs up to 1e5 x the slowest pole)."""
    rng = np.random.default_rng(seed)
    ctrl = random_controller(rng, n_real=int(rng.integers(1, 4)), n_pairs=int(rng.integers(0, 3)),
                             integrators=1 + seed % 2, biproper=seed % 3 == 0)
    fs = 10 ** rng.uniform(2.5, 5.5)
    dc = digital_controller(ctrl, fs)
    assert dc.n_states == len(ctrl.S) - 1
    th = frequency_grid(1000)
    th = th[th < np.pi * (1 - 1e-3)]
    ref = exact_response(ctrl, th, fs)
    err = np.abs(dc.freqresp(th)[:, 1] - ref[:, 1]) / np.abs(ref[:, 1])
    assert err.max() < 1e-9
    if len(ctrl.R) == len(ctrl.S):                    # biproper: feedthrough at Nyquist
        assert dc.freqresp(np.pi)[0, 1].real == pytest.approx(-ctrl.R[0], rel=1e-12)
    # the anti-windup gain makes the saturated dynamics stable (placed where aw_poles says)
    A, _, C, _, L = dc.state_space()
    got = np.linalg.eigvals(A - np.outer(L, C))
    assert np.max(np.abs(got)) < 1 and dc.aw_method in ("placed", "kalman")
    if dc.aw_method == "placed":
        np.testing.assert_allclose(np.sort(got.real), np.sort(aw_poles(ctrl, fs)), atol=1e-5)


def test_a_pole_at_twice_the_sampling_rate_is_refused():
    fs = 100.0
    ctrl = RSTController([1.0, 1.0], [1.0, -2 * fs, 0.0], [1.0])    # S = s (s - 2 fs)
    with pytest.raises(SpecError, match="z = infinity"):
        digital_controller(ctrl, fs)
    with pytest.raises(SpecError, match="sampling rate"):
        tustin_polynomials(ctrl, -1.0)
