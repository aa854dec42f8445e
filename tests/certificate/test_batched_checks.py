"""The certificate's batched kernels give what one computation at a time gives.

:func:`robrst.certificate.proof.certify` checks its family members and sweep temperatures in
one batch (:func:`robrst.certificate.models.check_all_many`): peaks of every loop through
:func:`robrst.core.peaks.peak_gains_many`, roots through :func:`robrst.core.poly.roots_many`, the
resolution test through :func:`robrst.core.interval.distance_to_instability_many`.  Each is
compared here with an independent computation (``numpy.roots``, a dense grid of the
unscaled polynomials, the distance formula evaluated directly with ``numpy.polyval``) and
with the one-at-a-time path, which must agree bit for bit: the batch only stacks LAPACK
calls on matrices of equal size.
"""

import numpy as np
import pytest

from robrst.core.analysis import spectral_abscissa_many
from robrst.certificate.proof import certify_problem
from robrst.core.peaks import peak_gain, peak_gains, peak_gains_many
from robrst.core.interval import distance_to_instability_many
from robrst.design.contract import model_record_json
from robrst.certificate.models import check_all, check_all_many
from robrst.core.poly import roots_many
from robrst.problem.files import load_problem
from robrst.synthesis.analytic import pole_placement


def _stable(rng, n):
    D = np.ones(1)
    while len(D) - 1 < n:
        if n - (len(D) - 1) >= 2:
            w, z = 10 ** rng.uniform(-1, 4), rng.uniform(0.02, 0.9)
            D = np.polymul(D, [1.0, 2 * z * w, w * w])
        else:
            D = np.polymul(D, [1.0, 10 ** rng.uniform(-1, 4)])
    return D


def _polys(rng, k):
    out = []
    for _ in range(k):
        n = int(rng.integers(1, 9))
        c = rng.normal(size=n + 1) * 10.0 ** rng.uniform(-3, 3, n + 1)
        c = np.concatenate([np.zeros(int(rng.integers(0, 2))), c,
                            np.zeros(int(rng.integers(0, 3)))])   # leading and trailing zeros
        out.append(c)
    return out + [np.zeros(3), np.array([2.0]), np.array([0.0, 3.0, 0.0])]


def test_roots_many_is_numpy_roots():
    rng = np.random.default_rng(20261125)
    polys = _polys(rng, 60)
    for c, r in zip(polys, roots_many(polys)):
        ref = np.roots(c)
        assert r.shape == ref.shape
        assert np.array_equal(np.sort_complex(r.astype(complex)),
                              np.sort_complex(ref.astype(complex)))


def test_spectral_abscissa_many_matches_unscaled_roots():
    rng = np.random.default_rng(7)
    Ds = [_stable(rng, int(rng.integers(1, 10))) for _ in range(40)]
    Ds += [np.polymul(D, [1.0, -0.5]) for D in Ds[:5]]          # unstable ones too
    for D, (sa, r) in zip(Ds, spectral_abscissa_many(Ds)):
        ref = np.max(np.roots(D).real)
        assert sa == pytest.approx(ref, rel=1e-6, abs=1e-9 * np.max(np.abs(np.roots(D))))
        assert len(r) == len(D) - 1


def _distance_direct(parts, Delta, roots, n_grid=400):
    """The documented formula, evaluated directly (numpy.polyval, scalar grids)."""
    prods = [np.convolve(np.abs(np.trim_zeros(np.asarray(a, float), "f")),
                         np.abs(np.trim_zeros(np.asarray(b, float), "f"))) for a, b in parts]
    Delta = np.trim_zeros(np.asarray(Delta, float), "f")
    n = max([len(Delta)] + [len(c) for c in prods])
    size = np.zeros(n)
    for c in prods:
        size[n - len(c):] += c
    Delta = np.concatenate([np.zeros(n - len(Delta)), Delta])
    roots = np.asarray(roots, complex)
    mags = np.abs(roots)[np.abs(roots) > 0]
    w = np.concatenate([[0.0], np.geomspace(mags.min() / 100, mags.max() * 100, n_grid),
                        np.abs(roots.imag)])
    r = np.abs(np.polyval(Delta, 1j * w)) / np.polyval(size, w)
    j = int(np.argmin(r))
    if j > 0 and w[j] > 0:
        t = np.geomspace(w[j] / 1.05, w[j] * 1.05, 201)
        r = np.concatenate([r, np.abs(np.polyval(Delta, 1j * t)) / np.polyval(size, t)])
    return float(np.min(r))


def test_distance_to_instability_many_matches_direct_formula():
    rng = np.random.default_rng(11)
    jobs = []
    for _ in range(30):
        n = int(rng.integers(1, 5))
        A, B = _stable(rng, n), rng.normal(size=n) * 10.0 ** rng.uniform(-2, 4)
        S, R = _stable(rng, n), rng.normal(size=n + 1)
        Delta = np.polyadd(np.polymul(A, S), np.polymul(B, R))
        jobs.append(([(A, S), (B, R)], Delta, np.roots(Delta)))
    got = distance_to_instability_many(jobs)
    for job, v in zip(jobs, got):
        # the direct formula works in unscaled s, robrst in the scaled variable: the same
        # grid points up to rounding
        assert v == pytest.approx(_distance_direct(*job), rel=1e-9)
    assert got == [distance_to_instability_many([job])[0] for job in jobs]   # bit for bit


def _dense_peak(N, D, w):
    return float(np.max(np.abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w))))


def test_peak_gains_many_is_peak_gains_and_dense_grid():
    rng = np.random.default_rng(3)
    jobs = []
    for _ in range(25):
        n = int(rng.integers(2, 9))
        D = _stable(rng, n)
        Ns = [rng.normal(size=int(rng.integers(1, n + 2))) * D[-1] for _ in range(3)]
        band = (10 ** rng.uniform(-1, 2), 10 ** rng.uniform(2, 4))
        jobs.append((Ns, D, [(1, band), (2, (band[0], np.inf))]))
    got = peak_gains_many(jobs)
    w = np.geomspace(1e-3, 1e6, 200_001)
    for (Ns, D, bands), pks in zip(jobs, got):
        assert pks == peak_gains(Ns, D, bands=bands)          # bit for bit, one job alone
        # a lone level (robrst.core._levelbatch.One, scalars) as in a stack (Batch)
        assert pks[:len(Ns)] == [peak_gain(N, D) for N in Ns]
        for N, pk in zip(Ns, pks):
            grid = _dense_peak(N, D, w)
            assert grid <= pk.value * (1 + 1e-9)               # never below the grid
            assert pk.value <= grid * (1 + 1e-4)               # attained (grid resolution)


@pytest.mark.parametrize("name", ["paper_robust", "paper_robust_continuous"])
def test_check_all_many_is_one_model_at_a_time(name):
    p = load_problem(name)
    ctrl = pole_placement(p.family.reference_model, p.poles, p.controller).controller
    models = list(p.family.sweep(9))
    specs = p.specs
    batch = check_all_many(models, ctrl, specs, 1e-3, (), p.family)
    for m, (rec, viol) in zip(models, batch):
        rec1, viol1 = check_all(m, ctrl, specs, 1e-3, (), p.family)
        assert viol == viol1
        a, b = model_record_json(rec), model_record_json(rec1)     # every published figure
        assert a.keys() == b.keys()
        for k in a:
            assert a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]), k
    cert = certify_problem(p, ctrl)
    assert len(cert.models) >= len(p.family.models) + 9


def _sequential_refine(family, ctrl, specs, rtol, recs, budget, ignore):
    """The interval halving one point at a time, depth first (as documented in
    :mod:`robrst.certificate.proof`): the checked temperatures and the violations in order."""
    from robrst.certificate.proof import MIN_WIDTH, REFINE_RATIO
    from robrst.certificate.models import JUMPS, margins

    def unresolved(ra, rb, ignore=()):
        ma, mb = margins(ra, specs, rtol), margins(rb, specs, rtol)
        for k in sorted(ma.keys() & mb.keys() - set(ignore)):
            (va, lim), (vb, _) = ma[k], mb[k]
            room = min(lim - va, lim - vb)
            if room > 0 and abs(va - vb) > REFINE_RATIO * room:
                return k
        return None

    lo, hi = family.range_C
    floor = MIN_WIDTH * (hi - lo)
    temps = sorted(recs)
    stack, viols, n_unresolved, walked = list(zip(temps[:-1], temps[1:])), [], 0, set()
    while stack:
        a, b = stack.pop()
        if unresolved(recs[a], recs[b], ignore) is None:
            continue
        deg = [recs[t].continuous.closed_loop_degree for t in (a, b)]
        if b - a <= floor and (deg[0] != deg[1] or
                               unresolved(recs[a], recs[b], (*ignore, *JUMPS)) is None):
            continue
        if b - a <= floor or budget <= 0:
            n_unresolved += 1
            continue
        m, low = 0.5 * (a + b), None
        if deg[0] != deg[1]:   # a degree drops at one temperature: probe next to that end
            low = a if deg[0] < deg[1] else b
            if low in walked:
                low = None
            else:
                m = a + 0.5 * floor if low == a else b - 0.5 * floor
        recs[m], v = check_all(family.at(m), ctrl, specs, rtol, (), family)
        viols += v
        if low is not None and (recs[m].continuous.closed_loop_degree
                                == recs[low].continuous.closed_loop_degree):
            walked.add(m)
        budget -= 1
        stack += [(a, m), (m, b)]
    return sorted(recs), viols, n_unresolved


@pytest.mark.parametrize("seed", [42, pytest.param(116, marks=pytest.mark.slow),
                                  pytest.param(127, marks=pytest.mark.slow)])
def test_refinement_in_batches_is_the_depth_first_halving(seed):
    import random_problems as rp
    from robrst.certificate.proof import certify

    from robrst.certificate.proof import resolved_specs

    p = rp.random_case(seed).problem()
    ctrl = pole_placement(p.family.reference_model, p.poles, p.controller).controller
    n_sweep = 35
    cert = certify(p.family, ctrl, p.specs, n_sweep=n_sweep, rtol=1e-3)
    # certify checks the specs with the damping floor resolved on the family (the default
    # floor when damping_min is not given): the sequential halving checks the same
    specs = resolved_specs(p.specs, p.family)[0]
    guardian = cert.interval.guardian
    assert guardian is None or not guardian.parts or all(
        q.candidate_C is None for q in guardian.parts)
    # a stability proof over the interval: the continuous spectral abscissa is not watched
    proved = cert.interval.stability in ("segment_crossing", "guardian_map")
    models = list(p.family.models)
    known = {m.temperature_C for m in models}
    models += [m for m in p.family.sweep(n_sweep) if m.temperature_C not in known]
    recs, viols = {}, []
    for m in models:
        recs[m.temperature_C], v = check_all(m, ctrl, specs, 1e-3, (), p.family)
        viols += v
    ignore = ("spectral_abscissa",) if proved else ()
    if cert.interval.pole_region_proof is not None and cert.interval.pole_region_proof.proved:
        ignore += ("damping", "decay_rad_s")
    temps, v_ref, n_unres = _sequential_refine(
        p.family, ctrl, specs, 1e-3, recs, max(4 * n_sweep, 64), ignore)
    assert [r.temperature_C for r in cert.models] == temps
    assert len(temps) > len(models)                      # the refinement did add points
    got = [v for v in cert.violations if "changes too fast" not in v.quantity]
    assert got == viols + v_ref
    assert len(cert.violations) - len(got) == n_unres


@pytest.mark.parametrize("name", ["paper_robust", "paper_robust_continuous"])
def test_start_scores_together_are_one_at_a_time(name):
    """The synthesis scores its start points together (:func:`score_many`): each start's
    worst grid ratio and spectral abscissa are those of :func:`score` alone, bit for bit,
    and the abscissa is the largest real part of numpy.roots of every model's scaled
    closed-loop polynomial."""
    from robrst.design import analytic_design
    from robrst.synthesis.context import Context
    from robrst.synthesis._nlp import closed_loop_maps, grid_blocks
    from robrst.synthesis.starts import candidates, score, score_many

    p = load_problem(name)
    start = analytic_design(p)
    ctx = Context.of(p, start)
    setup = ctx.setup(list(p.family.models), ctx.nu, "dominant")
    blocks = grid_blocks(setup, np.ones(ctx.param.n_x))
    starts = candidates(ctx, setup, blocks)
    assert len(starts) >= 5
    items = [(s.name, s.xc, s.wn, s.zeta) for s in starts]
    cl = closed_loop_maps(setup)
    for got, item in zip(score_many(setup, blocks, items), items):
        one = score(setup, blocks, *item)
        assert (got.worst, got.abscissa) == (one.worst, one.abscissa)
        D = [cl(a, b)[0] for _, _, a, b in setup.models]
        sa = max(np.max(np.roots(Dm @ got.xc + Dc).real) for Dm, Dc in D)
        assert got.abscissa == pytest.approx(sa, rel=1e-9, abs=1e-12)


def test_level_set_batch_gains_and_hamiltonians():
    """The batched level-set kernel (robrst.core._levelbatch): stacked gains are each row's
    gain() bit for bit, whatever the number of candidates per row (one, several, padded,
    beyond the overflow limit of the powers); the stacked Hamiltonians' imaginary
    eigenvalues j nu are where |N/D| (numpy.polyval) equals the level."""
    from robrst.core._levelbatch import gain, gains, hamiltonians
    from robrst.core.lti import companion_monic

    rng = np.random.default_rng(8)
    n, K, M = 5, 40, 7
    NDs = rng.normal(size=(K, 2, n + 1))
    NDs[:, 1, 0] = 1.0
    nu = 10 ** rng.uniform(-2, 2, (K, M))
    nu[3, :] = 10 ** rng.uniform(59, 61, M)                 # powers would overflow
    valid = rng.uniform(size=(K, M)) < 0.5
    valid[np.arange(K) % 4 == 0] = False
    valid[np.arange(K) % 4 == 0, 2] = True                  # rows with one candidate
    got = gains(NDs, nu, valid)
    for k in range(K):
        assert np.all(got[k, ~valid[k]] == -np.inf)
        if valid[k].any():
            assert np.array_equal(got[k, valid[k]], gain(NDs[k], nu[k, valid[k]]))
    parts = [companion_monic(N, D, balance=False) for N, D in NDs]
    A, B, C = (np.stack([p[i] for p in parts]) for i in range(3))
    d = np.array([p[3] for p in parts])
    g = 1.5 * np.abs(d) + 1.0
    crossings = 0
    for k, ev in enumerate(np.linalg.eigvals(hamiltonians(A, B, C, d, g))):
        nus = ev.imag[(np.abs(ev.real) < 1e-9 * np.abs(ev)) & (ev.imag > 0)]
        N, D = NDs[k]
        crossings += len(nus)
        for w in nus:
            assert abs(np.polyval(N, 1j * w) / np.polyval(D, 1j * w)) == pytest.approx(
                g[k], rel=1e-7)
    assert crossings >= 20
