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


def problems_dir() -> Path:
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


def problem_names() -> list[str]:
    """Names of the built-in problems (file stems, twin files excluded).

    Returns
    -------
    list of str
        Sorted, e.g. ``["paper", "paper_robust", "paper_robust_continuous"]``.
    """
    return sorted(p.stem for p in problems_dir().glob("*.toml") if not p.stem.startswith("twin_"))


def builtin_problem(name: str) -> Path | None:
    """Path of the built-in problem ``name`` (with or without ``.toml``), or ``None``.

    ``problems/NAME.toml`` (the package folder's name, as the documentation spells the
    shipped files) names the built-in too.

    Parameters
    ----------
    name : str
        ``"paper_robust"``, ``"paper_robust.toml"`` or ``"problems/paper_robust.toml"``.

    Returns
    -------
    pathlib.Path or None
        The shipped file, or ``None`` when no built-in problem has that name.

    Examples
    --------
    >>> from robrst.base.resources import builtin_problem
    >>> builtin_problem("paper").name
    'paper.toml'
    >>> builtin_problem("mine") is None
    True
    """
    return _builtin(name, problems_dir(), problem_names(), ("problems",))


def builtin_twin(name: str = "twin_paper") -> Path:
    """Path of a built-in twin file (default: the paper's actuator).

    Parameters
    ----------
    name : str
        File stem of the twin file.

    Returns
    -------
    pathlib.Path
        ``problems_dir() / f"{name}.toml"`` (not checked for existence).
    """
    return problems_dir() / f"{name}.toml"


def sweeps_dir() -> Path:
    """The folder holding the built-in sweep files (``problems/sweeps``).

    Returns
    -------
    pathlib.Path
    """
    return problems_dir() / "sweeps"


def sweep_names() -> list[str]:
    """Names of the built-in sweeps (file stems).

    Returns
    -------
    list of str
        Sorted, e.g. ``["paper_montecarlo", "paper_tradeoff"]``.
    """
    return sorted(p.stem for p in sweeps_dir().glob("*.toml"))


def builtin_sweep(name: str) -> Path | None:
    """Path of the built-in sweep ``name`` (with or without ``.toml``), or ``None``.

    Parameters
    ----------
    name : str
        ``"paper_montecarlo"``, with ``.toml``, or under ``sweeps/`` or
        ``problems/sweeps/``.

    Returns
    -------
    pathlib.Path or None
        The shipped file, or ``None`` when no built-in sweep has that name.
    """
    return _builtin(name, sweeps_dir(), sweep_names(), ("sweeps", "problems/sweeps"))


def _builtin(name, folder, names, aliases):
    p = Path(name)
    stem = p.name.removesuffix(".toml")
    parent = p.parent.as_posix()
    if stem not in names or parent not in (".", *aliases, *(f"robrst/{a}" for a in aliases)):
        return None
    return folder / f"{stem}.toml"


def find_file(name_or_path: str | Path, kind: str) -> Path | None:
    """``name_or_path`` if it exists, else the built-in ``kind`` of that name, else ``None``.

    A folder of that name (``./paper/``) does not hide the built-in; with no built-in of
    that name the folder is returned (and refused by the reader, naming it).

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A file, or the name of a shipped file.
    kind : {"problem", "sweep"}
        Which built-ins to look among.

    Returns
    -------
    pathlib.Path or None
        The file to read, or ``None`` when neither exists.
    """
    p = Path(name_or_path)
    if p.exists() and not p.is_dir():
        return p
    builtin = (builtin_problem if kind == "problem" else builtin_sweep)(str(name_or_path))
    if builtin is None and p.is_symlink():    # a broken link or a loop: the reader names it
        return p
    return builtin if builtin is not None or not p.exists() else p
