"""Datasets: the sample schema, the shard store, the generation pipeline and its executors, readers
for this project's datasets and for PressurePose and SLP files, and mat-to-mat resampling.

Import from the submodules (``pressurepose.data.schema``, ``.pipeline``, ``.dataset``...); this
package stays light so that ``import pressurepose.data`` is fast.
"""
