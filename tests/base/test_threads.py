"""One BLAS thread: every BLAS library of the process, CasADi's own included."""

import os
import subprocess
import sys

import pytest

SCRIPT = """
import ctypes
from pathlib import Path
import casadi as ca
from robrst.base.threads import one_blas_thread
x = ca.SX.sym("x")
ca.nlpsol("s", "ipopt", {"x": x, "f": x ** 2}, {"print_time": 0, "ipopt.print_level": 0,
                                                "ipopt.sb": "yes"})(x0=1.0)
found = sorted(Path(ca.__file__).parent.glob("libcasadi-tp-openblas*"))
lib = ctypes.CDLL(str(found[0])) if found else None
if lib is None or not hasattr(lib, "openblas_get_num_threads"):
    print("none")
else:
    outside = lib.openblas_get_num_threads()
    with one_blas_thread(scipy=False):
        inside = lib.openblas_get_num_threads()
    print(outside, inside, lib.openblas_get_num_threads())
"""


def test_casadis_openblas_runs_one_thread_inside_and_is_restored_after():
    """A user's script (no ``OPENBLAS_NUM_THREADS``: the library starts with a thread per
    core, here forced to 2): IPOPT's OpenBLAS runs one thread inside the block, as under
    the command line, and the script's own count after it."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env["OPENBLAS_NUM_THREADS"] = "2"
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    if out == ["none"]:
        pytest.skip("this CasADi build carries no OpenBLAS of its own")
    assert out == ["2", "1", "2"]
