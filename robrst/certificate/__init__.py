"""The certificate: exact peaks, stability and step figures over the temperature interval.

:mod:`~robrst.certificate.proof` certifies a controller on a problem's whole family,
:mod:`~robrst.certificate.models` holds the per-model checks and
:mod:`~robrst.certificate.steps` the reference-step figures (with private step kernels).
"""
