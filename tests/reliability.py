"""Random problems of :mod:`random_problems` through robrst, every claim re-checked.

:func:`generator` plugs :func:`random_problems.draw_case` into the ``gen(rng) -> Problem``
hook of ``tests/synthesis/test_random_problems.py``; :func:`run_seed` designs one seeded problem
as a user would (its TOML file through ``robrst design FILE --json``, in this process) and
classifies the outcome with the independent checker (:func:`random_problems.check`):

* ``certified``: ``certified: true`` and the checker confirms every claim;
* ``wrong``: ``certified: true`` and the checker refutes it (unstable somewhere on the
  temperature interval, or a peak above its bound) — a wrong certificate;
* ``refused``: an answer that is not a certificate (``not_certified`` with the best
  controller and what it achieves) or a clear robrst error (``robrst.base.errors``);
* ``failed``: anything else (a Python exception that is not robrst's — the command line's
  last-resort line :data:`robrst.cli.LAST_RESORT` or a traceback —, no answer);
* ``hung``: no answer within the time limit (:func:`run_many` only).

``figure_low`` counts certificates (certified or not) whose reported exact peak at a
family member is below the checker's dense-grid lower bound by more than 1e-6.

``python tests/reliability.py N [SEED0] [TIMEOUT_S] [WALL_S]`` runs seeds
``SEED0 .. SEED0+N-1`` in 2 worker processes (no new seed after ``WALL_S`` seconds) and
prints the table of the README ("Reliability").
"""

from __future__ import annotations

import contextlib
import io
import json
import multiprocessing as mp
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from random_problems import NumpyChooser, check, draw_case, random_case

__all__ = ["Outcome", "generator", "run_seed", "run_many", "table"]


def generator(rng):
    """``gen(rng) -> Problem`` for :func:`random_synthesis.evaluate` (a drawn document)."""
    seed = int(rng.integers(0, 2**31))
    case = draw_case(NumpyChooser(seed), seed=seed)
    return case.problem()


@dataclass(frozen=True)
class Outcome:
    """What happened to one seeded random problem."""

    seed: int
    status: str          # certified | wrong | refused | failed | hung
    detail: str
    kind: dict
    seconds: float
    figure_low: bool = False


@dataclass(frozen=True)
class _Answer:
    """A design answer read back from ``robrst design --json``: what the checker reads."""

    doc: dict
    controller: object

    def as_dict(self):
        return self.doc


def run_seed(seed, n_temps=33, n_grid=20000, method=None):
    """Design random problem ``seed`` (``method`` forces ``solver.method``) through the
    command line and classify the outcome (module docstring)."""
    from robrst.cli import LAST_RESORT, main
    from robrst.core.rst import RSTController

    t0 = time.perf_counter()
    case = random_case(seed, method=method)
    out, err = io.StringIO(), io.StringIO()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"random_{seed}.toml"
        path.write_text(case.toml(), encoding="utf-8")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main(["design", str(path), "--json", "--quiet"])
            except BaseException as exc:   # noqa: BLE001 - the command line must not raise
                rc, _ = None, err.write(f"raised {type(exc).__name__}: {exc}")
    err = err.getvalue().strip()
    lines = [x for x in err.splitlines() if not x.startswith("robrst: note:")]
    seconds = time.perf_counter() - t0
    if LAST_RESORT in err or "Traceback" in err or rc is None:
        return Outcome(seed, "failed", err[:400], case.kind, seconds)
    if rc == 2:
        ok = len(lines) == 1 and lines[0].startswith("robrst: error: ")
        return Outcome(seed, "refused" if ok else "failed", f"error: {err[:400]}", case.kind,
                       seconds)
    try:
        doc = json.loads(out.getvalue())
        ctrl = RSTController(**{k: doc["controller"][k] for k in "RST"})
    except (ValueError, KeyError, TypeError) as exc:
        return Outcome(seed, "failed", f"no JSON answer ({exc})", case.kind, seconds)
    if rc != (0 if doc["certified"] else 1) or not (doc["certified"] or doc["best_achievable"]):
        return Outcome(seed, "failed", f"no answer (exit {rc})", case.kind, seconds)
    res = _Answer(doc, ctrl)
    bad = check(case.data, res, n_temps=n_temps, n_grid=n_grid)
    wrong = [d for d in bad if d.what != "figure"]
    low = any(d.what == "figure" for d in bad)
    status = ("wrong" if wrong else "certified") if doc["certified"] else "refused"
    detail = "; ".join(d.detail for d in bad) or doc["status"]
    return Outcome(seed, status, detail, case.kind, time.perf_counter() - t0, low)


def _worker(seed, q):
    try:
        q.put(run_seed(seed))
    except Exception as exc:   # noqa: BLE001 - the checker itself failed: report, do not hide
        q.put(Outcome(seed, "failed", f"checker: {exc!r}", {}, 0.0))


def run_many(seeds, timeout_s=120.0, workers=2, wall_s=None):
    """Run ``seeds`` in ``workers`` processes, each problem killed after ``timeout_s``;
    with ``wall_s``, no new seed starts after that many seconds."""
    ctx = mp.get_context("fork")
    pending, running, out = list(seeds), {}, []
    start = time.perf_counter()
    while pending or running:
        if wall_s is not None and time.perf_counter() - start > wall_s:
            pending = []
        while pending and len(running) < workers:
            s = pending.pop(0)
            q = ctx.Queue()
            p = ctx.Process(target=_worker, args=(s, q))
            p.start()
            running[s] = (p, q, time.perf_counter())
        time.sleep(0.05)
        for s, (p, q, t0) in list(running.items()):
            if not q.empty():
                out.append(q.get())
                p.join()
                del running[s]
            elif time.perf_counter() - t0 > timeout_s:
                p.kill()
                p.join()
                out.append(Outcome(s, "hung", f"> {timeout_s:g} s", {}, timeout_s))
                del running[s]
            elif not p.is_alive() and q.empty():
                out.append(Outcome(s, "failed", f"worker died ({p.exitcode})", {}, 0.0))
                del running[s]
    return sorted(out, key=lambda o: o.seed)


def table(outcomes):
    """Markdown rows of the README's reliability table."""
    names = ("certified", "wrong", "refused", "failed", "hung")
    rows = ["| problems | " + " | ".join(names) + " | exact peak below the checker |"
            " median s |", "|---" * (len(names) + 3) + "|"]
    counts = [sum(o.status == k for o in outcomes) for k in names]
    med = np.median([o.seconds for o in outcomes]) if outcomes else 0.0
    rows.append(f"| {len(outcomes)} | " + " | ".join(map(str, counts)) +
                f" | {sum(o.figure_low for o in outcomes)} | {med:.1f} |")
    return rows


if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    s0 = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    limit = float(sys.argv[3]) if len(sys.argv) > 3 else 120.0
    wall = float(sys.argv[4]) if len(sys.argv) > 4 else None
    t0 = time.perf_counter()
    res = run_many(range(s0, s0 + n), timeout_s=limit, wall_s=wall)
    for o in res:
        if o.status != "certified" or o.figure_low:
            print(o.seed, o.status, o.kind, o.detail[:300], flush=True)
    print("\n".join(table(res)))
    print(f"wall {time.perf_counter() - t0:.0f} s")
