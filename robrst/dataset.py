"""The project's data format: measured and simulated datasets share it.

A CSV file: optional ``#`` comment lines, one header line, then rows.  Required
columns ``t,u,y,temp`` (+ optional ``yr``), in s, V, µm, °C; uniformly sampled;
``u`` is the *commanded* voltage.  Extra columns are an error (nothing is silently
dropped or ignored), as are NaN/inf, non-monotonic or non-uniform time, and values
no actuator in these units can produce (e.g. displacement in metres, temperature in
kelvin); every error names the file, and the line or column.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robrst.errors import DataError
from robrst.fileio import atomic_write_text

__all__ = ["Dataset", "load_dataset", "save_dataset", "COLUMNS", "PLAUSIBLE"]

COLUMNS = ("t", "u", "y", "temp")
OPTIONAL = ("yr",)
# plausible ranges per column (units s, V, µm, °C)
PLAUSIBLE = {"u": (-1000.0, 1000.0, "V"), "y": (-1.0e4, 1.0e4, "µm"), "yr": (-1.0e4, 1.0e4, "µm"),
             "temp": (-60.0, 200.0, "°C")}
TIME_RTOL = 1e-6


@dataclass(frozen=True, eq=False)
class Dataset:
    """Uniformly sampled record: t [s], u [V, commanded], y [µm], temp [°C], yr [µm]."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    temp: np.ndarray
    yr: np.ndarray = None
    comments: tuple = ()
    source: str = ""

    @property
    def fs(self):
        return float((len(self.t) - 1) / (self.t[-1] - self.t[0])) if len(self.t) > 1 else np.nan

    @property
    def n(self):
        return len(self.t)

    def columns(self):
        cols = {"t": self.t, "u": self.u, "y": self.y, "temp": self.temp}
        if self.yr is not None:
            cols["yr"] = self.yr
        return cols


def save_dataset(ds, path, comments=()):
    """Write ``ds`` as CSV atomically (``%.9g``; time with full precision)."""
    cols = ds.columns()
    lines = [f"# {c}" for c in (*ds.comments, *comments)]
    lines.append(",".join(cols))
    arr = np.column_stack(list(cols.values()))
    fmt = ["%.12g"] + ["%.9g"] * (arr.shape[1] - 1)
    body = "\n".join(",".join(f % v for f, v in zip(fmt, row)) for row in arr)
    atomic_write_text(path, "\n".join(lines) + "\n" + body + "\n")
    return Path(path)


def _read_lines(path):
    """The lines of a UTF-8 text file; :class:`DataError` for anything else."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{path}: data file not found") from None
    except IsADirectoryError:
        raise DataError(f"{path}: is a folder, expected a data file (CSV)") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read the data file ({exc.strerror})") from None
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise DataError(f"{path}: data file is UTF-16; save it as UTF-8")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise DataError(f"{path}: line {line}: not valid UTF-8 (byte 0x{raw[exc.start]:02x});"
                        " save the data file as UTF-8") from None
    if "\x00" in text:
        raise DataError(f"{path}: contains NUL bytes; expected a CSV text file (UTF-8)")
    return text.removeprefix("\ufeff").splitlines()


def load_dataset(path):
    """Read and validate a dataset CSV; raise :class:`DataError` naming file and line."""
    path = Path(path)
    lines = _read_lines(path)
    comments, i = [], 0
    while i < len(lines) and (lines[i].startswith("#") or not lines[i].strip()):
        if lines[i].startswith("#"):
            comments.append(lines[i][1:].strip())
        i += 1
    if i == len(lines):
        raise DataError(f"{path}: no header line (expected columns {','.join(COLUMNS)})")
    header = [h.strip() for h in lines[i].split(",")]
    hline = i + 1
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise DataError(f"{path}: line {hline}: missing column(s) {', '.join(missing)};"
                        f" expected {','.join(COLUMNS)}[,yr], got {','.join(header)}")
    extra = [h for h in header if h not in COLUMNS + OPTIONAL]
    if extra:
        raise DataError(f"{path}: line {hline}: unknown column(s) {', '.join(extra)};"
                        f" allowed {','.join(COLUMNS + OPTIONAL)}")
    if len(set(header)) != len(header):
        raise DataError(f"{path}: line {hline}: duplicate column names")
    rows = []
    for k, line in enumerate(lines[i + 1:], start=hline + 1):
        if not line.strip():
            continue
        parts = line.split(",")
        if len(parts) != len(header):
            raise DataError(f"{path}: line {k}: {len(parts)} fields, expected {len(header)}")
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise DataError(f"{path}: line {k}: non-numeric value in {line.strip()!r}") from None
        bad = [h for h, v in zip(header, vals) if not np.isfinite(v)]
        if bad:
            raise DataError(f"{path}: line {k}: NaN or inf in column(s) {', '.join(bad)}")
        rows.append((k, vals))
    if len(rows) < 2:
        raise DataError(f"{path}: fewer than 2 data rows")
    arr = np.array([v for _, v in rows])
    line_of = [k for k, _ in rows]
    col = {h: arr[:, j] for j, h in enumerate(header)}
    t = col["t"]
    dt = np.diff(t)
    if np.any(dt <= 0):
        j = int(np.argmax(dt <= 0)) + 1
        raise DataError(f"{path}: line {line_of[j]}: time not strictly increasing"
                        f" ({t[j - 1]:.9g} -> {t[j]:.9g})")
    h = (t[-1] - t[0]) / (len(t) - 1)
    dev = np.abs(dt - h)
    if np.max(dev) > TIME_RTOL * h + 1e-12:
        j = int(np.argmax(dev)) + 1
        raise DataError(f"{path}: line {line_of[j]}: non-uniform sampling (step {dt[j - 1]:.6g} s,"
                        f" expected {h:.6g} s); resample before loading")
    for name, (lo, hi, unit) in PLAUSIBLE.items():
        if name not in col:
            continue
        v = col[name]
        out = np.flatnonzero((v < lo) | (v > hi))
        if out.size:
            j = int(out[0])
            hint = " (kelvin? expected °C)" if name == "temp" and v[j] > 200 else ""
            raise DataError(f"{path}: line {line_of[j]}: column {name} = {v[j]:.6g} outside the"
                            f" plausible range [{lo:g}, {hi:g}] {unit}{hint}")
    if not np.any(col["y"]):
        raise DataError(f"{path}: column y is identically 0 over {len(t)} rows: no measured"
                        " displacement (expected y in µm from the sensor)")
    if np.max(np.abs(col["y"])) < 1e-3 and np.max(np.abs(col["y"])) > 0 and np.ptp(col["u"]) > 0.1:
        raise DataError(f"{path}: column y never exceeds 1e-3 µm while u varies: displacement"
                        " looks like metres; the format expects µm")
    return Dataset(t=t, u=col["u"], y=col["y"], temp=col["temp"], yr=col.get("yr"),
                   comments=tuple(comments), source=str(path))
