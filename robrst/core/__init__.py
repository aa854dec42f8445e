"""The maths core: polynomials, plants, thermal families, RST loops, peaks, margins.

One owner per numerical kernel: :mod:`~robrst.core.poly` (polynomials and the frequency
scaling), :mod:`~robrst.core.lti` (realisations, the ZOH kernel), :mod:`~robrst.core.plant`,
:mod:`~robrst.core.thermal` (the one thermal law), :mod:`~robrst.core.family`,
:mod:`~robrst.core.rst` (closed loops, Tustin), :mod:`~robrst.core.peaks` (exact H-infinity
peaks; private level-set kernels), :mod:`~robrst.core.analysis` (margins),
:mod:`~robrst.core.sampled` (the exact sampled loop) and :mod:`~robrst.core.interval`
(stability along a segment of plants).
"""
