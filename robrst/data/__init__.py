"""Measured and simulated records: the data format (:mod:`~robrst.data.dataset`) and the
conversion of other formats (:mod:`~robrst.data.convert`)."""
