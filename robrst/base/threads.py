"""One BLAS thread for robrst's own computations.

robrst's matrices are small (tens of states): a second OpenBLAS thread does not make
them faster, it spins between the calls and doubles the CPU time (paper_robust's design,
in process on a 2-core machine: 0.72 s CPU with two threads, 0.42 s with one, the same
wall time).  :func:`one_blas_thread` limits every BLAS library loaded in the process
(numpy's and SciPy's each carry one) for the duration of a ``with`` block and restores
the caller's settings afterwards.  A library is only limited once loaded, so SciPy's is
loaded first when the computation will use it (``scipy=True``).
"""

import os
from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import threadpool_limits

__all__ = ["one_blas_thread", "available_cores"]


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
    with threadpool_limits(1, "blas"):
        yield
