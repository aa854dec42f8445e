"""The base layer: exceptions, validated TOML, TOML writing, atomic files, shipped files, threads.

Everything above imports from here; nothing here imports robrst's higher layers.
"""
