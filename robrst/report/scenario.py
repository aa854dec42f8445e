"""``robrst simulate``: a scenario's datasets (CSV) and figure (PNG) in one folder."""

from pathlib import Path

from robrst.dataset import save_dataset
from robrst.report.figure import drawing

__all__ = ["write_scenario"]


def write_scenario(res, out_dir):
    """Write every dataset of ``res`` (a ScenarioResult) and ``<name>.png`` into ``out_dir``.

    Returns
    -------
    Path
        The folder.
    """
    out = Path(out_dir)
    for k, d in res.datasets.items():
        save_dataset(d, out / f"{k}.csv")
    with drawing(out / f"{res.name}.png", (8, 5), dpi=110, tight=False) as (fig, ax):
        for label, (x, y, xl, yl) in res.curves.items():
            ax.plot(x, y, label=label, lw=1)
            ax.set_xlabel(xl)
            ax.set_ylabel(yl)
        ax.set_title(f"{res.name}: {res.claim}", fontsize=10)
        ax.legend(fontsize=8)
    return out
