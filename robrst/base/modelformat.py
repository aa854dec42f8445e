"""The model file of ``robrst identify``: its ``[model]`` table read and checked.

A model file holds a continuous-time linear model in modal form, one ``[[model.at]]`` per
temperature (``format = "robrst-modal-1"``; written by :mod:`robrst.identify.modelfile`)::

    [model]
    format = "robrst-modal-1"
    inputs = 1
    outputs = 1
    order = 2                          # optional: number of poles
    fs_hz = 10000.0                    # optional: the records' sampling rate
    source = "robrst identify"         # optional
    [[model.at]]
    temperature_C = 20.0               # optional for one model, increasing for several
    poles_re = [-150.8]                # rad/s; pole p_i = poles_re[i] + j poles_im[i]
    poles_im = [5024.3]                # >= 0; > 0 stands for the conjugate pair
    residues_re = [[[0.0]]]            # per pole an outputs x inputs matrix
    residues_im = [[[-502.9]]]
    D = [[0.0]]                        # outputs x inputs

``G(s) = sum_i R_i/(s - p_i) (+ conjugate terms) + D``, inputs V, outputs µm.  A model
file of one input and one output may also carry a problem's design tables
(:data:`DESIGN_TABLES`): it is then a problem file whose plant family is the model
(:mod:`robrst.problem.files`).  This module only reads and checks the table (every error
names the file and the key); the modal model itself is
:class:`robrst.identify.modal.ModalModel`.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robrst.base.errors import SpecError

__all__ = ["FORMAT", "MODEL_KEYS", "AT_KEYS", "DESIGN_TABLES", "ModelAt", "ModelTable",
           "read_model_table"]

FORMAT = "robrst-modal-1"
MODEL_KEYS = ("format", "inputs", "outputs", "order", "fs_hz", "source", "at")
AT_KEYS = ("temperature_C", "poles_re", "poles_im", "residues_re", "residues_im", "D")
DESIGN_TABLES = ("problem", "controller", "poles", "specs", "solver")


@dataclass(frozen=True, eq=False)
class ModelAt:
    """One ``[[model.at]]`` of a model file.

    Attributes
    ----------
    poles : numpy.ndarray
        Stored poles [rad/s] (real, or the member of a pair with ``Im > 0``).
    residues : numpy.ndarray
        ``(n, outputs, inputs)`` complex residues.
    D : numpy.ndarray
        ``(outputs, inputs)`` feedthrough.
    temperature_C : float or None
        Where the model holds [°C].
    """

    poles: np.ndarray
    residues: np.ndarray
    D: np.ndarray
    temperature_C: float = None


@dataclass(frozen=True, eq=False)
class ModelTable:
    """The checked ``[model]`` table.

    Attributes
    ----------
    inputs, outputs : int
        Channel counts.
    fs_hz : float or None
        The records' sampling rate [Hz].
    at : tuple of ModelAt
        One per temperature, increasing.
    """

    inputs: int
    outputs: int
    fs_hz: float
    at: tuple


def _err(path, key, msg):
    return SpecError(f"{path}: [{key}] {msg}")


def _array(path, key, value, shape):
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise _err(path, key, f"expected numbers of shape {shape}") from None
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise _err(path, key, f"expected finite numbers of shape {shape}, got shape {a.shape}")
    return a


def _number(path, key, value, positive=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) \
            or (positive and value <= 0):
        raise _err(path, key, f"expected a {'positive ' if positive else ''}finite number,"
                   f" got {value!r}")
    return float(value)


def read_model_table(path: str | Path, data: dict, design_tables: bool = False) -> ModelTable:
    """The checked ``[model]`` table of ``data`` (a parsed model file from ``path``).

    Parameters
    ----------
    path : str or Path
        Named in every error.
    data : dict
        The parsed TOML document; it must hold ``[model]``.
    design_tables : bool
        Accept :data:`DESIGN_TABLES` beside ``[model]`` (their contents are the problem
        reader's to check); otherwise ``[model]`` must be alone.

    Returns
    -------
    ModelTable

    Raises
    ------
    SpecError
        Naming the file and the key: unknown keys, a wrong format, shapes, non-finite
        numbers, temperatures that do not increase.
    """
    model = data.get("model")
    if not isinstance(model, dict):
        raise _err(path, "model", "expected a table")
    unknown = sorted(set(model) - set(MODEL_KEYS))
    others = sorted(set(data) - {"model"} - (set(DESIGN_TABLES) if design_tables else set()))
    if unknown:
        raise _err(path, "model", f"unknown key(s) {unknown}; valid: {', '.join(sorted(MODEL_KEYS))}")
    if others:
        allowed = ("[model] and the design tables " + ", ".join(f"[{t}]" for t in DESIGN_TABLES)
                   if design_tables else "[model] only")
        raise _err(path, others[0], f"unknown table beside [model]: a model file holds {allowed}"
                   + ("; its plant is [model] (no [plant] or [family])"
                      if others[0] in ("plant", "family") else ""))
    if model.get("format") != FORMAT:
        raise _err(path, "model.format", f"expected {FORMAT!r}, got {model.get('format')!r}")
    k, m = model.get("inputs"), model.get("outputs")
    if not (isinstance(k, int) and isinstance(m, int) and not isinstance(k, bool)
            and not isinstance(m, bool) and 1 <= k <= 1000 and 1 <= m <= 1000):
        raise _err(path, "model", "inputs and outputs must be integers in 1..1000")
    fs = model.get("fs_hz")
    fs = None if fs is None else _number(path, "model.fs_hz", fs, positive=True)
    ats = model.get("at")
    if not isinstance(ats, list) or not ats:
        raise _err(path, "model.at", "expected at least one [[model.at]] table")
    out = []
    for n, at in enumerate(ats):
        key = f"model.at.{n}"
        if not isinstance(at, dict):
            raise _err(path, key, "expected a table")
        extra = sorted(set(at) - set(AT_KEYS))
        if extra:
            raise _err(path, key, f"unknown key(s) {extra}; valid: {', '.join(AT_KEYS)}")
        missing = [x for x in AT_KEYS[1:] if x not in at]
        if missing:
            raise _err(path, key, f"missing key(s) {missing}")
        if not isinstance(at["poles_re"], list):
            raise _err(path, f"{key}.poles_re", "expected a list of numbers")
        pr = _array(path, f"{key}.poles_re", at["poles_re"], (len(at["poles_re"]),))
        pi = _array(path, f"{key}.poles_im", at["poles_im"], pr.shape)
        if np.any(pi < 0):
            raise _err(path, f"{key}.poles_im", "expected values >= 0 (a pair is stored once,"
                       " by its member with positive imaginary part)")
        Rr = _array(path, f"{key}.residues_re", at["residues_re"], (pr.size, m, k))
        Ri = _array(path, f"{key}.residues_im", at["residues_im"], (pr.size, m, k))
        D = _array(path, f"{key}.D", at["D"], (m, k))
        T = at.get("temperature_C")
        T = None if T is None else _number(path, f"{key}.temperature_C", T)
        out.append(ModelAt(pr + 1j * pi, Rr + 1j * Ri, D, T))
    temps = [a.temperature_C for a in out]
    if len(out) > 1 and (None in temps or np.any(np.diff(temps) <= 0)):
        raise _err(path, "model.at", "several models need increasing temperature_C values")
    return ModelTable(inputs=k, outputs=m, fs_hz=fs, at=tuple(out))
