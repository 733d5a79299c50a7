"""Calibration: CMA-ES fits of the bed's foundation and sensor constants (paper appendix A.4).

* :mod:`.objects`: to measured rigid objects on a mat (:mod:`.measurements`), or to documented
  physical targets of an average body;
* :mod:`.people`: to real pressure images of people (their contact area, loads and region shares,
  the statistics of :mod:`pressurepose.eval.realism`), pressing resting bodies of a dataset.
"""
