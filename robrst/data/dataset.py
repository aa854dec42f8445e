"""The project's data format: measured and simulated records share it.

Two file formats hold the same :class:`Dataset` (units s, V, µm, °C; uniform sampling;
``u`` is the *commanded* input):

* **CSV** — optional ``#`` comment lines, one header line, then rows.  Columns: ``t``
  (required), the inputs ``u`` (one input) or ``u1..uk``, the outputs ``y`` or
  ``y1..ym``, optionally ``temp`` and (one output only) the reference ``yr``.  A
  comment line ``# period_samples = P`` marks a periodic record (a whole number of
  periods of P samples, e.g. repeated multisine periods).
* **NPZ** (``numpy.savez``) — arrays ``t`` (N), ``u`` (N or N x k), ``y`` (N or
  N x m), optional ``temp`` (N), ``yr`` (N) and ``period_samples`` (integer scalar).

Unknown columns or arrays are an error (nothing is silently dropped), as are NaN/inf,
non-monotonic or non-uniform time, and values no actuator in these units can produce
(displacement in metres, temperature in kelvin); every error names the file, and the
line or column.  CSV bodies are parsed in bulk (``numpy.loadtxt``); only a file that
fails is re-read line by line to name the offending line.
"""

from __future__ import annotations

import io
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robrst.base.errors import DataError
from robrst.base.fileio import atomic_write_bytes, atomic_write_text, check_input_file, read_utf8

__all__ = ["Dataset", "load_dataset", "save_dataset", "check_dataset", "check_sensor", "COLUMNS",
           "PLAUSIBLE"]

COLUMNS = ("t", "u", "y")          # required (u/y or u1..uk/y1..ym)
# plausible ranges per kind of column (units s, V, µm, °C)
PLAUSIBLE = {"u": (-1000.0, 1000.0, "V"), "y": (-1.0e4, 1.0e4, "µm"), "yr": (-1.0e4, 1.0e4, "µm"),
             "temp": (-60.0, 200.0, "°C")}
TIME_RTOL = 1e-6
#: sampling rates a record may have [Hz]: a thermal log at one sample per 1,000 s to a
#: 1 GHz digitiser; beyond, the time column is in another unit (ms, µs) or not a time
PLAUSIBLE_RATE_HZ = (1e-3, 1e9)
_PERIOD = re.compile(r"^period_samples\s*[=:]\s*(\d+)\s*$")
_NPZ_KEYS = ("t", "u", "y", "temp", "yr", "period_samples")


@dataclass(frozen=True, eq=False)
class Dataset:
    """Uniformly sampled record: t [s], u [V, commanded], y [µm], temp [°C], yr [µm].

    ``u`` and ``y`` are 1-D for one input/output, ``(N, k)`` / ``(N, m)`` otherwise
    (:attr:`U` and :attr:`Y` are always 2-D).

    Parameters
    ----------
    t : numpy.ndarray
        Time [s], uniform.
    u : numpy.ndarray
        Commanded input(s) [V].
    y : numpy.ndarray
        Output(s) [µm].
    temp : numpy.ndarray, optional
        Temperature [°C]; ``None`` when not measured.
    yr : numpy.ndarray, optional
        Reference [µm] (one output only).
    comments : tuple of str
        Comment lines of the file.
    source : str
        Where the record comes from (its file), named in messages.
    period : int
        Samples per period of a periodic excitation (0: not periodic); a periodic
        record holds a whole number of periods in steady state.

    Attributes
    ----------
    fs : float
        Sampling rate [Hz] (NaN below 2 samples).
    n : int
        Number of samples.
    U, Y : numpy.ndarray
        Inputs ``(N, k)`` and outputs ``(N, m)``.
    n_in, n_out : int
        Number of inputs and outputs.
    periods : int
        Whole periods in the record (0 when not periodic).
    level : float
        Excitation level: RMS of the inputs about their mean [V].
    """

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    temp: np.ndarray = None
    yr: np.ndarray = None
    comments: tuple = ()
    source: str = ""
    period: int = 0

    @property
    def fs(self):
        """Sampling rate [Hz]."""
        if len(self.t) < 2:
            return np.nan
        return float(f"{(len(self.t) - 1) / (self.t[-1] - self.t[0]):.12g}")

    @property
    def n(self):
        """Number of samples."""
        return len(self.t)

    @property
    def U(self):
        """Inputs as an ``(N, k)`` array."""
        return self.u.reshape(self.n, -1)

    @property
    def Y(self):
        """Outputs as an ``(N, m)`` array."""
        return self.y.reshape(self.n, -1)

    @property
    def n_in(self):
        return self.U.shape[1]

    @property
    def n_out(self):
        return self.Y.shape[1]

    @property
    def periods(self):
        """Whole periods in the record (0 when not periodic)."""
        return self.n // self.period if self.period else 0

    @property
    def level(self):
        """Excitation level: RMS of the inputs about their mean [V]."""
        U = self.U
        return float(np.sqrt(np.mean((U - U.mean(axis=0)) ** 2)))

    def temp_or(self, default_C: float) -> np.ndarray:
        """Temperature per sample, ``default_C`` everywhere when not measured.

        Parameters
        ----------
        default_C : float
            The temperature to assume [°C].

        Returns
        -------
        numpy.ndarray
            ``n`` temperatures [°C].
        """
        return np.full(self.n, float(default_C)) if self.temp is None else self.temp

    def column_names(self) -> list[str]:
        """The CSV column names of this record, in file order.

        Returns
        -------
        list of str
            ``t``, ``u`` or ``u1..uk``, ``y`` or ``y1..ym``, then ``temp`` and ``yr``
            when present.
        """
        u = ["u"] if self.u.ndim == 1 else [f"u{i + 1}" for i in range(self.n_in)]
        y = ["y"] if self.y.ndim == 1 else [f"y{i + 1}" for i in range(self.n_out)]
        return ["t", *u, *y] + (["temp"] if self.temp is not None else []) + (
            ["yr"] if self.yr is not None else [])

    def columns(self) -> dict[str, np.ndarray]:
        """Name -> 1-D array, in file order.

        Returns
        -------
        dict
            The columns of :meth:`column_names`.
        """
        arrays = [self.t, *self.U.T, *self.Y.T]
        arrays += [self.temp] if self.temp is not None else []
        arrays += [self.yr] if self.yr is not None else []
        return dict(zip(self.column_names(), arrays))


def check_sensor(d: Dataset) -> None:
    """Refuse a record whose output column is constant while an input varies.

    A valid file (a sensor that was off or saturated still writes numbers), but nothing
    to fit or compare a model with: identification and diagnosis both call this.

    Parameters
    ----------
    d : Dataset
        The record (its ``source`` is named).

    Raises
    ------
    DataError
        Naming the record's file and the column, e.g. ``column y is constant (3 µm)``.
    """
    flat = [j for j in range(d.n_out) if np.ptp(d.Y[:, j]) == 0.0]
    if flat and np.ptp(d.U, axis=0).max() > 0.0:
        col = "y" if d.n_out == 1 else f"y{flat[0] + 1}"
        raise DataError(f"{d.source or 'record'}: column {col} is constant"
                        f" ({d.Y[0, flat[0]]:g} µm) while u varies: no sensor signal to fit"
                        " or compare a model with")


def save_dataset(ds: Dataset, path: str | Path, comments: Iterable[str] = ()) -> Path:
    """Write ``ds`` atomically: ``.npz`` by suffix, else CSV (``%.9g``; time ``%.12g``).

    Parameters
    ----------
    ds : Dataset
        The record.
    path : str or pathlib.Path
        The file; its suffix chooses the format.
    comments : iterable of str
        Extra comment lines (CSV only), after the record's own.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = Path(path)
    if path.suffix == ".npz":
        arrays = {"t": ds.t, "u": ds.u, "y": ds.y}
        arrays.update({k: v for k, v in (("temp", ds.temp), ("yr", ds.yr)) if v is not None})
        if ds.period:
            arrays["period_samples"] = np.int64(ds.period)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return atomic_write_bytes(path, buf.getvalue())
    cols = ds.columns()
    lines = [f"# {c}" for c in (*ds.comments, *comments)]
    if ds.period:
        lines.append(f"# period_samples = {ds.period}")
    lines.append(",".join(cols))
    arr = np.column_stack(list(cols.values()))
    buf = io.StringIO()
    np.savetxt(buf, arr, fmt=["%.12g"] + ["%.9g"] * (arr.shape[1] - 1), delimiter=",")
    atomic_write_text(path, "\n".join(lines) + "\n" + buf.getvalue())
    return path


def _kind(name):
    """'u', 'y', 'temp', 'yr', 't' for a column name; None if unknown."""
    if name in ("t", "u", "y", "temp", "yr"):
        return name
    m = re.fullmatch(r"([uy])([1-9][0-9]*)", name)
    return m.group(1) if m else None


def _check_header(path, header, hline):
    where = f"{path}: line {hline}"
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise DataError(f"{where}: duplicate column(s) {', '.join(dup)}")
    extra = [h for h in header if _kind(h) is None]
    if extra:
        raise DataError(f"{where}: unknown column(s) {', '.join(extra)}; allowed t, u or u1..uk,"
                        " y or y1..ym, temp, yr")
    for c in COLUMNS:
        if not any(_kind(h) == c for h in header):
            raise DataError(f"{where}: missing column(s) {c}; expected t, u (or u1..uk), y (or"
                            f" y1..ym)[, temp][, yr]; got {','.join(header)}")
    for c in ("u", "y"):
        names = [h for h in header if _kind(h) == c]
        if c in names and len(names) > 1:
            raise DataError(f"{where}: column {c} mixed with {c}1..; use {c}1..{c}k for several")
        if c not in names:
            want = [f"{c}{i + 1}" for i in range(len(names))]
            if sorted(names, key=lambda s: int(s[1:])) != want:
                raise DataError(f"{where}: columns {', '.join(names)} must be numbered"
                                f" {c}1..{c}{len(names)} without gaps")
    if "yr" in header and sum(_kind(h) == "y" for h in header) > 1:
        raise DataError(f"{where}: column yr needs exactly one output column")


def _slow_parse(path, body, first_line, n_fields):
    """Line-by-line parse of a body the bulk parser rejected: name the first bad line."""
    for k, line in enumerate(body, start=first_line):
        if not line.strip():
            continue
        parts = line.split(",")
        if len(parts) != n_fields:
            raise DataError(f"{path}: line {k}: {len(parts)} fields, expected {n_fields}")
        try:
            if "_" in line:      # Python's float reads 1_000; the bulk parser does not
                raise ValueError(line)
            [float(p) for p in parts]
        except ValueError:
            raise DataError(f"{path}: line {k}: non-numeric value in {line.strip()!r}") from None
    raise DataError(f"{path}: unreadable data rows")


def _read_lines(path):
    """The lines of a UTF-8 text file; :class:`DataError` for anything else."""
    text = read_utf8(path, "data file", "CSV", DataError)
    if "\x00" in text:
        raise DataError(f"{path}: contains NUL bytes; expected a CSV text file (UTF-8)")
    return text.splitlines()


def _read_csv(path):
    lines = _read_lines(path)
    comments, i = [], 0
    while i < len(lines) and (lines[i].startswith("#") or not lines[i].strip()):
        if lines[i].startswith("#"):
            comments.append(lines[i][1:].strip())
        i += 1
    if i == len(lines):
        raise DataError(f"{path}: no header line (expected columns t, u, y[, temp])")
    header = [h.strip() for h in lines[i].split(",")]
    hline = i + 1
    _check_header(path, header, hline)
    body = lines[i + 1:]
    if not any(line.strip() for line in body):
        arr = np.zeros((0, len(header)))     # header only: "fewer than 2 data rows" below
    else:
        try:
            arr = np.loadtxt(io.StringIO("\n".join(body)), delimiter=",", comments=None,
                             ndmin=2)
        except ValueError:
            _slow_parse(path, body, hline + 1, len(header))
    if arr.shape[1] != len(header):
        _slow_parse(path, body, hline + 1, len(header))

    def line_of(j):  # file line of data row j (blank lines are skipped by the parser)
        rows = [k for k, line in enumerate(body, start=hline + 1) if line.strip()]
        return rows[j]

    period, kept = 0, []
    for c in comments:
        m = _PERIOD.match(c)
        if m:
            period = int(m.group(1))
        else:
            kept.append(c)
    return {h: arr[:, j] for j, h in enumerate(header)}, tuple(kept), period, line_of, header


def _read_npz(path):
    check_input_file(path, "data file", DataError)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: np.asarray(z[k]) for k in z.files}
    except FileNotFoundError:
        raise DataError(f"{path}: data file not found") from None
    except (ValueError, OSError) as exc:
        raise DataError(f"{path}: not a readable .npz file ({exc})") from None
    extra = [k for k in data if k not in _NPZ_KEYS]
    if extra:
        raise DataError(f"{path}: unknown array(s) {', '.join(extra)}; allowed"
                        f" {', '.join(_NPZ_KEYS)}")
    for k in COLUMNS:
        if k not in data:
            raise DataError(f"{path}: missing array {k!r}; expected t (N), u (N or N x k),"
                            " y (N or N x m)[, temp (N)][, period_samples]")
    t = data["t"]
    if t.ndim != 1:
        raise DataError(f"{path}: array t must be 1-D, got shape {t.shape}")
    for k in ("t", "u", "y", "temp", "yr"):
        # integers and floats only: a complex array would lose its imaginary part
        if k in data and data[k].dtype.kind not in "iuf":
            raise DataError(f"{path}: array {k} must hold real numbers (integer or float),"
                            f" got dtype {data[k].dtype}")
    cols, header = {"t": t.astype(float)}, ["t"]
    for k in ("u", "y", "temp", "yr"):
        if k not in data:
            continue
        a = data[k]
        if a.shape[:1] != t.shape or a.ndim > (2 if k in ("u", "y") else 1):
            raise DataError(f"{path}: array {k} has shape {a.shape}; expected ({t.size},"
                            + (f" or ({t.size}, channels)" if k in ("u", "y") else "") + ")")
        a = a.astype(float)
        if a.ndim == 2 and a.shape[1] == 1:
            a = a[:, 0]
        names = [k] if a.ndim == 1 else [f"{k}{i + 1}" for i in range(a.shape[1])]
        for j, name in enumerate(names):
            cols[name] = a if a.ndim == 1 else a[:, j]
        header += names
    if "yr" in cols and sum(_kind(h) == "y" for h in header) > 1:
        raise DataError(f"{path}: array yr needs a single output y")
    period = 0
    if "period_samples" in data:
        p = data["period_samples"]
        if p.shape != () or not np.issubdtype(p.dtype, np.integer):
            raise DataError(f"{path}: period_samples must be an integer scalar, got {p!r}")
        period = int(p)
    return cols, (), period, (lambda j: f"sample {j}"), header


def _check_columns(path, col, header, period, at):
    """The loader's checks of a record's columns (named ``header``, in ``col``); returns the
    input and output column names.  ``at(j)`` names data row ``j`` in messages."""
    n = col["t"].size
    if n < 2:
        raise DataError(f"{path}: fewer than 2 data rows")
    for h in header:
        bad = np.flatnonzero(~np.isfinite(col[h]))
        if bad.size:
            j = int(bad[0])
            names = [c for c in header if not np.isfinite(col[c][j])]
            raise DataError(f"{path}: {at(j)}: NaN or inf in column(s) {', '.join(names)}")
    t = col["t"]
    dt = np.diff(t)
    if np.any(dt <= 0):
        j = int(np.argmax(dt <= 0)) + 1
        raise DataError(f"{path}: {at(j)}: time not strictly increasing"
                        f" ({t[j - 1]:.9g} -> {t[j]:.9g})")
    h = (t[-1] - t[0]) / (n - 1)
    if not PLAUSIBLE_RATE_HZ[0] <= 1.0 / h <= PLAUSIBLE_RATE_HZ[1]:
        raise DataError(f"{path}: column t: sampling rate {1.0 / h:.6g} Hz (step {h:.6g} s)"
                        f" outside the plausible range [{PLAUSIBLE_RATE_HZ[0]:g},"
                        f" {PLAUSIBLE_RATE_HZ[1]:g}] Hz: is the time column in seconds?")
    dev = np.abs(dt - h)
    if np.max(dev) > TIME_RTOL * h + 1e-12:
        j = int(np.argmax(dev)) + 1
        raise DataError(f"{path}: {at(j)}: non-uniform sampling (step {dt[j - 1]:.6g} s,"
                        f" expected {h:.6g} s); resample before loading")
    for name in header:
        kind = _kind(name)
        if kind not in PLAUSIBLE:
            continue
        lo, hi, unit = PLAUSIBLE[kind]
        v = col[name]
        out = np.flatnonzero((v < lo) | (v > hi))
        if out.size:
            j = int(out[0])
            hint = " (kelvin? expected °C)" if kind == "temp" and v[j] > 200 else ""
            hint += " (displacement in nm? expected µm)" if kind == "y" else ""
            raise DataError(f"{path}: {at(j)}: column {name} = {v[j]:.6g} outside the"
                            f" plausible range [{lo:g}, {hi:g}] {unit}{hint}")
    ins = [h for h in header if _kind(h) == "u"]
    outs = [h for h in header if _kind(h) == "y"]
    for name in outs:
        if not np.any(col[name]):
            raise DataError(f"{path}: column {name} is identically 0 over {len(t)} rows: no"
                            " measured displacement (expected y in µm from the sensor)")
    u_moves = max(np.ptp(col[c]) for c in ins) > 1e-3
    for name in outs:
        peak = np.max(np.abs(col[name]))
        if 0 < peak < 1e-3 and u_moves:
            raise DataError(f"{path}: column {name} never exceeds 1e-3 µm while the input varies:"
                            " displacement looks like metres; the format expects µm (convert"
                            " with `robrst convert --y-unit m`)")
    if period:
        if period < 2 or n % period:
            raise DataError(f"{path}: period_samples = {period} does not divide the {n} samples"
                            " into whole periods")
    return ins, outs


def check_dataset(ds: Dataset, where: str) -> None:
    """Refuse a record (in memory) that :func:`load_dataset` would refuse once written.

    Parameters
    ----------
    ds : Dataset
    where : str
        What to name in messages (e.g. the record file about to be written).

    Raises
    ------
    DataError
        The loader's message: fewer than 2 samples, NaN or inf, non-uniform time, a value
        outside its plausible range (temperature, input, output), an output identically 0.
    """
    col = ds.columns()
    _check_columns(where, col, list(col), ds.period, lambda j: f"sample {j}")


def load_dataset(path: str | Path) -> Dataset:
    """Read and validate a dataset (``.npz`` by suffix, else CSV).

    Parameters
    ----------
    path : str or pathlib.Path
        A record file in the format of this module's docstring.

    Returns
    -------
    Dataset
        With ``source`` the file's name.

    Raises
    ------
    DataError
        Naming the file and the line (CSV) or array/column of the first problem.
    """
    path = Path(path)
    npz = path.suffix == ".npz"
    col, comments, period, line_of, header = _read_npz(path) if npz else _read_csv(path)

    def at(j):  # location of data row j in messages
        loc = line_of(j)
        return loc if npz else f"line {loc}"

    ins, outs = _check_columns(path, col, header, period, at)

    def stack(names):
        if len(names) == 1 and names[0] in ("u", "y"):
            return col[names[0]]
        order = sorted(names, key=lambda s: int(s[1:]))
        return np.column_stack([col[c] for c in order]) if len(order) > 1 else col[order[0]]

    return Dataset(t=col["t"], u=stack(ins), y=stack(outs), temp=col.get("temp"), yr=col.get("yr"),
                   comments=comments, source=str(path), period=period)
