"""robrst benchmarks: robrst paths against the baselines users would otherwise write.

Run ``python -m benchmarks`` (``--tiny`` for the smoke sizes the test suite uses).
Each benchmark runs robrst and its baseline in the same process, alternating, over
several repeats, and reports the median of the per-repeat time ratios: absolute times
on a shared machine are noisy, ratios are what count.
"""
