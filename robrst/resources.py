"""Files the package ships: the paper's problem files, twin file and sweep files.

They live in ``robrst/problems/`` (sweep files in ``robrst/problems/sweeps/``) inside the
installed package, so every documented command runs from any folder without a source checkout.
"""

from importlib import resources
from pathlib import Path

__all__ = ["problems_dir", "builtin_problem", "problem_names", "builtin_twin", "sweeps_dir",
           "sweep_names", "builtin_sweep"]


def problems_dir():
    """The folder holding the built-in problem and twin files."""
    return Path(str(resources.files("robrst") / "problems"))


def problem_names():
    """Names of the built-in problems (file stems, twin files excluded)."""
    return sorted(p.stem for p in problems_dir().glob("*.toml") if not p.stem.startswith("twin_"))


def builtin_problem(name):
    """Path of the built-in problem ``name`` (with or without ``.toml``), or ``None``."""
    stem = Path(name).name.removesuffix(".toml")
    if Path(name).parent != Path(".") or stem not in problem_names():
        return None
    return problems_dir() / f"{stem}.toml"


def builtin_twin(name="twin_paper"):
    """Path of a built-in twin file (default: the paper's actuator)."""
    return problems_dir() / f"{name}.toml"


def sweeps_dir():
    """The folder holding the built-in sweep files (``problems/sweeps``)."""
    return problems_dir() / "sweeps"


def sweep_names():
    """Names of the built-in sweeps (file stems)."""
    return sorted(p.stem for p in sweeps_dir().glob("*.toml"))


def builtin_sweep(name):
    """Path of the built-in sweep ``name`` (with or without ``.toml``), or ``None``."""
    stem = Path(name).name.removesuffix(".toml")
    if Path(name).parent != Path(".") or stem not in sweep_names():
        return None
    return sweeps_dir() / f"{stem}.toml"
