"""The identification report draws the curves of :mod:`robrst.identify.curves`.

Records of the paper's plant simulated by python-control (ZOH) are identified; the report
folder holds its three figures and the identified JSON, and the curves it drew are the
model's own frequency response (checked against python-control on the same frequencies)
and a simulated output that follows the measured one.
"""

import control
import numpy as np

from robrst.core.plant import paper_plant
from robrst.data.dataset import Dataset
from robrst.identify.curves import identification_curves
from robrst.identify.identification import identify
from robrst.report.identification import FIGURES, write_identification_report

FS = 20000.0


def _records(n=8000):
    plant = paper_plant()
    sysd = control.c2d(plant.to_tf(), 1.0 / FS, method="zoh")
    out = []
    for s in (1, 2, 3):
        rng = np.random.default_rng(s)
        u = np.repeat(rng.uniform(0, 150, n // 400 + 1), 400)[:n]
        y = np.ravel(control.forced_response(sysd, U=u).outputs)
        out.append(Dataset(t=np.arange(n) / FS, u=u, y=y, source=f"r{s}"))
    return out


def test_the_report_draws_the_identification_curves(tmp_path):
    recs = _records()
    ident = identify(recs[:2], validate=recs[2:], order=3)
    curves = identification_curves(ident, recs)
    ref = np.array([complex(np.ravel(paper_plant().to_tf()(2j * np.pi * f))[0])
                    for f in curves.f_model[::50]])            # python-control, the truth
    got = curves.model[::50, 0, 0]
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 0.05
    err = np.linalg.norm(curves.simulated - curves.measured)
    assert err <= 0.05 * np.linalg.norm(curves.measured - curves.measured.mean())
    folder = write_identification_report(ident, recs, tmp_path / "rep", curves=curves)
    assert sorted(p.name for p in folder.glob("*.png")) == sorted(FIGURES)
    assert (folder / "identified.json").is_file()
