"""The physics: the bed and its sensor, the ragdoll settle and the press (mat geometry: :mod:`pressurepose.mat`).

>>> from pressurepose.sim import get_bed, press
>>> bed = get_bed("boditrak_bt3510")
>>> res = press(vertices, faces, mass_kg=62.5, bed=bed)   # res.pressure (64, 27) mmHg
"""

from pressurepose.sim.bed import BedSpec, FullGrid, get_bed
from pressurepose.sim.foundation import PressFailed
from pressurepose.sim.press import DEPTH_EMPTY_M, GRAVITY, PressResult, press
from pressurepose.sim.sensor import MMHG_PA, force_to_mmhg, read_sensor

__all__ = ["BedSpec", "FullGrid", "get_bed", "press", "PressResult", "PressFailed", "DEPTH_EMPTY_M", "GRAVITY", "MMHG_PA", "read_sensor",
           "force_to_mmhg"]
