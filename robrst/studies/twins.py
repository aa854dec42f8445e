"""The twin of a user's stage: a twin file whose plant is a problem file or a model file
of ``robrst identify``, and the twin of a design's own plant.

:mod:`robrst.twin.config` validates twin files on the modelling side (base and maths core
only); the plant files it cannot read (problem files are a layer above it) are read here
and handed to it (:func:`robrst.twin.config.parse_twin`'s ``plant_loader``).
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from robrst.base.schema import load_toml
from robrst.studies.linear_model import problem_family
from robrst.twin.config import TwinConfig, default_twin, parse_twin

__all__ = ["load_twin", "plant_file", "twin_of_design"]


def plant_file(path: str | os.PathLike) -> tuple:
    """What a twin's ``[twin] plant`` file gives the twin.

    Parameters
    ----------
    path : str or Path
        A problem file (a model file of ``robrst identify`` is one,
        :func:`robrst.problem.files.model_document`), or a built-in problem by name.

    Returns
    -------
    (Plant, float, dict or None, float or None)
        The reference model of its family, its temperature [°C], the parametric family's
        gain, resonance and damping laws, and its ``specs.sample_rate_hz``.

    Raises
    ------
    SpecError
        Naming the file: not found, not a problem or model file, several inputs/outputs.
    """
    from robrst.base.errors import SpecError
    from robrst.problem.files import load_problem, parse_problem

    p = Path(path)
    if p.is_file():
        data = load_toml(p, "problem or model file")
        fam = problem_family(p)
        try:     # the rate, when the file's design tables are valid (a plant file need not)
            rate = parse_problem({"poles": {"wn": 1.0, "zeta": 1.0}, **data}, p,
                                 compare=False).specs.sample_rate_hz
        except SpecError:
            rate = None
    else:
        problem = load_problem(path)
        fam, rate = problem.family, problem.specs.sample_rate_hz
    law = None
    if fam.thermal is not None:
        c = fam.thermal
        law = {"gain_per_K": c.gain_per_K, "resonance_per_K": c.resonance_per_K,
               "damping_per_K": c.damping_per_K}
    ref = fam.reference_model
    return ref, ref.temperature_C, law, rate


def load_twin(path: str | os.PathLike, sample_rate_hz: float | None = None) -> TwinConfig:
    """Load and validate a twin file whose plant may be the user's own.

    ``[twin] plant`` is ``"paper"`` (the paper's actuator) or a problem file or a model
    file of ``robrst identify`` (a path relative to the twin file): its family's reference
    model is the linear part; ``reference_C`` defaults to its temperature,
    ``sample_rate_hz`` to its ``specs.sample_rate_hz``, ``[thermal_dynamics]`` to its
    parametric family's per-kelvin laws; and only the effects whose tables the twin file
    has are on.

    Parameters
    ----------
    path : str or Path
    sample_rate_hz : float, optional
        The rate when the file states none (a controller's: the twin runs at it); else the
        plant file's ``specs.sample_rate_hz``, else 20 kHz.

    Returns
    -------
    TwinConfig

    Raises
    ------
    SpecError
        One line naming the twin file and the key (``[twin.plant]`` for a bad plant file).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "stage.toml").write_text("[plant]\\nB = [5.0e6]\\nA = [1.0, 300.0, 2.5e7]\\n")
    >>> _ = (folder / "twin.toml").write_text('[twin]\\nplant = "stage.toml"\\n[noise]\\n')
    >>> twin = load_twin(folder / "twin.toml")
    >>> [k for k in twin.effects if twin.enabled(k)], twin.linear_plant.B.tolist()
    (['noise'], [5000000.0])
    """
    data = load_toml(path, "twin file")
    rates = {}

    def loader(target):
        plant, ref, law, rate = plant_file(target)
        rates["rate"] = rate
        return plant, ref, law

    cfg = parse_twin(data, str(path), loader)
    given = (data.get("twin") or {}).keys() & {"sample_rate_hz", "fs_hz"}
    rate = sample_rate_hz or (rates.get("rate") if cfg.plant_model is not None else None)
    if not given and rate:
        cfg = replace(cfg, sample_rate_hz=float(rate))
    return cfg


def twin_of_design(result: object, sample_rate_hz: float | None = None) -> TwinConfig:
    """The linear twin of a design's plant.

    Parameters
    ----------
    result : DesignResult
    sample_rate_hz : float, optional
        Default the design's sampling rate, else 20 kHz.

    Returns
    -------
    TwinConfig
        Its family's reference model, every effect off.
    """
    sp = result.problem.specs
    rate = sample_rate_hz or sp.sample_rate_hz or 20000.0
    ref = result.problem.family.reference_model
    cfg = default_twin().with_effects(only=[]).with_plant(ref, name=f"{result.problem.name}")
    return replace(cfg, name=f"linear twin of {result.problem.name}",
                   sample_rate_hz=float(rate))
