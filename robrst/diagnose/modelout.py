"""The answer's model as files: what a diagnosis fitted, for ``design``, ``simulate`` and others.

:func:`answer_models` evaluates the linear part of the diagnosis's answer (the selected
set's final fit, or the linear re-fit) as continuous-time modal models: one at the
model's reference for a level-independent answer, one per excitation level for the
amplitude-dependent dynamics (the training and test records' levels, grouped within
``level_tol``).  A ``stiffness_nonlinearity`` answer changes the linear part itself
(a cubic stiffness inside the loop, :mod:`robrst.diagnose._stiffness`): its model is the
fitted plant at small amplitude (with the fitted input gain), and the stiffness is the
twin's effect of the same name.  :func:`write_models` writes each as a model file of the
format ``robrst-modal-1`` (:mod:`robrst.base.modelformat`), the file ``robrst identify``
writes (:func:`robrst.identify.modelfile.modal_model_table`, the one writer of the
table): ``robrst diagnose --model``, ``robrst identify``'s readers and a twin file's
``[twin] plant`` read it; a model of one input and one output also carries the starting
design tables of ``robrst identify`` (:func:`robrst.identify.modelfile.starting_design`),
so ``robrst design`` reads it as it is.  When the answer names an effect the twin
simulates from its fitted parameters (the cubic stiffness), a twin file ``twin.toml``
beside the model switches it on over that model (``[twin] plant = "model.toml"``, the
records' rate and the model's temperature): ``robrst simulate --twin DIR/twin.toml``
runs the answer.  The input-side effects of other answers are reported in the diagnosis
(``selected[].params``; a twin file switches them on); their files hold the linear part.

Files are written atomically and never over a file robrst diagnose did not write.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import tomlkit

from robrst.base.errors import SpecError
from robrst.base.fileio import atomic_write_text, peek_text
from robrst.base.tomlwrite import document, plain
from robrst.diagnose._findings import level_groups
from robrst.identify.modal import ModalModel
from robrst.identify.modelfile import modal_model_table, starting_design

if TYPE_CHECKING:
    from robrst.diagnose.result import Diagnosis

__all__ = ["AnswerModel", "answer_models", "write_models", "check_model_out", "model_file_text",
           "twin_file_text", "MARKER"]

MARKER = "# written by robrst diagnose"


@dataclass(frozen=True, eq=False)
class AnswerModel:
    """The answer's linear part at one excitation level.

    Parameters
    ----------
    model : ModalModel
        The continuous-time modal model.
    level_V : float or None
        The excitation level it holds at [V rms] (None: every level).
    name : str
        The file's stem.
    twin : dict
        The twin file's effect tables that put the answer's effect back over the model
        (empty: the model is the whole answer, or its effects are reported only).
    reference_C : float or None
        The temperature the fit holds at [°C] (the twin file's ``reference_C``).
    """

    model: ModalModel
    level_V: float
    name: str
    twin: dict = field(default_factory=dict)
    reference_C: float = None


def answer_models(diag: Diagnosis) -> list:
    """The linear part of ``diag``'s answer, as modal models (see the module doc).

    Parameters
    ----------
    diag : Diagnosis
        A diagnosis (its ``traces`` hold the answer's fit).

    Returns
    -------
    list of AnswerModel
        Empty for an answer without a fitted linear part (``none``, a ``cannot_tell``
        without a partial explanation).
    """
    fit = diag.traces.answer_fit if diag.traces is not None else None
    if fit is not None and hasattr(fit, "twin_tables"):     # the stiffness: the plant itself
        plant = fit.linear_plant()
        return [AnswerModel(ModalModel.from_plant(plant), None, "model", fit.twin_tables(),
                            float(fit.stage.model.config.reference_C))]
    if fit is None or not hasattr(fit, "lin"):
        return []
    if getattr(fit, "slopes", ()):
        recs = diag.traces.records
        out = []
        for lv, _ in level_groups(recs):
            m = fit.model_at(lv) if hasattr(fit, "model_at") else fit.lin.continuous(
                fit.theta_at(lv))
            out.append(AnswerModel(m, float(lv), f"model_{lv:.4g}Vrms"))
        return out
    return [AnswerModel(fit.lin.continuous(fit.parts()[1]), None, "model")]


def model_file_text(model: ModalModel, fs: float, header: list) -> str:
    """The text of a model file (``robrst-modal-1``) holding ``model``.

    Parameters
    ----------
    model : ModalModel
        The model.
    fs : float
        The records' sampling rate [Hz].
    header : list of str
        Comment lines after the marker line.

    Returns
    -------
    str
    """
    doc = document([MARKER[2:] + " (model file)"] + list(header))
    doc["model"] = modal_model_table([model], model.order, fs, "robrst diagnose")
    if (model.n_in, model.n_out) == (1, 1):
        try:
            plant = model.channel(0, 0)
        except SpecError:            # too high an order for polynomials: no design tables
            plant = None
        if plant is not None:
            doc.add(tomlkit.nl())
            doc.add(tomlkit.comment("A starting design (as robrst identify writes it; edit"
                                    " freely): robrst design reads this file as it is."))
            for k, v in starting_design([plant], fs).items():
                doc[k] = plain(v)
    return tomlkit.dumps(doc)


def twin_file_text(model_file: str, fs: float, reference_C: float | None, tables: dict,
                   header: list) -> str:
    """The text of a twin file that runs a model file with the answer's effect switched on.

    Parameters
    ----------
    model_file : str
        The model file, relative to the twin file (``[twin] plant``).
    fs : float
        The records' sampling rate [Hz] (``[twin] sample_rate_hz``).
    reference_C : float or None
        The temperature the fit holds at [°C] (``[twin] reference_C``).
    tables : dict
        The effects' tables (``{"stiffness_nonlinearity": {...}}``).
    header : list of str
        Comment lines after the marker line.

    Returns
    -------
    str
    """
    doc = document([MARKER[2:] + " (twin file)"] + list(header))
    twin = {"name": "diagnosis answer", "plant": model_file, "sample_rate_hz": float(fs)}
    if reference_C is not None:
        twin["reference_C"] = float(reference_C)
    doc["twin"] = plain(twin)
    for k, v in tables.items():
        doc[k] = plain(v)
    return tomlkit.dumps(doc)


def _refuse_foreign(path):
    if path.exists():
        first = (peek_text(path) or "").splitlines()[:1]
        if not first or not first[0].startswith(MARKER):
            raise SpecError(f"{path}: exists and was not written by robrst diagnose; not"
                            " overwriting it (choose another --model-out)")


def check_model_out(folder: str | Path) -> None:
    """Refuse, before any work, a ``--model-out`` folder that is a file or holds a file of a
    name the answer may write (``model.toml``, ``model_<level>Vrms.toml``, ``twin.toml``)
    that robrst diagnose did not write.

    Parameters
    ----------
    folder : str or Path

    Raises
    ------
    SpecError
        Naming the file in the way.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise SpecError(f"{folder}: is a file; --model-out needs a folder")
    if folder.is_dir():
        for path in sorted(folder.glob("*.toml")):
            if path.name in ("model.toml", "twin.toml") or (
                    path.name.startswith("model_") and path.name.endswith("Vrms.toml")):
                _refuse_foreign(path)


def write_models(diag: Diagnosis, folder: str | Path) -> list:
    """Write the answer's models (:func:`answer_models`) into ``folder``.

    Parameters
    ----------
    diag : Diagnosis
        The diagnosis.
    folder : str or Path
        Created when missing; a file of the same name that robrst diagnose did not write
        is never overwritten.

    Returns
    -------
    list of dict
        ``{"file", "level_V", "order"}`` per file written, and ``"twin_file"`` (the twin
        file that runs it with the answer's effect, or None).

    Raises
    ------
    SpecError
        Naming a file in the way (written by something else), or a folder path that is a
        file.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise SpecError(f"{folder}: is a file; --model-out needs a folder")
    models = answer_models(diag)
    fs = float(diag.data.fs_hz)
    for am in models:             # every target checked before anything is written
        _refuse_foreign(folder / f"{am.name}.toml")
        if am.twin:
            _refuse_foreign(folder / "twin.toml")
    out = []
    for am in models:
        path = folder / f"{am.name}.toml"
        where = ("at small amplitude" if am.twin else "at every excitation level"
                 if am.level_V is None else f"at the excitation level {am.level_V:.6g} V rms")
        header = [f"the linear part of the answer '{diag.cause}'"
                  f" ({' + '.join(diag.causes) or 'linear corrections'}) {where}",
                  f"records: {', '.join(map(str, diag.data.train))[:200]}"]
        if am.twin:
            header.append("twin.toml beside it switches the answer's "
                          + ", ".join(am.twin) + " on over it (robrst simulate --twin)")
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, model_file_text(am.model, fs, header))
        twin = None
        if am.twin:
            twin = folder / "twin.toml"
            params = ", ".join(f"{k} = {v:.6g}" for t in am.twin.values() for k, v in t.items()
                               if k != "enabled")
            atomic_write_text(twin, twin_file_text(
                path.name, fs, am.reference_C, am.twin,
                [f"the answer '{diag.cause}' ({params}) over {path.name}"]))
        out.append({"file": str(path), "level_V": am.level_V, "order": int(am.model.order),
                    "twin_file": None if twin is None else str(twin)})
    return out
