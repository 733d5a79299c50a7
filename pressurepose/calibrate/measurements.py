"""Calibration measurements: rigid capsules of known size and weight on the real mat.

One file (``.npz``, read without pickle) holds J objects, each lying horizontally on the bed, with
the mat's pressure image under it and how far it sank. Arrays (docs/calibration.md has the full
description):

=================  ==================  =====================================================
key                shape, dtype        meaning
=================  ==================  =====================================================
format             () str              ``"pressurepose-calibration"``
version            () int              ``1``
mat_name           () str              a preset name or any label
mat_shape          (2,) int            taxel rows (along the bed), cols (across)
mat_pitch_m        (2,) float          taxel pitch along the bed, across the bed, metres
max_mmhg           () float            top of the sensor's range
radius_m           (J,) float          capsule radius
length_m           (J,) float          capsule length end to end, caps included (>= 2 r)
mass_kg            (J,) float          capsule mass with any weights on it
center_xy_m        (J, 2) float        bed-frame x, y of the capsule's centre
yaw_rad            (J,) float          angle of the capsule's axis from the bed's x axis
pressure_mmhg      (J, rows, cols)     the mat's reading with the object at rest, >= 0
sink_m             (J,) float          depth of the object's lowest point below the unloaded
                                       mattress top, metres, positive when sunk
=================  ==================  =====================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pressurepose.errors import BadInput
from pressurepose.files import load_npz, save_npz_atomic
from pressurepose.mat import MatSpec

FORMAT = "pressurepose-calibration"
VERSION = 1


@dataclass(frozen=True)
class CapsuleMeasurements:
    """J capsule measurements on one mat (see the module docstring for each array)."""

    mat: MatSpec
    radius_m: np.ndarray
    length_m: np.ndarray
    mass_kg: np.ndarray
    center_xy_m: np.ndarray
    yaw_rad: np.ndarray
    pressure_mmhg: np.ndarray
    sink_m: np.ndarray

    def __post_init__(self):
        j = np.asarray(self.radius_m).shape
        if len(j) != 1 or j[0] < 1:
            raise BadInput(f"radius_m has shape {j}; expected (J,) with J >= 1 objects")
        n = j[0]
        shapes = {"radius_m": (n,), "length_m": (n,), "mass_kg": (n,), "center_xy_m": (n, 2), "yaw_rad": (n,),
                  "pressure_mmhg": (n,) + self.mat.shape, "sink_m": (n,)}
        for name, shape in shapes.items():
            try:
                a = np.asarray(getattr(self, name), dtype=np.float64)
            except (TypeError, ValueError):
                raise BadInput(f"{name} must be numeric; expected shape {shape}") from None
            if a.shape != shape:
                raise BadInput(f"{name} has shape {a.shape}; expected {shape} for {n} objects on the "
                               f"{self.mat.rows} x {self.mat.cols} {self.mat.name} mat")
            if not np.all(np.isfinite(a)):
                raise BadInput(f"{name} contains NaN or infinite values")
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        for name in ("radius_m", "mass_kg"):
            if np.any(getattr(self, name) <= 0):
                raise BadInput(f"{name} must be positive")
        width, length = self.mat.cols * self.mat.pitch_col_m, self.mat.rows * self.mat.pitch_row_m
        off = np.flatnonzero((self.center_xy_m[:, 0] < 0) | (self.center_xy_m[:, 0] > width)
                             | (self.center_xy_m[:, 1] < 0) | (self.center_xy_m[:, 1] > length))
        if off.size:
            raise BadInput(f"objects {off.tolist()[:10]} have centres off the mat (center_xy_m outside "
                           f"0..{width:.3f} m x 0..{length:.3f} m of the {self.mat.name} mat's sensing area)")
        if np.any(self.length_m < 2 * self.radius_m):
            raise BadInput("length_m must be at least 2 radius_m (a capsule's length includes its caps)")
        if np.any(self.pressure_mmhg < 0):
            raise BadInput("pressure_mmhg contains negative pressures")

    def __len__(self) -> int:
        return len(self.radius_m)


def save_measurements(path: str | Path, data: CapsuleMeasurements) -> None:
    """Write ``data`` as a calibration ``.npz`` (the format above)."""
    m = data.mat
    save_npz_atomic(
        Path(path), format=np.array(FORMAT), version=np.array(VERSION), mat_name=np.array(m.name),
        mat_shape=np.array(m.shape), mat_pitch_m=np.array([m.pitch_row_m, m.pitch_col_m]),
        max_mmhg=np.array(m.max_mmhg), radius_m=data.radius_m, length_m=data.length_m, mass_kg=data.mass_kg,
        center_xy_m=data.center_xy_m, yaw_rad=data.yaw_rad, pressure_mmhg=data.pressure_mmhg, sink_m=data.sink_m)


def load_measurements(path: str | Path) -> CapsuleMeasurements:
    """Read a calibration ``.npz``; BadInput naming what is missing or wrong."""
    p = Path(path)
    if not p.is_file():
        raise BadInput(f"calibration data {str(p)!r} does not exist")
    arrays = load_npz(p, "calibration data")
    need = ["format", "version", "mat_name", "mat_shape", "mat_pitch_m", "max_mmhg", "radius_m", "length_m",
            "mass_kg", "center_xy_m", "yaw_rad", "pressure_mmhg", "sink_m"]
    missing = [k for k in need if k not in arrays]
    if missing:
        raise BadInput(f"calibration data {str(p)!r} lacks {', '.join(missing)} (see docs/calibration.md)")
    version = arrays["version"]
    if (str(arrays["format"]) != FORMAT or version.shape != () or version.dtype.kind not in "iu"
            or int(version) != VERSION):
        raise BadInput(f"calibration data {str(p)!r} is format {str(arrays['format'])!r} version "
                       f"{version!r}; expected {FORMAT!r} version {VERSION}")
    shape, pitch, top = arrays["mat_shape"], arrays["mat_pitch_m"], arrays["max_mmhg"]
    for name, a, want in (("mat_shape", shape, (2,)), ("mat_pitch_m", pitch, (2,)), ("max_mmhg", top, ())):
        if a.shape != want or a.dtype.kind not in "iuf":
            raise BadInput(f"calibration data {str(p)!r}: {name} is {a!r}; expected "
                           f"{'two numbers (along, across the bed)' if want else 'one number'}")
    if shape.dtype.kind == "f" and not np.all(np.isfinite(shape) & (shape == np.round(shape))):
        raise BadInput(f"calibration data {str(p)!r}: mat_shape is {shape!r}; expected two whole numbers of taxels")
    mat = MatSpec(str(arrays["mat_name"]), int(shape[0]), int(shape[1]), float(pitch[0]), float(pitch[1]),
                  float(top))
    return CapsuleMeasurements(mat, *(arrays[k] for k in need[6:]))
