"""python-control's view of a sampled loop, independent of robrst's kernels (test helper).

The plant goes through ``control.c2d`` (ZOH) in a time-scaled variable (coefficients
O(1)); the controller is the exported law ``R_z, S_z, T_z`` read as discrete transfer
functions; peaks are taken on a dense unit-circle grid with local refinement.
"""

import control
import numpy as np
from scipy.optimize import minimize_scalar


def time_scale(plant):
    """An O(1)-making time scale [rad/s] for ``plant`` (any will do: the loop is the same)."""
    return float(abs(plant.A[-1]) ** (1.0 / plant.n)) or 1.0


def zoh_plant(plant, fs, delay=0):
    """ZOH model of ``plant`` at ``fs`` behind ``delay`` samples, with ``dt = w0/fs``."""
    w0 = time_scale(plant)
    n = plant.n
    num = np.concatenate([np.zeros(n + 1 - len(plant.B)), plant.B])
    k = w0 ** -np.arange(n + 1)
    h = w0 / fs
    Pd = control.c2d(control.ss(control.tf(num * k, plant.A * k)), h, "zoh")
    if delay:
        Pd = Pd * control.tf([1.0], [1.0] + [0.0] * delay, h)
    return Pd


def resp(sys, z):
    """Frequency response of a SISO python-control system at the points ``z``.

    Transfer functions through python-control; state spaces by one batched solve of
    ``C (zI - A)^-1 B + D`` (python-control evaluates them point by point).
    """
    z = np.atleast_1d(z)
    if isinstance(sys, control.TransferFunction):
        return np.asarray(sys(z)).ravel()
    n = sys.A.shape[0]
    X = np.linalg.solve(z[:, None, None] * np.eye(n) - sys.A, np.broadcast_to(sys.B, (z.size, n, 1)))
    return (sys.C @ X)[:, 0, 0] + sys.D[0, 0]


GRID = np.concatenate([np.linspace(1e-6, np.pi, 20000), [np.pi]])


def unit_circle_max(f, values=None):
    """max over theta in (0, pi] of ``|f(exp(j theta))|``: grid, Nyquist, local refinement.

    ``values`` are ``f`` on :data:`GRID` when already known.
    """
    th = GRID
    g = np.abs(f(np.exp(1j * th)) if values is None else values)
    i = int(np.argmax(g))
    lo, hi = th[max(i - 1, 0)], th[min(i + 1, th.size - 2)]
    r = minimize_scalar(lambda x: -float(np.abs(f(np.exp(1j * np.array([x])))).max()),
                        bounds=(lo, hi), method="bounded", options={"xatol": 1e-13})
    return max(float(g[i]), -r.fun)


def feedback_law(exported, dt, form="direct"):
    """``K_R`` (``u = -K_R y`` part) of an exported controller as a python-control system.

    ``form="direct"``: ``R_z/S_z`` as a discrete transfer function; ``"sections"``: the
    state space of the sections (``DigitalController.to_ss``), relabelled with ``dt``.
    """
    if form == "direct":
        d = exported.digital
        return control.tf(list(d.R_z), list(d.S_z), dt)
    K = -exported.digital.to_ss()[0, 1]
    return control.ss(K.A, K.B, K.C, K.D, dt)


def loop_figures(plant, KR, fs, delay=0):
    """Sampled-loop figures from python-control: Ms, Mt, Mu, closed-loop spectral radius.

    ``KR`` is the feedback law with the ``dt`` of :func:`zoh_plant`.  ``S = 1/(1 + L)``,
    ``T = L/(1 + L)``, ``U = K_R/(1 + L)`` pointwise from python-control's frequency
    responses (no transfer-function algebra: expanding ``L/(1 + L)`` into polynomials
    loses the near-cancelling creep pole).
    """
    Pss = zoh_plant(plant, fs, delay)
    Ptf = control.tf(Pss)
    L = lambda z: resp(Ptf, z) * resp(KR, z)                            # noqa: E731
    z = np.exp(1j * GRID)
    Kz = resp(KR, z)
    Lz = resp(Ptf, z) * Kz
    poles = control.feedback(Pss, KR).poles()
    return {"Ms": unit_circle_max(lambda z: 1 / (1 + L(z)), 1 / (1 + Lz)),
            "Mt": unit_circle_max(lambda z: L(z) / (1 + L(z)), Lz / (1 + Lz)),
            "Mu": unit_circle_max(lambda z: resp(KR, z) / (1 + L(z)), Kz / (1 + Lz)),
            "spectral_radius": float(np.max(np.abs(poles)))}
