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

__all__ = ["Loop", "compile_loop", "cache_dir"]

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
    cc = shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")
    if cc is None or os.environ.get("ROBRST_NO_COMPILE"):
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
    out = cache_dir() / f"{name}_{key}.so"
    if not out.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            c = Path(tmp, "f.c")
            c.write_text(src)
            so = Path(tmp, "f.so")
            r = subprocess.run([cc, *flags, "-shared", "-fPIC", "-o", str(so), str(c), "-lm"],
                               capture_output=True, text=True)
            if r.returncode != 0:
                return Loop(step)
            tmp_out = out.with_suffix(f".{os.getpid()}.tmp")
            shutil.copyfile(so, tmp_out)
            os.replace(tmp_out, out)  # atomic: concurrent builders never see half a library
    lib = ctypes.CDLL(str(out))
    lib.robrst_loop.restype = ctypes.c_int
    return Loop(step, lib)
