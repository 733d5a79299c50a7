"""Readers and converters for other datasets: the official PressurePose release
(``pressurepose_pickle``) and SLP pressure arrays (``slp``)."""
