"""The linear model of a model file (``robrst identify``) or of a problem file's family.

Problem files are parsed by :mod:`robrst.problem.files` (problem layer) and model files by
:mod:`robrst.identify.modelfile` (modelling side); this module, above both, picks one.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from robrst.identify.modal import ModalModel
from robrst.identify.modelfile import modal_models, read_model_data
from robrst.problem.files import load_problem, parse_problem

if TYPE_CHECKING:
    from robrst.core.family import PlantFamily

__all__ = ["load_linear_model", "problem_family", "family_of_data"]


def problem_family(path: str | Path) -> PlantFamily:
    """The plant family of a problem file, a built-in problem's name, or a problem file
    straight from ``robrst identify`` (no ``[poles]`` yet: only the plant matters here).

    Parameters
    ----------
    path : str or pathlib.Path
        A problem file or a built-in problem's name.

    Returns
    -------
    PlantFamily

    Raises
    ------
    SpecError
        Naming the file and the key of the first problem.
    """
    path = Path(path)
    if not path.is_file():
        return load_problem(path).family    # a built-in name (or a clear error)
    return family_of_data(read_model_data(path), path)


def family_of_data(data: dict, path: str | Path) -> PlantFamily:
    """The plant family of a parsed problem document, as :func:`problem_family` reads it
    (``robrst identify`` checks the text it would write with this).

    Parameters
    ----------
    data : dict
        The parsed TOML document (``[poles]`` may be missing).
    path : str or Path
        Named in every error.

    Returns
    -------
    PlantFamily

    Raises
    ------
    SpecError
        Naming ``path`` and the key of the first problem.
    """
    # a placeholder stands in for the (unused) [poles] table a file may not have yet
    return parse_problem({"poles": {"wn": 1.0, "zeta": 1.0}, **data}, path).family


def load_linear_model(path: str | Path) -> tuple[tuple[ModalModel, ...], float | None]:
    """Models of a model file or of a problem file's family, lowest temperature first.

    Parameters
    ----------
    path : str or Path
        A model file written by ``robrst identify`` or a problem file.

    Returns
    -------
    tuple
        ``(models, reference_C)``: a tuple of :class:`~robrst.identify.modal.ModalModel`
        and the reference temperature (None when the file states none).
    """
    path = Path(path)
    data = read_model_data(path)
    if "model" in data:
        return modal_models(path, data)
    fam = problem_family(path)
    models = tuple(ModalModel.from_plant(p) for p in fam.models)
    return models, fam.reference_model.temperature_C
