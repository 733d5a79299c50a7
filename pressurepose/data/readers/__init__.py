"""Readers and converters for other datasets: the official PressurePose release
(``pressurepose_pickle``), SLP pressure arrays (``slp``), and real pressure images with their labels
(``real.read_real``: PhysioNet PMD experiments I and II in ``pmd``, generic labelled folders in
``labelled``), and a bare recording of one person without labels (``recording.read_recording``)."""
