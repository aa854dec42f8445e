"""The multi-axis design: a MimoProblem in, a MimoDesignResult out.

:class:`~robrst.problem.mimo.MimoProblem` in, :class:`MimoDesignResult` out.

:func:`design_mimo`:

1. **Decoupler** (:func:`robrst.synthesis.mimo_design.decoupler_of`).
2. **Per-axis designs** (the start): each axis designed alone on its diagonal channel
   ``(G W)_ii`` over every model and loop of the family
   (:func:`robrst.synthesis.mimo_design.design_axes`); with method ``per_axis`` they are
   the answer.
3. **The global phase** (method ``nlp`` with ``multistart``:
   :func:`robrst.synthesis.mimo_search.search_mimo`): a population search over every
   axis's law on the members and the midpoints between them; its best is certified as it
   is, and the joint program runs from it as well as from the per-axis start when it
   screens above the first answer (the program is local: either start can end higher).
   **The joint program** (method ``nlp``,
   :func:`robrst.synthesis.mimo_design.program_rounds`): every axis, the coupling and
   every model at once; then the full certificate, whose violated points between models
   join the program as further models.
   Before it, the per-axis start is certified, and while it is not, the start with every
   axis's feedback gain backed off (``R_i`` scaled by :data:`BACK_OFF`), up to the first
   certified one.
4. **Always an answer**: the certified controller with the largest least integral gain
   of the joint designs, the search's point and that certified start (the joint program
   is local: where it ends or stops can lie below its start), else the best found, with
   its certificate and the binding figure (the largest ratio to its bound) named; with
   none certified,
   the least violating of every controller tried (the smallest binding ratio: a joint
   result outside its own rows can be far worse than its start).
5. **The comparison**: the per-axis designs certified on the whole loop, and (``compare``)
   the loops designed one by one on ``G_ii`` ignoring the coupling (no decoupler), on the
   same certificate.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from robrst.base.threads import one_blas_thread
from robrst.certificate.mimo import MimoCertificate, certify_mimo, check_models
from robrst.core.mimo_loop import MimoController
from robrst.problem.mimo import MimoProblem
from robrst.synthesis.mimo_design import (decoupler_of, design_axes, per_axis_controller,
                                          program_rounds, controller_of)
from robrst.synthesis.mimo_program import AxisParam
from robrst.synthesis.mimo_search import search_mimo
from robrst.synthesis.mimo_start import design_scale

__all__ = ["Binding", "MimoComparison", "MimoDesignResult", "design_mimo", "BACK_OFF",
           "COMPARISON_VIOLATIONS", "LOCAL_RUN_NOTE"]

#: the gain factors of the last resort (module docstring, step 4)
BACK_OFF = (0.9, 0.75, 0.5)
COMPARISON_VIOLATIONS = 20   # a comparison's violations its JSON keeps (and the summary names)
#: the note of a joint design without the global phase: the program is local, and which
#: basin it ends in depends on where it starts (on seeded three-axis stages the search's
#: basin was up to ten times higher: docs/guide/multi-axis.md)
LOCAL_RUN_NOTE = ("no global phase: the joint program from the per-axis start, a local"
                  " method whose answer depends on where it starts ([mimo.solver]"
                  " multistart = true searches every axis's law first and can reach a higher"
                  " basin, at a few times the CPU)")


@dataclass(frozen=True)
class Binding:
    """The figure nearest to (or furthest beyond) its bound.

    Parameters
    ----------
    figure : str
        The figure (``"stability"`` for an unstable loop).
    ratio : float
        Its ratio to its bound (``inf`` for an unstable loop).
    model : str
        The model's label.
    loop : str
        ``"continuous"`` or ``"sampled"``.
    """

    figure: str
    ratio: float
    model: str
    loop: str

    def as_dict(self) -> dict:
        """The JSON form: ``figure, ratio, model, loop``.

        Returns
        -------
        dict
        """
        return {"figure": self.figure, "ratio": self.ratio, "model": self.model,
                "loop": self.loop}


@dataclass(frozen=True, eq=False)
class MimoComparison:
    """Another controller of the same problem on the same certificate.

    Parameters
    ----------
    controller : MimoController
    certificate : MimoCertificate
    note : str
        What the controller is.
    """

    controller: MimoController
    certificate: MimoCertificate
    note: str

    def as_dict(self) -> dict:
        """The comparison as JSON-ready fields.

        Returns
        -------
        dict
            ``certified, note, ratios, controller``, the first 20 ``violations`` and the
            ``members``' figures.
        """
        c = self.certificate
        return {"certified": c.certified, "note": self.note, "ratios": c.ratios(),
                "controller": self.controller.as_dict(),
                "violations": [x.as_dict() for x in c.violations[:COMPARISON_VIOLATIONS]],
                "members": [m.as_dict() for m in c.members()]}


@dataclass(frozen=True, eq=False)
class MimoDesignResult:
    """What :func:`design_mimo` returns (always an answer).

    Parameters
    ----------
    problem : MimoProblem
    controller : MimoController
        The answer: the best certified controller, else the best found.
    certificate : MimoCertificate
        Its certificate over the whole family.
    binding : Binding or None
        The figure with the largest ratio to its bound (``None``: nothing bounded).
    rounds : tuple of MimoRound
    start : MimoController
        The per-axis designs with the decoupler (the program's start).
    comparisons : dict of str to MimoComparison
        ``per_axis_start``, ``global_search`` (the global phase's best law, when it
        screened above the start) and (with ``compare``) ``ignoring_coupling``, the
        per-axis designs that ignore the coupling.
    w_design : float
        The start's crossover [rad/s].
    seconds : float
        Wall time.
    notes : tuple of str
        What the answer is and is not: without the global phase, the local program's
        (:data:`LOCAL_RUN_NOTE`); with it, why the search's best was not used, when it was
        not.

    Attributes
    ----------
    certified : bool
    """

    problem: MimoProblem
    controller: MimoController
    certificate: MimoCertificate
    binding: Binding | None
    rounds: tuple
    start: MimoController
    comparisons: dict = field(default_factory=dict)
    w_design: float = 0.0
    seconds: float = 0.0
    notes: tuple = ()

    @property
    def certified(self) -> bool:
        return self.certificate.certified

    def integral_gains(self) -> list[float]:
        """Every axis's integral gain ``lim s R_i/S_i`` [V/(µm s)] (before the decoupler).

        Returns
        -------
        list of float
        """
        return _integral_gains(self.controller)

    def as_dict(self) -> dict:
        """The design as one JSON-ready object.

        Returns
        -------
        dict
            ``kind = "mimo"``, ``problem``, ``certified``, ``controller``, ``certificate``,
            ``binding``, ``integral_gains``, ``rounds``, ``comparisons`` (their certified
            flag, ratios and violations), ``seconds``, ``notes``.
        """
        p = self.problem
        return {
            "kind": "mimo", "problem": p.name, "certified": self.certified,
            "axes": list(p.axes), "parameter": p.family.parameter, "unit": p.family.unit,
            "models": [m.label for m in p.family.models],
            "values": [m.value for m in p.family.models],
            "specs": p.specs.as_dict(), "method": p.solver.method,
            "controller": self.controller.as_dict(),
            "integral_gains": self.integral_gains(),
            "w_design_rad_s": self.w_design,
            "binding": {} if self.binding is None else self.binding.as_dict(),
            "certificate": self.certificate.as_dict(),
            "rounds": [r.__dict__ for r in self.rounds],
            "comparisons": {k: v.as_dict() for k, v in self.comparisons.items()},
            "seconds": self.seconds,
            "notes": list(self.notes),
        }


def _binding(cert: MimoCertificate) -> Binding | None:
    """The figure with the largest ratio to its bound (or the first violation's)."""
    best = None
    for rec in cert.models:
        for loop in ("continuous", "sampled"):
            lf = rec.loop(loop)
            if lf is None:
                continue
            if not lf.stable:
                return Binding("stability", np.inf, rec.label, loop)
            for fig, b in cert.bounds.items():
                v = lf.value(fig)
                if v is not None and (best is None or v / b > best.ratio):
                    best = Binding(fig, v / b, rec.label, loop)
    if best is None and cert.violations:
        v = cert.violations[0]
        best = Binding(v.quantity, v.ratio, v.label, v.loop)
    return best


def _backed_off(xs, axis, factor):
    """The per-axis vectors with every axis's feedback ``R_i`` scaled by ``factor``."""
    return [np.concatenate([x[:axis.d], factor * x[axis.d:]]) for x in xs]


def _certified_start(fam, xs, axes, W, st, names, specs, so, say):
    """``[(factor, controller, certificate)]``: the per-axis start (factor 1), then backed
    off by :data:`BACK_OFF` while none is certified."""
    out = []
    for factor in (1.0,) + BACK_OFF:
        ctrl = per_axis_controller(axes, _backed_off(xs, axes[0], factor), W, st.T_mode,
                                   names)
        say("certifying the per-axis start over the whole family" if factor == 1.0 else
            f"certifying the per-axis start at {factor:g} x its gain")
        cert = certify_mimo(fam, ctrl, specs, so.cert_tol, so.cert_points)
        out.append((factor, ctrl, cert))
        if cert.certified:
            break
    return out


def _integral_gains(ctrl: MimoController) -> list[float]:
    """Every axis's integral gain ``lim s R_i/S_i`` (0 without integral action)."""
    out = []
    for c in ctrl.axes:
        S = np.trim_zeros(c.S, "b")
        out.append(float(c.R[-1] / S[-1]) if len(S) < len(c.S) else 0.0)
    return out


def _least_gain(ctrl: MimoController) -> float:
    """The least of the axes' integral gains in magnitude: what the joint program
    maximises."""
    return min(abs(k) for k in _integral_gains(ctrl))


def _miss(cert: MimoCertificate) -> float:
    """How far ``cert``'s controller is from the specs: its binding ratio (infinite when
    a loop is unstable or a figure unbounded)."""
    b = _binding(cert)
    r = np.inf if b is None or b.ratio is None else b.ratio
    return float(r) if np.isfinite(r) else np.inf


def _stable_start(models, xs, axes, W, st, names, specs, so):
    """The per-axis start, its feedback gains halved while the coupling destabilises a
    model's loop (the joint program's start without the global phase)."""
    axis = axes[0]
    x0 = np.concatenate(xs)
    recs, _ = check_models(models, per_axis_controller(axes, xs, W, st.T_mode, names), specs,
                           so.cert_tol)
    shrink = 1.0
    while not all(r.continuous.stable and (r.sampled is None or r.sampled.stable)
                  for r in recs) and shrink > 1e-3:
        shrink *= 0.5
        x0 = np.concatenate([np.concatenate([x[:axis.d], shrink * x[axis.d:]]) for x in xs])
        recs, _ = check_models(models, per_axis_controller(
            axes, [x0[i * axis.n_x:(i + 1) * axis.n_x] for i in range(len(xs))], W,
            st.T_mode, names), specs, so.cert_tol)
    return x0


def _better(ctrl, cert, other, other_cert):
    """Whether ``ctrl`` is the better answer: certified with a larger least integral gain,
    or certified where the other is not, or neither certified and it misses less."""
    if cert.certified != other_cert.certified:
        return cert.certified
    if cert.certified:
        return _least_gain(ctrl) > _least_gain(other)
    return _miss(cert) < _miss(other_cert)


def _joint(fam, models, x0, axes, W, st, names, specs, so, signs, say, w_design, rounds):
    """The joint program's rounds from ``x0`` and the certificate, the certificate's
    violated points between models joining the program (three times at most):
    ``(x, controller, certificate)``."""
    extra = []
    for _ in range(3):
        x, _, _ = program_rounds("joint", models, specs, axes, W, st.T_mode, names, x0,
                                 signs, so, say, w_design, rounds, extra)
        ctrl = controller_of(axes, x, W, st.T_mode, names)
        say("certifying the joint design over the whole family")
        cert = certify_mimo(fam, ctrl, specs, so.cert_tol, so.cert_points)
        if cert.certified:
            break
        bad = [v for v in cert.violations if v.kind in ("exceeds", "unstable")
               and v.value_param is not None
               and not any(v.label == m.label for m in models)]
        new = []
        for v in bad:
            plant = fam.at(v.value_param)
            if not any(plant.value == e.value for e in extra):
                new.append(plant)
        if not new:
            break
        say(f"  {len(new)} point(s) between models violated: added to the program")
        extra += new[:4]
        x0 = x
    return x, ctrl, cert


def design_mimo(problem: MimoProblem, progress: Callable[[str], None] | None = None,
                compare: bool = True) -> MimoDesignResult:
    """Design and certify a decentralised multi-axis controller (module docstring).

    Parameters
    ----------
    problem : MimoProblem
    progress : callable, optional
        Receives progress lines.
    compare : bool
        Also design the axes one by one ignoring the coupling (no decoupler) and certify
        them on the same family and specs.

    Returns
    -------
    MimoDesignResult
        Always an answer (module docstring, step 4).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.core.mimo import MimoFamily, MimoPlant
    >>> from robrst.problem.mimo import MimoProblem, MimoSpecs, MimoSolverOptions
    >>> G = MimoPlant(-100.0 * np.eye(2), 100.0 * np.eye(2), [[1.0, 0.2], [0.1, 1.0]],
    ...               np.zeros((2, 2)))
    >>> pr = MimoProblem("stage", MimoFamily((G,)), specs=MimoSpecs(sigma_S_max=2.0),
    ...                  solver=MimoSolverOptions(max_rounds=2))
    >>> design_mimo(pr, compare=False).certified
    True
    """
    # small matrices: a second BLAS thread only spins (robrst.base.threads); the program's
    # rows and the per-axis scans ran with the caller's threads, the certificates with one
    with one_blas_thread():
        return _design_mimo(problem, progress, compare)


def _design_mimo(problem, progress, compare):
    """:func:`design_mimo` with one BLAS thread."""
    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    st, specs, so = problem.structure, problem.specs, problem.solver
    fam = problem.family
    names = problem.axes
    W = decoupler_of(problem)
    w_design = design_scale(fam.reference_model, specs, so.bandwidth_hz)
    axis = AxisParam.of(w_design, st.extra_degree, st.relative_degree, st.roll_off_order,
                        st.roll_off_hz)
    rounds = []
    models = list(fam.models)
    say(f"designing {problem.name}: {fam.n_out} axes, {len(models)} model(s) over"
        f" {fam.parameter}, crossover scale {w_design / (2 * np.pi):.4g} Hz")
    # the start: each axis alone on (G W)_ii, its integral-gain scan (the per-axis method:
    # the program's rounds too)
    xs, signs = design_axes(models, W, specs, axis, so, names, st.T_mode, say, w_design,
                            rounds, optimize=so.method == "per_axis")
    axes = [axis] * len(names)
    start = per_axis_controller(axes, xs, W, st.T_mode, names)
    best_ctrl = start
    # the per-axis start and its backed-off gains (BACK_OFF), certified until one is: an
    # answer beside the joint design's (the joint program's local optimum, or where it
    # stopped, can lie below it)
    backed = _certified_start(fam, xs, axes, W, st, names, specs, so, say)
    start_cert = backed[0][2]
    certified_start = next((b for b in backed if b[2].certified), None)
    found, notes = None, []
    if so.method == "nlp":
        x_axes = _stable_start(models, xs, axes, W, st, names, specs, so)
        x0 = x_axes
        if so.multistart:
            say("global phase: a population search over every axis's law")
            # the members and the midpoint of every segment between them: a law that
            # holds on the members only (a resonance cancelled at one temperature) is
            # what the certificate's sweep between them then refuses
            between = [fam.at((a.value + b.value) / 2) for a, b in fam.segments()
                       if a.value is not None and b.value is not None]
            search = search_mimo(models + between, specs, axes, W, st.T_mode, signs,
                                 np.concatenate(xs), w_design, progress=say)
            if search.feasible and search.objective > search.start_objective:
                # the program starts from the search's best, and that point, certified as
                # it is, is an answer beside the program's result
                x0 = search.x
                ctrl = controller_of(axes, x0, W, st.T_mode, names)
                say("certifying the search's best over the whole family")
                found = (ctrl, certify_mimo(fam, ctrl, specs, so.cert_tol, so.cert_points),
                         search)
            elif not search.feasible:
                notes.append(f"global phase: none of its {search.evaluations} candidates met"
                             " the specs on its screen; the joint program runs from the"
                             " per-axis start alone")
            else:
                notes.append(f"global phase: its best of {search.evaluations} candidates"
                             " screened below the per-axis start; the joint program runs"
                             " from that start alone")
        else:
            notes.append(LOCAL_RUN_NOTE)
        x_joint, best_ctrl, certificate = _joint(fam, models, x_axes, axes, W, st, names,
                                                 specs, so, signs, say, w_design, rounds)
        if found is not None:
            # the program is local: from the search's best it may end higher, or lower,
            # than from the per-axis start (seeded three-axis stages: 0.1x to 12x). It is
            # solved from there too when that point screens above the first answer, or
            # the first answer is not certified; the better certified one is the answer
            ahead = found[2].objective > found[2].space.objective(x_joint)[0]
            if ahead or not certificate.certified:
                say("the joint program from the search's best")
                _, ctrl, cert = _joint(fam, models, x0, axes, W, st, names, specs, so,
                                       signs, say, w_design, rounds)
                if _better(ctrl, cert, best_ctrl, certificate):
                    best_ctrl, certificate = ctrl, cert
            else:
                say("the search's best screens below the joint program's answer: not"
                    " polished")
    else:
        certificate = start_cert
    start_note = "each axis designed alone on (G W)_ii with the decoupler" + (
        "" if found is not None else "; the joint program's start")
    comparisons = {"per_axis_start": MimoComparison(start, start_cert, start_note)}
    if found is not None:
        ctrl, cert, search = found
        note = (f"the global phase's best law ({search.evaluations} candidates screened),"
                " certified as it is; the joint program's start")
        if cert.certified and _better(ctrl, cert, best_ctrl, certificate):
            note += "; the answer is it (the joint program ended below it)"
            best_ctrl, certificate = ctrl, cert
        comparisons["global_search"] = MimoComparison(ctrl, cert, note)
    if certified_start is not None:
        factor, ctrl, cert = certified_start
        if not certificate.certified or _least_gain(ctrl) > _least_gain(best_ctrl):
            why = "" if factor == 1.0 else f"; the answer is it at {factor:g} x its gain"
            if certificate.certified:       # the joint design's, certified but lower
                why += ("; the answer is it" if factor == 1.0 else "") + (
                    " (certified, with larger integral gains than the joint design's)")
            best_ctrl, certificate = ctrl, cert
            comparisons["per_axis_start"] = MimoComparison(start, start_cert, start_note + why)
    if not certificate.certified:
        # nothing certified: the least violating of every controller tried (a joint result
        # the program could not hold inside its rows may be far worse than its start)
        tried = [(_miss(certificate), 0, best_ctrl, certificate, None)] + [
            (_miss(c), i + 1, ctrl, c, "the per-axis start, the least violating controller"
             " tried" if f == 1.0 else f"it at {f:g} x its gain, the least violating"
             " controller tried") for i, (f, ctrl, c) in enumerate(backed)]
        if found is not None:
            tried.append((_miss(found[1]), len(tried), found[0], found[1], None))
        _, _, best_ctrl, certificate, why = min(tried, key=lambda t: t[:2])
        if why is not None:
            comparisons["per_axis_start"] = MimoComparison(
                start, start_cert, f"{start_note}; the answer is {why}")
    if compare and fam.n_out > 1:
        say("designing the axes one by one on G_ii, ignoring the coupling (no decoupler)")
        ident = np.eye(fam.n_out)
        xs2, _ = design_axes(models, ident, specs, axis, replace(so, max_rounds=min(
            so.max_rounds, 3)), names, st.T_mode, say, w_design, rounds)
        naive = per_axis_controller(axes, xs2, ident, st.T_mode, names)
        say("certifying them on the coupled plant")
        comparisons["ignoring_coupling"] = MimoComparison(
            naive, certify_mimo(fam, naive, specs, so.cert_tol, so.cert_points),
            "each axis designed alone on G_ii (no decoupler), the coupling ignored")
    return MimoDesignResult(problem=problem, controller=best_ctrl, certificate=certificate,
                            binding=_binding(certificate), rounds=tuple(rounds), start=start,
                            comparisons=comparisons, w_design=w_design,
                            seconds=time.perf_counter() - t0, notes=tuple(notes))
