"""Files the package ships: the paper's problem files, twin file and sweep files.

In a source checkout they live in the top-level ``problems/`` folder (sweep files in
``problems/sweeps/``); installed, the same files are the data package ``robrst.problems``
(``pyproject.toml`` maps the folder), so every documented command runs from any folder.
"""

import importlib.util
from pathlib import Path

__all__ = ["problems_dir", "builtin_problem", "problem_names", "builtin_twin", "sweeps_dir",
           "sweep_names", "builtin_sweep", "find_file"]


CHECKOUT_PROBLEMS = Path(__file__).resolve().parents[2] / "problems"


def problems_dir():
    """The folder holding the built-in problem and twin files.

    Returns
    -------
    pathlib.Path
        The installed data package ``robrst.problems``; when robrst is imported from a
        source checkout (no such package on the path), the checkout's ``problems/``.
    """
    spec = importlib.util.find_spec("robrst.problems")
    if spec is None or not spec.submodule_search_locations:
        return CHECKOUT_PROBLEMS
    return Path(next(iter(spec.submodule_search_locations)))


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
    if builtin is None and p.is_symlink():    # a broken link or a loop: the reader names it
        return p
    return builtin if builtin is not None or not p.exists() else p
