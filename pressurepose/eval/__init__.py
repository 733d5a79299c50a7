"""Evaluation: ``metrics`` (MPJPE, v2v, 3DVPE, the mean-pose baseline), ``report`` (the accuracy
table of a trained PressureNet on a dataset) and the ``evaluate`` verb (``commands``)."""
