"""Files the package ships: the paper's problem files, twin file and sweep files.

They live in ``robrst/problems/`` (sweep files in ``robrst/problems/sweeps/``) inside the
installed package, so every documented command runs from any folder without a source checkout.
"""

from importlib import resources
from pathlib import Path

__all__ = ["problems_dir", "builtin_problem", "problem_names", "builtin_twin", "sweeps_dir",
           "sweep_names", "builtin_sweep", "find_file"]


def problems_dir():
    """The folder holding the built-in problem and twin files."""
    return Path(str(resources.files("robrst") / "problems"))


def problem_names():
    """Names of the built-in problems (file stems, twin files excluded)."""
    return sorted(p.stem for p in problems_dir().glob("*.toml") if not p.stem.startswith("twin_"))


def builtin_problem(name):
    """Path of the built-in problem ``name`` (with or without ``.toml``), or ``None``.

    ``problems/NAME.toml`` (the package folder's name, as the issues and README spell
    the shipped files) names the built-in too.
    """
    return _builtin(name, problems_dir(), problem_names(), ("problems",))


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
    return _builtin(name, sweeps_dir(), sweep_names(), ("sweeps", "problems/sweeps"))


def _builtin(name, folder, names, aliases):
    p = Path(name)
    stem = p.name.removesuffix(".toml")
    parent = p.parent.as_posix()
    if stem not in names or parent not in (".", *aliases, *(f"robrst/{a}" for a in aliases)):
        return None
    return folder / f"{stem}.toml"


def find_file(name_or_path, kind):
    """``name_or_path`` if it exists, else the built-in ``kind`` of that name, else ``None``.

    ``kind`` is ``"problem"`` or ``"sweep"``.  A folder of that name (``./paper/``) does not
    hide the built-in; with no built-in of that name the folder is returned (and refused by
    the reader, naming it).
    """
    p = Path(name_or_path)
    if p.exists() and not p.is_dir():
        return p
    builtin = (builtin_problem if kind == "problem" else builtin_sweep)(str(name_or_path))
    return builtin if builtin is not None or not p.exists() else p
