"""Where the tests find the measured fine-steering mirror's arrays (one place to change).

``mirror_data_dir()`` returns a folder of ``u_{level}mV_{split}.npy`` / ``y_...`` arrays in
the data set's own layout, or None when the checkout has none (the tests then skip).  The
suite ships a compact copy (``tests/data/fsm_compact``: one realization of every level's
training and test records); the tests never read beside the checkout.
"""

from pathlib import Path

COMPACT = Path(__file__).resolve().parent / "data" / "fsm_compact"


def mirror_data_dir():
    """Folder of the mirror's arrays for the tests, or None."""
    return COMPACT if (COMPACT / "u_100mV_train.npy").is_file() else None
