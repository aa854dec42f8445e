"""The versions a result was computed with (a saved design carries them)."""

import platform
import sys
from importlib import metadata

__all__ = ["versions", "PACKAGES"]

PACKAGES = ("robrst", "numpy", "scipy", "casadi", "control")


def versions() -> dict:
    """``{package: version}`` of robrst and the libraries its numbers depend on, plus
    ``python`` and ``platform`` (``None`` for a package not installed).

    Returns
    -------
    dict

    Examples
    --------
    >>> sorted(versions())[:3]
    ['casadi', 'control', 'numpy']
    """
    out = {}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    if out["robrst"] is None:           # a source tree that is not installed
        from robrst import __version__

        out["robrst"] = __version__
    out["python"] = sys.version.split()[0]
    out["platform"] = f"{platform.system()} {platform.machine()}"
    return out
