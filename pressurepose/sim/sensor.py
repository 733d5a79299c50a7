"""The pressure sensor: taxel forces to readings in mmHg.

The paper (section 3.1) models a taxel's output as ``u = C2 |x|^2 + C1 |x| + C0`` of the
compression ``x`` of the mat's top layer. For a thin elastic layer the compression is proportional
to the pressure on it, so the same law is written here in the taxel's mean contact pressure
``x = force / taxel area`` (in mmHg): it keeps the constants identifiable (a layer stiffness
would only rescale C1 and C2) and gives them plain meaning: C1 = 1, C0 = C2 = 0 is an ideal
sensor. Taxels that carry no load read 0; readings are clipped to ``[0, mat.max_mmhg]``, and
readings below the bed's ``sensor_threshold_mmhg`` read 0.
"""

from __future__ import annotations

import numpy as np

from pressurepose.errors import BadInput

MMHG_PA = 133.322  # pascals per mmHg
GRAVITY = 9.81

__all__ = ["MMHG_PA", "read_sensor", "sensor_law", "force_to_mmhg"]


def sensor_law(x_mmhg: np.ndarray, c0: float, c1: float, c2: float, max_mmhg: float) -> np.ndarray:
    """``clip(c2 x^2 + c1 x + c0, 0, max_mmhg)`` where ``x > 0``, else 0 (x in mmHg)."""
    x = np.asarray(x_mmhg, dtype=np.float64)
    u = (c2 * x + c1) * x + c0
    return np.where(x > 0, np.clip(u, 0.0, max_mmhg), 0.0)


def read_sensor(force_n, bed) -> np.ndarray:
    """Readings (mmHg) of the mat of ``bed`` (a BedSpec) for taxel forces ``force_n`` (rows, cols) N."""
    f = np.asarray(force_n, dtype=np.float64)
    if f.shape != bed.mat.shape:
        raise BadInput(f"force has shape {f.shape}; the {bed.mat.name} mat is {bed.mat.rows} x {bed.mat.cols}")
    if not np.all(np.isfinite(f)) or f.min(initial=0.0) < 0:
        raise BadInput("taxel forces must be finite and non-negative newtons")
    x = f / bed.mat.taxel_area_m2 / MMHG_PA
    u = sensor_law(x, bed.sensor_c0, bed.sensor_c1, bed.sensor_c2, bed.mat.max_mmhg)
    return np.where(u >= bed.sensor_threshold_mmhg, u, 0.0)


def force_to_mmhg(image, mass_kg: float, taxel_area_m2: float) -> np.ndarray:
    """Rescale any pressure image so that it carries the body's weight, in mmHg.

    ``p_mmHg = p * (m g) / (sum(p) * A_taxel) / 133.322`` (the conversion BodyPressure and BodyMAP
    use to put mats of unknown calibration on one scale). image (..., rows, cols) >= 0 in any unit;
    batches are normalised image by image. An all-zero image stays zero.
    """
    p = np.asarray(image, dtype=np.float64)
    if p.ndim < 2:
        raise BadInput(f"image has shape {p.shape}; expected (..., rows, cols)")
    if not np.all(np.isfinite(p)) or p.min(initial=0.0) < 0:
        raise BadInput("image must be finite and non-negative")
    m = np.asarray(mass_kg, dtype=np.float64)
    if not np.all(np.isfinite(m)) or np.any(m <= 0):
        raise BadInput(f"mass_kg is {mass_kg!r}; expected positive kilograms")
    if not np.isfinite(taxel_area_m2) or taxel_area_m2 <= 0:
        raise BadInput(f"taxel_area_m2 is {taxel_area_m2!r}; expected a positive area in m^2")
    total = p.sum(axis=(-2, -1), keepdims=True)
    m = m.reshape(m.shape + (1, 1)) if m.ndim else m
    scale = np.divide(m * GRAVITY, total * taxel_area_m2, out=np.zeros_like(total), where=total > 0)
    return p * scale / MMHG_PA
