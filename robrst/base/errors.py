"""robrst's exceptions.

Every error a user can provoke with bad input is one of these; the CLI turns them
into a single line on stderr and a non-zero exit code.
"""

__all__ = [
    "RobrstError",
    "SpecError",
    "DegreeError",
    "CoprimeError",
    "DataError",
    "SolverError",
    "InfeasibleError",
    "OutputError",
]


class RobrstError(Exception):
    """Base class of every exception raised on purpose by robrst."""


class SpecError(RobrstError, ValueError):
    """A problem file or argument is malformed (names the file and key path)."""


class DegreeError(SpecError):
    """Polynomial degrees are inconsistent (improper controller, too low order)."""


class CoprimeError(RobrstError, ValueError):
    """A and B share a root, so the Diophantine equation has no unique solution.

    Parameters
    ----------
    message : str
        The error message (names the common root).
    root : complex, optional
        The common root of ``A·Sf`` and ``B·Rf`` [rad/s].
    """

    def __init__(self, message: str, root: complex | None = None) -> None:
        super().__init__(message)
        self.root = root


class DataError(RobrstError, ValueError):
    """A data file is malformed (names the file, line or column)."""


class SolverError(RobrstError, RuntimeError):
    """A numerical solve failed; its result must not be used."""


class InfeasibleError(SolverError):
    """The specifications cannot be met; the message names the binding constraint.

    Parameters
    ----------
    message : str
        The error message.
    binding : dict, optional
        The binding constraints (name -> multiplier or figure); ``{}`` when not given.
    """

    def __init__(self, message: str, binding: dict | None = None) -> None:
        super().__init__(message)
        self.binding = binding or {}


class OutputError(RobrstError, ValueError):
    """An output path robrst must not or cannot write (names the path and why)."""
