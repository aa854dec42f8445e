"""One BLAS thread for robrst's own computations.

robrst's matrices are small (tens of states): a second OpenBLAS thread does not make
them faster, it spins between the calls and doubles the CPU time (paper_robust's design,
in process on a 2-core machine: 0.72 s CPU with two threads, 0.42 s with one, the same
wall time).  :func:`one_blas_thread` limits every BLAS library loaded in the process
(numpy's and SciPy's each carry one) for the duration of a ``with`` block and restores
the caller's settings afterwards.  A library is only limited once loaded, so SciPy's is
loaded first when the computation will use it (``scipy=True``).

CasADi carries a third OpenBLAS (``libcasadi-tp-openblas``: the linear algebra of IPOPT's
MUMPS) that threadpoolctl does not recognise by name; it reads ``OPENBLAS_NUM_THREADS``
once, when it loads.  The command line sets that variable before anything loads; in a
user's script it ran as many threads as cores, so the same problem took a different
solver path (other rounding in the last bits) through :func:`robrst.design.run_problem`
than through ``robrst design``, and spun a second core.  :func:`one_blas_thread` limits it
too, through its own ``openblas_set_num_threads``.
"""

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from threadpoolctl import threadpool_limits

__all__ = ["one_blas_thread", "available_cores"]

# CasADi's own OpenBLAS, by platform (the libraries its IPOPT plugin links)
_CASADI_OPENBLAS = ("libcasadi-tp-openblas.so", "libcasadi-tp-openblas.so.0",
                    "libcasadi-tp-openblas.dylib", "libcasadi-tp-openblas.dll")


def available_cores() -> int:
    """The cores this process may use (Linux: its affinity; else the machine's).

    Returns
    -------
    int
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # not on Linux
        return os.cpu_count() or 1


@contextmanager
def one_blas_thread(scipy: bool = True) -> Iterator[None]:
    """Run the ``with`` block with one BLAS thread in every BLAS library.

    Parameters
    ----------
    scipy : bool
        Load ``scipy.linalg`` first (the sampled loop, step responses and balancing use
        it), so that its BLAS is limited as well; ``False`` for computations that never
        load SciPy (importing it costs 0.15-0.3 s).

    Yields
    ------
    None
        Inside the block every loaded BLAS library runs one thread; the caller's limits
        are restored on exit.

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.base.threads import one_blas_thread
    >>> with one_blas_thread(scipy=False):
    ...     float(np.linalg.norm(np.eye(3)))
    1.7320508075688772
    """
    if scipy:
        import scipy.linalg  # noqa: F401 — its OpenBLAS must be loaded to be limited
    lib = _casadi_openblas()
    before = lib.openblas_get_num_threads() if lib is not None else None
    try:
        if lib is not None:
            lib.openblas_set_num_threads(1)
        with threadpool_limits(1, "blas"):
            yield
    finally:
        if lib is not None and before and before > 0:
            lib.openblas_set_num_threads(before)


def _casadi_openblas() -> ctypes.CDLL | None:
    """CasADi's own OpenBLAS (IPOPT's linear algebra), loaded, or ``None``.

    Only when CasADi is imported already (a computation that solves a program has
    imported it; loading CasADi here would cost every other computation its import).
    The library is the one IPOPT's plugin links: loading it here first changes nothing
    but the moment it reads its environment.

    Returns
    -------
    ctypes.CDLL or None
        With ``openblas_get_num_threads`` and ``openblas_set_num_threads``; ``None`` on a
        build without a bundled OpenBLAS (or one that does not export them).
    """
    casadi = sys.modules.get("casadi")
    where = getattr(casadi, "__file__", None)
    if where is None:
        return None
    for name in _CASADI_OPENBLAS:      # named, not globbed: a listing of CasADi's folder
        path = Path(where).parent / name  # cost 0.12 ms on every block
        if not path.exists():
            continue
        try:
            lib = ctypes.CDLL(str(path))
            lib.openblas_get_num_threads.restype = ctypes.c_int
            lib.openblas_set_num_threads.argtypes = [ctypes.c_int]
        except (OSError, AttributeError):
            continue
        return lib
    return None
