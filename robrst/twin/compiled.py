"""Compiled simulation loops: CasADi C code generation + a C driver loop, built with gcc.

``compile_loop(step)`` generates C for a step function ``(x, p, theta) -> (x+, y)``,
adds a driver that runs it over N samples, builds a shared library once per distinct
source (SHA-256 key) in ``$ROBRST_CACHE`` (default ``~/.cache/robrst``) and returns a
:class:`Loop`.  Without a working compiler, :class:`Loop` runs the same step through
CasADi's ``mapaccum`` in its virtual machine (same numbers, slower) and says so.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

import casadi as ca
import numpy as np

__all__ = ["Loop", "compile_loop", "cache_dir", "ControlledLoop", "compile_controlled_loop",
           "compiler"]

_DRIVER = r"""
#include <stdlib.h>
#include <string.h>
int robrst_loop(long N, double* x, const double* P, const double* theta, double* Y) {
  casadi_int sz_arg, sz_res, sz_iw, sz_w;
  FNAME_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
  const casadi_real** arg = malloc(sizeof(casadi_real*) * (sz_arg > 3 ? sz_arg : 3));
  casadi_real** res = malloc(sizeof(casadi_real*) * (sz_res > 2 ? sz_res : 2));
  casadi_int* iw = malloc(sizeof(casadi_int) * (sz_iw + 1));
  casadi_real* w = malloc(sizeof(casadi_real) * (sz_w + 1));
  casadi_real xn[NX];
  int flag = 0;
  for (long k = 0; k < N; ++k) {
    arg[0] = x; arg[1] = P + NP * k; arg[2] = theta;
    res[0] = xn; res[1] = Y + NY * k;
    if (FNAME(arg, res, iw, w, 0)) { flag = 1; break; }
    memcpy(x, xn, sizeof(casadi_real) * NX);
  }
  free(arg); free(res); free(iw); free(w);
  return flag;
}
"""


def cache_dir() -> Path:
    """Where compiled loops are cached: ``$ROBRST_CACHE``, else ``~/.cache/robrst``.

    Returns
    -------
    pathlib.Path
    """
    return Path(os.environ.get("ROBRST_CACHE", Path.home() / ".cache" / "robrst"))


class Loop:
    """Run ``step`` over the columns of ``P``: compiled C when available, else the VM.

    Calling it as ``loop(P, x0, theta)`` returns the outputs (one column per sample) and
    the final state.

    Parameters
    ----------
    step : casadi.Function
        ``(x, p, theta) -> (x_next, out)``.
    lib : ctypes.CDLL, optional
        The compiled driver loop (``None``: CasADi's virtual machine).

    Attributes
    ----------
    nx, np_, ny : int
        Sizes of the state, the per-sample input and the output.
    is_compiled : bool
        The loop runs compiled C.
    """

    def __init__(self, step: ca.Function, lib: ctypes.CDLL | None = None) -> None:
        self.step, self.lib = step, lib
        self.nx = step.size1_in(0)
        self.np_ = step.size1_in(1)
        self.ny = step.size1_out(1)
        self.is_compiled = lib is not None
        self._vm = None

    def __call__(self, P, x0, theta):
        """Outputs ``(ny x N)`` and the final state."""
        N = P.shape[1]
        x = np.ascontiguousarray(x0, dtype=float).copy()
        if self.lib is not None:
            Pc = np.ascontiguousarray(P.T, dtype=float)
            th = np.ascontiguousarray(theta, dtype=float)
            Y = np.empty((N, self.ny))
            dp = ctypes.POINTER(ctypes.c_double)
            flag = self.lib.robrst_loop(ctypes.c_long(N), x.ctypes.data_as(dp),
                                        Pc.ctypes.data_as(dp), th.ctypes.data_as(dp),
                                        Y.ctypes.data_as(dp))
            if flag:
                raise RuntimeError("compiled twin step failed")
            return Y.T, x
        chunk = 2000
        if self._vm is None:
            self._vm = self.step.mapaccum("twin_chunk", chunk)
        outs = []
        for c in range(0, N, chunk):
            Pk = P[:, c:c + chunk]
            n = Pk.shape[1]
            if n < chunk:
                Pk = np.hstack([Pk, np.repeat(Pk[:, -1:], chunk - n, axis=1)])
            X, Y = self._vm(x, Pk, theta)
            outs.append(np.asarray(Y)[:, :n])
            x = np.asarray(X)[:, n - 1]
        return np.hstack(outs), x


def compiler() -> str | None:
    """The C compiler robrst uses.

    Returns
    -------
    str or None
        ``$CC``, gcc or cc; ``None`` without one (also with ``ROBRST_NO_COMPILE`` set).
    """
    if os.environ.get("ROBRST_NO_COMPILE"):
        return None
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


def compile_loop(step: ca.Function, flags: Sequence[str] = ("-O2",)) -> Loop:
    """A :class:`Loop` for ``step``; compiled when a C compiler works, else the VM.

    Parameters
    ----------
    step : casadi.Function
        ``(x, p, theta) -> (x_next, out)``.
    flags : sequence of str
        C compiler flags.

    Returns
    -------
    Loop
        The same numbers either way (the compiled loop is cached by the step's hash).
    """
    cc = compiler()
    if cc is None:
        return Loop(step)
    name = step.name()
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        cg.add(step)
        cg.generate(tmp + os.sep)      # a prefix, not chdir: threads may compile at once
        src = Path(tmp, f"{name}.c").read_text()
    driver = (_DRIVER.replace("FNAME", name).replace("NX", str(step.size1_in(0)))
              .replace("NP", str(step.size1_in(1))).replace("NY", str(step.size1_out(1))))
    src = src + driver
    key = hashlib.sha256((src + " ".join(flags)).encode()).hexdigest()[:16]

    def build(so):
        c = so.with_name("f.c")
        c.write_text(src)
        r = subprocess.run([cc, *flags, "-shared", "-fPIC", "-o", str(so), str(c), "-lm"],
                           capture_output=True, text=True)
        return r.returncode == 0

    lib = _library(cache_dir() / f"{name}_{key}.so", build)
    if lib is None:
        return Loop(step)
    lib.robrst_loop.restype = ctypes.c_int
    return Loop(step, lib)


def _library(out, build):
    """The shared library ``out`` of the cache, built once by ``build(path) -> ok`` when
    missing or damaged (``None`` when the build fails).  A cache that cannot be written
    (``ROBRST_CACHE`` a file, a read-only or full disk): the library just built is loaded
    from its temporary folder, not cached; the same code either way."""
    try:
        if out.exists():
            return ctypes.CDLL(str(out))
    except OSError:
        pass                         # a damaged library: built again and replaced below
    with tempfile.TemporaryDirectory() as tmp:
        so = Path(tmp, "f.so")
        if not build(so):
            return None
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            tmp_out = out.with_suffix(f".{os.getpid()}.tmp")
            shutil.copyfile(so, tmp_out)
            os.replace(tmp_out, out)  # atomic: concurrent builders never see half a library
            return ctypes.CDLL(str(out))
        except OSError:
            return ctypes.CDLL(str(so))   # loaded: the file may go with its folder


_CL_DRIVER = r"""
#include <stdlib.h>
#include <string.h>
#include "HEADER"
static int robrst_call(int (*f)(const casadi_real**, casadi_real**, casadi_int*, casadi_real*, int),
                       const casadi_real** arg, casadi_real** res, casadi_int* iw,
                       casadi_real* w) {
  return f(arg, res, iw, w, 0);
}
int robrst_cl_loop(long N, double* x, const double* P, const double* theta, double* Y,
                   long delay) {
  casadi_int a1, r1, i1, w1, a2, r2, i2, w2;
  STEP_work(&a1, &r1, &i1, &w1);
  OUT_work(&a2, &r2, &i2, &w2);
  casadi_int na = (a1 > a2 ? a1 : a2) + 3, nr = (r1 > r2 ? r1 : r2) + 2;
  casadi_int ni = (i1 > i2 ? i1 : i2) + 1, nw = (w1 > w2 ? w1 : w2) + 1;
  const casadi_real** arg = malloc(sizeof(casadi_real*) * na);
  casadi_real** res = malloc(sizeof(casadi_real*) * nr);
  casadi_int* iw = malloc(sizeof(casadi_int) * ni);
  casadi_real* w = malloc(sizeof(casadi_real) * nw);
  double* pend = calloc((size_t)(delay + 1), sizeof(double));
  casadi_real xn[NX], p[3], yo[1], out[NY];
  PREFIX_state st;
  int flag = 0;
  PREFIX_init(&st);
  for (long k = 0; k < N; ++k) {
    double u, ua;
    p[0] = 0.0; p[1] = P[3 * k + 1]; p[2] = P[3 * k + 2];
    arg[0] = x; arg[1] = p; arg[2] = theta; res[0] = yo;
    if (robrst_call(OUT, arg, res, iw, w)) { flag = 1; break; }
    u = (double) PREFIX_step(&st, (PREFIX_real) P[3 * k], (PREFIX_real) yo[0]);
    ua = u;
    if (delay > 0) {
      ua = pend[0];
      memmove(pend, pend + 1, sizeof(double) * (size_t)(delay - 1));
      pend[delay - 1] = u;
    }
    p[0] = ua;
    arg[0] = x; arg[1] = p; arg[2] = theta; res[0] = xn; res[1] = out;
    if (robrst_call(STEP, arg, res, iw, w)) { flag = 1; break; }
    memcpy(x, xn, sizeof(casadi_real) * NX);
    Y[4 * k] = out[0]; Y[4 * k + 1] = out[1]; Y[4 * k + 2] = out[2]; Y[4 * k + 3] = u;
  }
  free(arg); free(res); free(iw); free(w); free(pend);
  return flag;
}
"""


class ControlledLoop:
    """The twin's step in closed loop with a digital controller, sample by sample.

    Each sample: the measured output at the sample (``output``), the controller's command
    for ``(yr, y)``, held over the sample after ``delay`` samples of computation delay,
    then the twin's ``step``.  ``lib``: the twin's C and the controller's own C compiled
    together (:func:`compile_controlled_loop`); else ``py_step(yr, y) -> u``, a Python step
    with the same arithmetic, around CasADi's VM (slower, the same numbers).

    Parameters
    ----------
    step, output : casadi.Function
        The twin's step and its measurement at the sample.
    delay : int
        Computation delay [samples].
    lib : ctypes.CDLL, optional
        The compiled loop.
    py_step : callable, optional
        ``step(yr, y) -> u``.

    Raises
    ------
    ValueError
        Neither ``lib`` nor ``py_step``.
    """

    def __init__(self, step: object, output: object, delay: int = 0, lib: object = None,
                 py_step: object = None):
        if lib is None and py_step is None:
            raise ValueError("ControlledLoop needs a compiled library or a Python step")
        self.step, self.output, self.lib, self.py_step = step, output, lib, py_step
        self.delay = int(delay)
        self.nx = step.size1_in(0)
        self.is_compiled = lib is not None

    def __call__(self, P: np.ndarray, x0: np.ndarray, theta: np.ndarray) -> tuple:
        """Run the loop over the columns of ``P``.

        Parameters
        ----------
        P : numpy.ndarray
            ``3 x N``: reference, temperature, noise per sample.
        x0 : numpy.ndarray
            The twin's initial state.
        theta : numpy.ndarray
            The twin's parameters.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            Outputs ``(4 x N)`` — measured and true output [µm], applied and commanded
            voltage [V] — and the final state.

        Raises
        ------
        RuntimeError
            The compiled step failed.
        """
        N = P.shape[1]
        x = np.ascontiguousarray(x0, dtype=float).copy()
        th = np.ascontiguousarray(theta, dtype=float)
        if self.lib is not None:
            Pc = np.ascontiguousarray(P.T, dtype=float)
            Y = np.empty((N, 4))
            dp = ctypes.POINTER(ctypes.c_double)
            flag = self.lib.robrst_cl_loop(ctypes.c_long(N), x.ctypes.data_as(dp),
                                           Pc.ctypes.data_as(dp), th.ctypes.data_as(dp),
                                           Y.ctypes.data_as(dp), ctypes.c_long(self.delay))
            if flag:
                raise RuntimeError("compiled closed-loop twin step failed")
            return Y.T, x
        Y = np.empty((4, N))
        pend = [0.0] * self.delay
        for k in range(N):
            p = np.array([0.0, P[1, k], P[2, k]])
            y = float(self.output(x, p, th))
            u = float(self.py_step(P[0, k], y))
            pend.append(u)
            p[0] = pend.pop(0)
            xn, out = self.step(x, p, th)
            x = np.asarray(xn, float).ravel()
            out = np.asarray(out, float).ravel()
            Y[:3, k], Y[3, k] = out[:3], u
        return Y, x


def compile_controlled_loop(step: object, output: object, files: dict, header: str,
                            prefix: str, real: str = "double", delay: int = 0,
                            flags: tuple = ("-O2", "-ffp-contract=off")) -> object:
    """A compiled :class:`ControlledLoop`: the twin's ``step`` and ``output`` (CasADi code
    generation) with a controller's own C files, or ``None`` without a working compiler.

    Parameters
    ----------
    step, output : casadi.Function
        ``(x, [u, T, noise], theta) -> (x+, [y_meas, y_true, u_applied])`` and
        ``(x, p, theta) -> y_meas`` (a strictly proper plant: ``y`` at the sample).
    files : dict
        ``{file name: text}`` of the controller's C (its header and source).
    header : str
        The header's file name (included by the driver).
    prefix : str
        The controller's C prefix: ``<prefix>_state``, ``<prefix>_init``,
        ``<prefix>_step``, ``<PREFIX>_REAL``.
    real : {"double", "float"}
        The controller's arithmetic (``-D<PREFIX>_REAL=...``).
    delay : int
        Computation delay [samples].
    flags : tuple of str
        Compiler flags (no FMA contraction: the controller's operations as written).

    Returns
    -------
    ControlledLoop or None

    Raises
    ------
    RuntimeError
        The compiler refused the sources (its first lines in the message).
    """
    cc = compiler()
    if cc is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator("twin_cl.c", {"with_header": False})
        cg.add(step)
        cg.add(output)
        cg.generate(tmp + os.sep)
        twin_src = Path(tmp, "twin_cl.c").read_text()
    P = prefix.upper()
    driver = (_CL_DRIVER.replace("HEADER", header).replace("STEP", step.name())
              .replace("OUT", output.name()).replace("NX", str(step.size1_in(0)))
              .replace("NY", str(step.size1_out(1))).replace("PREFIX_state", f"{prefix}_state")
              .replace("PREFIX_init", f"{prefix}_init").replace("PREFIX_step", f"{prefix}_step")
              .replace("PREFIX_real", f"{prefix}_real"))
    defines = (f"-D{P}_REAL={real}",)
    twin_src = twin_src + driver      # one unit: the driver calls the generated functions
    key_src = "\n".join([twin_src, *(files[k] for k in sorted(files)),
                         " ".join(flags + defines)])
    key = hashlib.sha256(key_src.encode()).hexdigest()[:16]

    def build(so):
        tmp = so.parent
        for name, text in files.items():
            Path(tmp, name).write_text(text)
        Path(tmp, "twin_cl.c").write_text(twin_src)
        sources = [str(Path(tmp, n)) for n in files if n.endswith(".c")]
        r = subprocess.run([cc, *flags, *defines, "-shared", "-fPIC", "-o", str(so),
                            str(Path(tmp, "twin_cl.c")), *sources, "-lm"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"compiling the controller with the twin failed:"
                               f" {r.stderr.strip()[:400]}")
        return True

    lib = _library(cache_dir() / f"twin_cl_{key}.so", build)
    lib.robrst_cl_loop.restype = ctypes.c_int
    return ControlledLoop(step, output, delay, lib=lib)
