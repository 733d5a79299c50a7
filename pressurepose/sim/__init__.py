"""Bed, mat and sensor specs; physics simulation #2 (press); calibration of their constants.

>>> from pressurepose.sim import get_bed, press
>>> bed = get_bed("boditrak_bt3510")
>>> res = press(vertices, faces, mass_kg=62.5, bed=bed)   # res.pressure (64, 27) mmHg
"""

from pressurepose.sim.bed import (DEFAULT_MAT, MATS, BedSpec, FullGrid, MatSpec, custom_mat, get_bed,
                                  get_mat)
from pressurepose.sim.foundation import PressFailed
from pressurepose.sim.press import DEPTH_EMPTY_M, GRAVITY, PressResult, press
from pressurepose.sim.sensor import MMHG_PA, force_to_mmhg, read_sensor

__all__ = ["BedSpec", "MatSpec", "FullGrid", "MATS", "DEFAULT_MAT", "get_bed", "get_mat", "custom_mat",
           "press", "PressResult", "PressFailed", "DEPTH_EMPTY_M", "GRAVITY", "MMHG_PA", "read_sensor",
           "force_to_mmhg"]
