"""Two fixed pressure images (64 x 27, mmHg) from a closed formula: body-like blobs (head, trunk,
two legs), the second a mirrored, shifted copy. Used to check that PressureNet's estimates stay
the same through speed changes (``data/golden_estimate.npz``)."""

import numpy as np


def _blob(y, x, cy, cx, sy, sx, peak):
    return peak * np.exp(-0.5 * (((y - cy) / sy) ** 2 + ((x - cx) / sx) ** 2))


def fixed_images() -> np.ndarray:
    """(2, 64, 27) float32 pressure images."""
    y, x = np.mgrid[0:64, 0:27].astype(np.float64)
    img = (_blob(y, x, 5, 13, 2.5, 2.5, 45) + _blob(y, x, 20, 13, 7, 4.5, 35) + _blob(y, x, 30, 13, 3, 5, 60)
           + _blob(y, x, 45, 10.5, 8, 1.8, 30) + _blob(y, x, 45, 15.5, 8, 1.8, 30)
           + _blob(y, x, 60, 10, 1.5, 1.5, 40) + _blob(y, x, 60, 16, 1.5, 1.5, 40))
    img = np.where(img > 2.0, img, 0.0)
    other = np.roll(img[:, ::-1], (2, 1), axis=(0, 1))
    return np.stack([img, other]).astype(np.float32)
