"""Arrays as labs store them -> robrst records (:class:`~robrst.data.dataset.Dataset`).

Measured data often come as multi-dimensional arrays, e.g. the data set of a
fine-steering mirror (KU Leuven, CC BY 4.0): ``(N, channel, realization, period)`` in
volts and metres.  :func:`records_from_arrays` turns one pair of input/output arrays into
one record per realization, its periods concatenated in order (a periodic record with
``period = N``), outputs converted to µm.  ``robrst convert`` is the command-line face.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robrst.data.dataset import Dataset, check_dataset
from robrst.base.errors import DataError
from robrst.base.fileio import check_input_file

__all__ = ["records_from_arrays", "load_array", "AXES", "Y_UNITS", "U_UNITS"]

AXES = ("time", "channel", "realization", "period")
Y_UNITS = {"m": 1e6, "mm": 1e3, "um": 1.0, "µm": 1.0, "nm": 1e-3}
U_UNITS = {"V": 1.0, "mV": 1e-3, "kV": 1e3}


def load_array(path: str | Path) -> np.ndarray:
    """Load a ``.npy`` array (no pickles).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.npy`` file.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    DataError
        Naming the file when it is missing or not a readable array.
    """
    check_input_file(path, "NumPy array file", DataError)
    try:
        return np.load(Path(path), allow_pickle=False)
    except FileNotFoundError:
        raise DataError(f"{path}: array file not found") from None
    except (ValueError, OSError) as exc:
        raise DataError(f"{path}: not a readable .npy array ({exc})") from None


def _axes(layout):
    names = [a.strip() for a in layout.split(",")]
    if "time" not in names or len(set(names)) != len(names) or not set(names) <= set(AXES):
        raise DataError(f"layout {layout!r}: expected distinct axis names from"
                        f" {', '.join(AXES)}, including 'time'")
    return names


def _standard(a, names, what):
    """Array with axes (time, channel, realization, period) in that order."""
    if a.ndim != len(names):
        raise DataError(f"{what}: array has {a.ndim} axes but the layout names {len(names)}"
                        f" ({', '.join(names)})")
    if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.bool_):
        raise DataError(f"{what}: array must be numeric, got {a.dtype}")
    if np.iscomplexobj(a):
        raise DataError(f"{what}: array is complex ({a.dtype}); a record is a real signal"
                        " (its imaginary part would be dropped): give the real part")
    for ax in AXES:
        if ax not in names:
            a = a[..., None]
            names = names + [ax]
    return np.transpose(a, [names.index(ax) for ax in AXES]).astype(float)


def records_from_arrays(u: np.ndarray, y: np.ndarray, fs: float,
                        layout: str = "time,channel,realization,period", y_unit: str = "m",
                        u_unit: str = "V", source: str = "arrays",
                        temp_C: float | None = None) -> list[Dataset]:
    """One :class:`Dataset` per realization from input/output arrays.

    Parameters
    ----------
    u, y : numpy.ndarray
        Input and output arrays with the axes named by ``layout`` (same sizes except
        the channel axis).
    fs : float
        Sampling rate [Hz].
    layout : str
        Comma-separated axis names out of ``time, channel, realization, period``;
        ``time`` is required, the others optional.  With a ``period`` axis each
        record is its periods in order and is marked periodic (``period = N``).
    y_unit, u_unit : str
        Units of the arrays (``m, mm, um, nm``; ``V, mV, kV``); records are µm and V.
    source : str
        Prefix of the records' names (``source`` + ``_r1``, ``_r2``, ...).
    temp_C : float, optional
        A constant temperature column [°C]; none by default.

    Returns
    -------
    list of Dataset

    Raises
    ------
    DataError
        A rate that is not > 0, unknown units or layout axes, arrays that do not match
        the layout or each other, non-numeric or complex arrays, NaN or inf, a
        non-finite temperature, and every record :func:`robrst.data.dataset.load_dataset`
        would refuse once written (fewer than 2 samples, values outside the plausible
        ranges, an output identically 0).

    Examples
    --------
    >>> import numpy as np
    >>> from robrst.data.convert import records_from_arrays
    >>> u = np.ones((100, 1, 2))                        # time x channel x realization
    >>> recs = records_from_arrays(u, 1e-6 * u, 1000.0, layout="time,channel,realization")
    >>> len(recs), float(recs[0].y[0])                  # metres -> µm
    (2, 1.0)
    """
    if not fs or not np.isfinite(fs) or fs <= 0:
        raise DataError(f"sampling rate must be > 0, got {fs}")
    if temp_C is not None and not np.isfinite(temp_C):
        raise DataError(f"temp_C: expected a finite temperature [°C], got {temp_C}")
    if y_unit not in Y_UNITS or u_unit not in U_UNITS:
        raise DataError(f"units: y in {sorted(Y_UNITS)}, u in {sorted(U_UNITS)}; got {y_unit!r},"
                        f" {u_unit!r}")
    names = _axes(layout)
    U = _standard(np.asarray(u), list(names), f"{source}: input array") * U_UNITS[u_unit]
    Y = _standard(np.asarray(y), list(names), f"{source}: output array") * Y_UNITS[y_unit]
    for ax, i in (("time", 0), ("realization", 2), ("period", 3)):
        if U.shape[i] != Y.shape[i]:
            raise DataError(f"{source}: input and output differ along {ax}"
                            f" ({U.shape[i]} vs {Y.shape[i]})")
    for what, a in (("input", U), ("output", Y)):
        if not np.all(np.isfinite(a)):
            raise DataError(f"{source}: NaN or inf in the {what} array")
    N, _, R, P = U.shape
    periodic = "period" in names
    out = []
    for r in range(R):
        u_r = np.concatenate([U[:, :, r, p] for p in range(P)])
        y_r = np.concatenate([Y[:, :, r, p] for p in range(P)])
        n = u_r.shape[0]
        out.append(Dataset(t=np.arange(n) / float(fs), u=u_r[:, 0] if u_r.shape[1] == 1 else u_r,
                           y=y_r[:, 0] if y_r.shape[1] == 1 else y_r,
                           temp=None if temp_C is None else np.full(n, float(temp_C)),
                           comments=(f"converted from {source}, realization {r + 1} of {R}",),
                           source=f"{source}_r{r + 1}", period=N if periodic else 0))
    for d in out:     # what the loader would refuse is not written
        check_dataset(d, f"{source}: record {d.source}")
    return out
