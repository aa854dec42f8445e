"""A signal stops IPOPT at its next iteration (:mod:`robrst.base.interrupt`).

A Python signal handler cannot raise inside IPOPT: CasADi catches what its callbacks raise
and reports a failed solve, and the run goes on.  :class:`StopWhenAsked` is IPOPT's
iteration callback: it asks IPOPT to stop (``User_Requested_Stop``) once a signal asked the
run to; with the solve inside :func:`robrst.base.interrupt.solver_call`, which raises
:class:`~robrst.base.interrupt.Interrupted` on leaving, Ctrl-C or ``kill`` ends the run
within an iteration.  Every IPOPT program of robrst (one loop and several axes) uses it.
"""

from __future__ import annotations

import casadi as ca

from robrst.base.interrupt import requested

__all__ = ["StopWhenAsked"]


class StopWhenAsked(ca.Callback):
    """IPOPT's iteration callback: asks it to stop (``User_Requested_Stop``) once a signal
    asked the run to (:func:`robrst.base.interrupt.requested`), so that Ctrl-C or ``kill``
    ends a solve at its next iteration instead of its last.

    Parameters
    ----------
    nx, ng : int
        The program's variables and constraints.
    """

    def __init__(self, nx: int, ng: int) -> None:
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.construct("stop_when_asked", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "stop"

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg: list) -> list:
        return [1 if requested() else 0]
