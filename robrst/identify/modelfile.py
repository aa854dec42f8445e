"""Files written by ``robrst identify``: a problem file (one input and output) or a model file.

* **Problem file** (SISO, or one channel of a MIMO fit with ``--channel``): ``[problem]``,
  ``[plant]`` with ``B``/``A`` (highest power first, s in rad/s) and, from records at
  several temperatures, ``[family]`` with one ``[[family.models]]`` per temperature.
  ``robrst design`` reads it once ``[poles]`` (and ``[specs]``, ``[solver]``) are added;
  a commented template is included.
* **Model file** (several inputs or outputs): the modal form, one ``[[model.at]]`` per
  temperature::

      [model]
      format = "robrst-modal-1"
      inputs = 3
      outputs = 3
      [[model.at]]
      temperature_C = 28.0               # optional
      poles_re = [...]                   # rad/s; pole p_i = poles_re[i] + j poles_im[i]
      poles_im = [...]                   # >= 0; > 0 stands for the conjugate pair
      residues_re = [[[...]]]            # per pole an outputs x inputs matrix
      residues_im = [[[...]]]
      D = [[...]]                        # outputs x inputs

  ``G(s) = sum_i R_i/(s - p_i) (+ conjugate terms) + D``, inputs V, outputs µm.

:func:`modal_models` reads a model file; :func:`robrst.studies.linear_model.load_linear_model`
reads either kind (problem files through :mod:`robrst.problem.files`, a layer above this one).
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import tomlkit

from robrst.base.errors import SpecError
from robrst.base.fileio import atomic_write_text, check_file_target, peek_text, read_utf8
from robrst.base.tomlwrite import comment_text, document, plain
from robrst.identify.modal import ModalModel
from robrst.base.modelformat import FORMAT, read_model_table
from robrst.base.schema import MAX_MAGNITUDE

if TYPE_CHECKING:
    from robrst.identify.identification import Identified

__all__ = ["problem_text", "model_text", "modal_model_table", "write_identified", "check_target", "read_model_data",
           "modal_models", "starting_wn", "starting_mu", "starting_design", "MARKER", "FORMAT"]

MARKER = "# written by robrst identify"
NEGLIGIBLE_LEAD = 1e-9   # a leading numerator term below this share of B up to Nyquist


def _header(ident, sources, what):
    return [f"{MARKER[2:]} ({what})",
            f"from {len(sources)} record(s): " + ", ".join(str(s) for s in sources[:6])
            + (" ..." if len(sources) > 6 else ""),
            f"order {ident.order} (poles), sampled at {ident.fs:g} Hz, held-out NRMSE"
            f" {ident.heldout_nrmse:.4g} on " + ", ".join(str(h) for h in ident.heldout[:4])]


def _commented(value, comment):
    """A TOML value with a comment after it on its line."""
    item = tomlkit.item(plain(value))
    item.comment(comment_text(comment))
    return item


def _readable(plants, order):
    """Refuse polynomials a problem file cannot hold (expanded, a high order's coefficients
    leave the range every robrst file accepts) before anything is written."""
    c = (np.concatenate([np.concatenate([p.B, p.A]) for p in plants]) if plants is not None
         else np.array([np.inf]))      # None: the expansion overflowed float64
    nz = np.abs(c[c != 0])
    if not np.all(np.isfinite(c)) or (nz.size and not (
            nz.min() >= 1 / MAX_MAGNITUDE and nz.max() <= MAX_MAGNITUDE)):
        big = float(np.max(np.abs(c))) if np.all(np.isfinite(c)) else np.inf
        raise SpecError(f"order {order}: the problem file's expanded polynomials B, A would"
                        f" need coefficients up to {big:.3g} (a robrst file holds 0 or"
                        f" {1 / MAX_MAGNITUDE:g} <= |x| <= {MAX_MAGNITUDE:g}); write the modal"
                        " model file instead (--modal; read by diagnose and simulate) or choose"
                        " a lower --order / --max-order")


def _drop_negligible_lead(plants, fs, rtol=NEGLIGIBLE_LEAD):
    """Drop leading numerator coefficients that change no model's response from 0 to
    Nyquist by more than ``rtol`` relative (the expansion's rounding residue of a
    relative degree above one: a zero far beyond Nyquist, e.g. at 2e16 rad/s, that a
    problem file cannot hold).  Every model keeps the same degrees."""
    w = np.pi * fs * np.linspace(0.0, 1.0, 1025)[1:]
    s = 1j * w
    while all(p.B.size > 1 for p in plants):
        lead = [np.abs(p.B[0] * s ** (p.B.size - 1)) / np.maximum(np.abs(np.polyval(p.B, s)),
                                                                    1e-300) for p in plants]
        if max(float(r.max()) for r in lead) > rtol:
            break
        plants = [replace(p, B=p.B[1:]) for p in plants]
    return plants


def starting_wn(plants: list, fs: float) -> float:
    """A dominant closed-loop natural frequency [rad/s] for a first design of ``plants``.

    A fifth of the lowest natural frequency of a lightly damped pole pair (damping below
    0.5) of any model; without one, the geometric mean of the nonzero pole magnitudes;
    at most ``2 pi fs / 20`` (well below Nyquist); three significant digits.

    Parameters
    ----------
    plants : list of Plant
        The identified models.
    fs : float
        The records' rate [Hz].

    Returns
    -------
    float
    """
    poles = np.concatenate([np.roots(p.A) for p in plants])
    mag = np.abs(poles)
    pairs = (poles.imag > 0) & (-poles.real < 0.5 * mag)
    if np.any(pairs):
        w = float(np.min(mag[pairs])) / 5.0
    elif np.any(mag > 0):
        w = float(np.exp(np.mean(np.log(mag[mag > 0]))))
    else:
        w = 2 * np.pi * fs / 100.0
    w = min(w, 2 * np.pi * fs / 20.0)
    return float(f"{max(w, 1e-6):.3g}")


MU_STROKE_SHARE = 0.1   # an error of this share of the stroke may ask the whole voltage range


def starting_mu(plants: list, u_range: tuple | None = None) -> tuple[float, str] | None:
    """The ``|U|`` bound of a first design and why: ``Mu_max = 1 / (MU_STROKE_SHARE k)``.

    ``|U| = |K S|`` is the voltage the controller asks per µm of measurement noise or
    error.  With ``k`` the identified static gain, the records' voltage range ``W`` moves
    the stage over ``k W`` µm; ``Mu_max = 10 / k`` means an error of a tenth of that stroke
    never asks for more than the whole range ``W`` (the README's example stage, 0.1 µm/V,
    gets 100 V/µm).  Below ``1 / k`` no loop can track (``|U| = |T| / k`` at low
    frequency).

    Parameters
    ----------
    plants : list of Plant
        The identified models (the largest static gain over them: the tightest bound).
    u_range : (float, float), optional
        The records' smallest and largest input [V] (said in the reason).

    Returns
    -------
    (float, str) or None
        The bound [V/µm] (three significant digits) and the reason; ``None`` for a plant
        whose static gain is not finite and non-zero (an integrator: no stroke per volt).
    """
    gains = []
    for p in plants:
        A0, B0 = float(p.A[-1]), float(p.B[-1])
        if A0 == 0 or B0 == 0 or not np.isfinite(B0 / A0):
            return None
        gains.append(abs(B0 / A0))
    k = max(gains)
    mu = float(f"{1.0 / (MU_STROKE_SHARE * k):.3g}")
    why = (f"1/({MU_STROKE_SHARE:g} k), k = {k:.3g} um/V the identified static gain:"
           f" an error of {MU_STROKE_SHARE:g} of the stroke never asks for more than the"
           " records' voltage range")
    if u_range is not None and u_range[1] > u_range[0]:
        W = u_range[1] - u_range[0]
        why += (f" ({W:.3g} V, {u_range[0]:.3g} .. {u_range[1]:.3g} V: a stroke of"
                f" {k * W:.3g} um)")
    return mu, why


def starting_design(plants: list, fs: float, u_range: tuple | None = None) -> dict:
    """The design tables ``robrst identify`` writes into a file of one input and one output,
    so that ``robrst design`` runs on it as it is: the robust NLP (integral gain, certified
    modulus margin 0.5, ``|T| <= 1.3``, ``|U|`` bounded from the identified gain
    (:func:`starting_mu`) and a reference step overshooting at most 2 %, on the
    sampled loop at the records' rate), a two-degree-of-freedom reference path, the
    dominant poles and the reference model's bandwidth from :func:`starting_wn`.

    Parameters
    ----------
    plants : list of Plant
        The identified models.
    fs : float
        The records' rate [Hz].
    u_range : (float, float), optional
        The records' input range [V] (:attr:`robrst.identify.identification.Identified.u_range_V`).

    Returns
    -------
    dict
        The tables ``poles``, ``controller``, ``specs`` and ``solver`` (a problem
        document's values; :func:`problem_text` and :func:`model_text` write them with
        their comments).
    """
    wn = starting_wn(plants, fs)
    specs = {"Ms_max": 2.0, "Mt_max": 1.3}
    mu = starting_mu(plants, u_range)
    if mu is not None:
        specs.update(Mu_max=mu[0], Mu_reason=mu[1])
    specs.update(overshoot_max_pct=2.0, sample_rate_hz=float(fs))
    return {"poles": {"wn": wn, "zeta": 1.0},
            "controller": {"T_mode": "reference_model", "reference_wn": wn},
            "specs": specs,
            "solver": {"method": "nlp"}}


def _add_starting_design(doc, plants, fs, u_range=None):
    """:func:`starting_design`'s tables added to ``doc`` with their comments."""
    tables = starting_design(plants, fs, u_range)
    doc.add(tomlkit.nl())
    mu = ("" if "Mu_max" not in tables["specs"] else
          f" |U| <= {tables['specs']['Mu_max']:g} V/um (Mu_reason says why),")
    for line in ("A starting design, chosen by robrst identify from the model (edit freely):",
                 "the robust NLP at the records' sampling rate (the controller runs at it),",
                 "dominant poles a fifth of the lowest resonance, modulus margin >= 0.5,"
                 + mu, "and a reference path (2-DOF) whose step overshoots at most 2 %."):
        doc.add(tomlkit.comment(line))
    poles = tomlkit.table()
    poles["wn"] = _commented(tables["poles"]["wn"], "dominant natural frequency [rad/s]")
    poles["zeta"] = tables["poles"]["zeta"]
    doc["poles"] = poles
    for name in ("controller", "specs", "solver"):
        doc[name] = plain(tables[name])


def problem_text(ident: Identified, sources: Sequence[str], name: str,
                 channel: tuple[int, int] = (0, 0)) -> str:
    """The problem-file text of output ``channel[0]`` from input ``channel[1]``.

    Parameters
    ----------
    ident : Identified
        The identification result (one model per temperature).
    sources : sequence of str
        Names of the training records (named in the header comment).
    name : str
        The problem name.
    channel : (int, int)
        Output and input, 0-based.

    Returns
    -------
    str
        ``[problem]``, ``[plant]`` (and ``[family]`` for several temperatures) and a
        commented template of the tables a design needs.

    Raises
    ------
    SpecError
        When the expanded polynomials do not fit in a robrst file (beyond 1e100, or
        beyond float64).
    """
    i, j = channel
    try:
        plants = _drop_negligible_lead([m.channel(i, j) for m in ident.models], ident.fs)
    except SpecError:      # the expanded coefficients overflow float64
        plants = None
    _readable(plants, ident.order)
    doc = document(_header(ident, sources, "problem file"))
    desc = f"identified by robrst identify (output y{i + 1} from input u{j + 1})"
    doc["problem"] = plain({"name": name, "description": desc})
    T0 = ident.models[0].temperature_C
    plant = {"B": plants[0].B, "A": plants[0].A}
    if T0 is not None:
        plant["temperature_C"] = float(T0)
    doc["plant"] = plain({**plant, "source": "robrst identify"})
    law = ident.thermal if (i, j) == (0, 0) else None
    if len(plants) > 1 and law is not None and law.consistent:
        temps = ", ".join(f"{T:g}" for T in law.temperatures_C)
        family = tomlkit.table()
        family.update(plain({
            "reference_C": float(T0), "temperatures_C": law.temperatures_C,
            "source": f"robrst identify: per-kelvin laws fitted to the models at {temps} degC"
                      " (1-sigma beside each)"}))
        parametric = tomlkit.table()
        for k in ("gain_per_K", "resonance_per_K", "damping_per_K"):
            parametric[k] = _commented(float(getattr(law, k)),
                                       f"+/- {law.std[k]:.3g} (1 sigma)")
        family["parametric"] = parametric
        doc["family"] = family
    elif len(plants) > 1:
        family = tomlkit.table()
        family.update(plain({"reference_C": float(T0),
                             "source": "robrst identify: one model per record temperature"}))
        if law is not None and law.note:
            family.add(tomlkit.comment(comment_text(
                f"explicit models (robrst's thermal law does not hold: {law.note})")))
        models = tomlkit.aot()
        for p in plants:
            models.append(plain({"temperature_C": float(p.temperature_C), "B": p.B, "A": p.A}))
        family["models"] = models
        doc["family"] = family
    _add_starting_design(doc, [m.channel(i, j) for m in ident.models], ident.fs,
                         ident.u_range_V)
    return tomlkit.dumps(doc)


def modal_model_table(models: Sequence[ModalModel], order: int, fs: float,
                      source: str) -> tomlkit.items.Table:
    """The ``[model]`` table of a ``robrst-modal-1`` file: its header and one ``[[model.at]]``
    record per model (poles, residues and ``D``; the temperature when known).

    Parameters
    ----------
    models : sequence of ModalModel
        Of one shape (inputs, outputs).
    order : int
        The models' order.
    fs : float
        The records' sampling rate [Hz].
    source : str
        The command that wrote the file.

    Returns
    -------
    tomlkit.items.Table
    """
    m0 = models[0]
    table = tomlkit.table()
    table.update(plain({"format": FORMAT, "inputs": m0.n_in, "outputs": m0.n_out,
                        "order": order, "fs_hz": float(fs), "source": source}))
    at = tomlkit.aot()
    for m in models:
        rec = {} if m.temperature_C is None else {"temperature_C": float(m.temperature_C)}
        rec.update({"poles_re": m.poles.real, "poles_im": m.poles.imag,
                    "residues_re": [np.atleast_2d(R.real) for R in m.residues],
                    "residues_im": [np.atleast_2d(R.imag) for R in m.residues],
                    "D": np.atleast_2d(m.D)})
        at.append(plain(rec))
    table["at"] = at
    return table


def model_text(ident: Identified, sources: Sequence[str]) -> str:
    """The model-file text (modal form, every channel).

    Parameters
    ----------
    ident : Identified
        The identification result.
    sources : sequence of str
        Names of the training records (named in the header comment).

    Returns
    -------
    str
        ``[model]`` with ``format = "robrst-modal-1"`` and one ``[[model.at]]`` per
        temperature.
    """
    m0 = ident.models[0]
    header = _header(ident, sources, "model file")
    law = ident.thermal
    if law is not None and law.std:
        header.append(f"per-kelvin laws fitted to these models"
                      f" ({'robrst thermal law holds' if law.consistent else law.note}): "
                      + ", ".join(f"{k} = {getattr(law, k):.6g} +/- {law.std[k]:.3g}"
                                  for k in ("gain_per_K", "resonance_per_K", "damping_per_K")))
    doc = document(header)
    doc["model"] = modal_model_table(ident.models, ident.order, ident.fs, "robrst identify")
    if (m0.n_in, m0.n_out) == (1, 1):
        try:
            plants = [m.channel(0, 0) for m in ident.models]
        except SpecError:      # too high an order for polynomials: no design from this file
            plants = None
        if plants is not None:
            _add_starting_design(doc, plants, ident.fs, ident.u_range_V)
    return tomlkit.dumps(doc)


def check_target(path: str | Path) -> Path:
    """The output path, refused when it is a folder or a file robrst identify did not write
    (called before any work, and again when writing).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``--out`` file.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    SpecError
        For a folder, or an existing file without robrst identify's first line.
    """
    path = Path(path)
    if path.is_dir():
        raise SpecError(f"{path}: is a folder; --out needs a file name (e.g."
                        f" {path / 'model.toml'})")
    check_file_target(path)
    if path.exists():
        first = (peek_text(path) or "").splitlines()[:1]
        if not first or not first[0].startswith(MARKER):
            raise SpecError(f"{path}: exists and was not written by robrst identify; not"
                            " overwriting it (choose another --out)")
    return path


def write_identified(ident: Identified, path: str | Path, sources: Sequence[str],
                     channel: tuple[int, int] | None = None, name: str | None = None,
                     modal: bool = False,
                     check: Callable[[str, Path], None] | None = None) -> Path:
    """Write a problem file (SISO or ``channel``) or a model file; atomically.

    Parameters
    ----------
    ident : Identified
        The identification result.
    path : str or pathlib.Path
        The output file; an existing file robrst identify did not write is refused.
    sources : sequence of str
        Names of the training records (named in the file's header comment).
    channel : (int, int), optional
        Output and input (0-based) of the problem file of a MIMO model.
    name : str, optional
        The problem name (default: the file stem).
    modal : bool
        Write the model file (modal form, any order) for one input and output too.
    check : callable, optional
        Called as ``check(text, path)`` with a problem file's text before anything is
        written; it raises :class:`SpecError` to refuse a file robrst could not read back
        (the CLI parses it as ``robrst.problem.files`` does, a layer above this one).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    SpecError
        ``modal`` with ``channel``, a channel the model does not have, a refused target or
        a problem file that cannot hold the model.
    """
    path = check_target(path)
    if modal and channel is not None:
        raise SpecError("--modal and --channel exclude each other: the model file holds every"
                        " channel, a problem file one")
    m = ident.models[0]
    if channel is None and (m.n_in, m.n_out) == (1, 1) and not modal:
        channel = (0, 0)
    if channel is not None:
        i, j = channel
        if not (0 <= i < m.n_out and 0 <= j < m.n_in):
            raise SpecError(f"channel y{i + 1} from u{j + 1} does not exist: the model has"
                            f" {m.n_out} output(s) and {m.n_in} input(s)")
        text = problem_text(ident, sources, name or path.stem, channel)
        if check is not None:
            check(text, path)
    else:
        text = model_text(ident, sources)
    atomic_write_text(path, text)
    return path


def _modal_models(path, data):
    table = read_model_table(path, data, design_tables=True)
    out = []
    for n, at in enumerate(table.at):
        try:
            out.append(ModalModel(at.poles, at.residues, at.D, label=f"{Path(path).stem}",
                                  temperature_C=at.temperature_C))
        except SpecError as exc:
            raise SpecError(f"{path}: [model.at.{n}] {exc}") from None
    return tuple(out)


def read_model_data(path: Path) -> dict:
    """The TOML table of a model or problem file (robrst's errors name the file).

    Parameters
    ----------
    path : pathlib.Path
        The file.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    SpecError
        An unreadable file or invalid TOML.
    """
    path = Path(path)
    text = read_utf8(path, "model file", "TOML", SpecError)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: invalid TOML ({exc})") from None


def modal_models(path: str | Path, data: dict) -> tuple[tuple[ModalModel, ...], float | None]:
    """Models of a model file's ``[model]`` table (``data`` as read from ``path``).

    Parameters
    ----------
    path : str or pathlib.Path
        The file, named in errors.
    data : dict
        Its parsed document.

    Returns
    -------
    models : tuple of ModalModel
        Lowest temperature first.
    reference_C : float or None
        The reference temperature (None when the file states none).

    Raises
    ------
    SpecError
        Naming the file and the key of a malformed table or array.
    """
    models = _modal_models(path, data)
    return models, models[0].temperature_C
