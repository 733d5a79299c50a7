"""The settle bed's foundation modulus (paper appendix A.5): the stiffness at which body-part capsules
sink into the settle's cells as deep as the bed's press model says they sink, and a cache that keeps
it on disk.

* :data:`BODY_PART_CAPSULES` (:class:`CapsuleObjects`): the objects of the fit.
* :func:`settle_sink_fn`: their sinks on a config's cell bed as a function of the modulus.
* :func:`calibrate_stiffness`: the fit (about 1.5-4 s).
* :func:`settle_stiffness`: the fit, computed once and read back from :func:`cache_dir` under
  :func:`stiffness_cache_key` afterwards.

The fit itself (:func:`~pressurepose.sim.stiffness.fit_settle_stiffness`) and the press model's
objects (:func:`~pressurepose.sim.stiffness.press_objects`) are in :mod:`pressurepose.sim.stiffness`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np

from pressurepose.sim.bed import BedSpec, get_bed
from pressurepose.sim.cellbed import capsule_sinks
from pressurepose.sim.settle_config import SettleConfig
from pressurepose.sim.settle_model import settle_cells

CACHE_ENV = "PRESSUREPOSE_CACHE_DIR"


@dataclass(frozen=True)
class CapsuleObjects:
    """Rigid capsules lying on the bed, in :class:`~pressurepose.calibrate.measurements.CapsuleMeasurements`'
    terms: radius_m, length_m (end to end, caps included), mass_kg (J,); center_xy_m (J, 2); yaw_rad (J,)."""

    radius_m: tuple[float, ...]
    length_m: tuple[float, ...]
    mass_kg: tuple[float, ...]
    center_xy_m: tuple[tuple[float, float], ...]
    yaw_rad: tuple[float, ...]


# Body-part-like capsules of an average body (trunk, thigh, calf, upper arm, head), spread over the bed
# at assorted angles so that the fit does not hinge on how one object lines up with the cells.
BODY_PART_CAPSULES = CapsuleObjects(
    radius_m=(0.10, 0.07, 0.05, 0.045, 0.09), length_m=(0.50, 0.49, 0.45, 0.34, 0.28),
    mass_kg=(25.0, 8.0, 3.0, 2.0, 5.0),
    center_xy_m=((0.38, 0.90), (0.30, 1.20), (0.50, 0.60), (0.20, 0.40), (0.40, 1.50)),
    yaw_rad=(0.0, 1.57, 0.3, 0.8, 0.0))


def settle_sink_fn(objects, bed: BedSpec, config: SettleConfig | None = None):
    """``k -> sinks (J,)`` m of the capsules ``objects`` (a :class:`CapsuleObjects` or measurements) on
    ``config``'s cell bed with foundation modulus k (N/m^3): the ``sink_fn`` of
    :func:`pressurepose.sim.stiffness.fit_settle_stiffness` (appendix A.5). The cell size matters: a
    coarse cell is pressed as deep as the deepest point above it, so coarse grids need a softer k."""
    config = SettleConfig() if config is None else config
    o = objects

    def sink_fn(k: float) -> np.ndarray:
        return capsule_sinks(settle_cells(bed, config, k), o.radius_m, o.length_m, o.mass_kg, o.center_xy_m,
                             o.yaw_rad)

    return sink_fn


def calibrate_stiffness(bed: BedSpec | None = None, config: SettleConfig | None = None,
                        objects: CapsuleObjects = BODY_PART_CAPSULES):
    """Appendix A.5 without real measurements: the settle bed's modulus at which ``objects`` sink as
    deep as the (calibrated) press model of ``bed`` says they sink. Returns a
    :class:`~pressurepose.sim.stiffness.SettleStiffness`; use ``SettleConfig(stiffness_n_m3=...)``.
    About 15 s on one core."""
    from pressurepose.sim.press import body_heightfield
    from pressurepose.sim.stiffness import (
        capsule_mesh,
        fit_settle_stiffness,
        press_objects,
    )

    bed = get_bed() if bed is None else bed
    o = objects
    fields = [body_heightfield(*capsule_mesh(r, L, xy, yaw), bed)
              for r, L, xy, yaw in zip(o.radius_m, o.length_m, o.center_xy_m, o.yaw_rad)]
    _, press_sinks = press_objects(bed, fields, o.mass_kg)
    k = bed.stiffness_n_m3
    return fit_settle_stiffness(press_sinks, settle_sink_fn(o, bed, config), bounds=(k / 10, k * 10), xtol=2e-3)


def cache_dir() -> Path | None:
    """Where computed set-up (the settle stiffness) is kept between runs: ``$PRESSUREPOSE_CACHE_DIR``
    (empty: no cache), else ``$XDG_CACHE_HOME/pressurepose``, else ``~/.cache/pressurepose``."""
    if CACHE_ENV in os.environ:
        value = os.environ[CACHE_ENV].strip()
        return Path(value).expanduser() if value else None
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "pressurepose"


@lru_cache(maxsize=1)
def _source_digest() -> str:
    """sha256 of the simulation package's source: any change to the bed, the press or the fit
    invalidates cached fits."""
    h = hashlib.sha256()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def stiffness_cache_key(bed: BedSpec, config: SettleConfig) -> str:
    """Key of a fitted settle stiffness: everything it depends on (the bed, the config, the source of
    :mod:`pressurepose.sim` and the versions of the libraries that compute it)."""
    import scipy

    from pressurepose import __version__

    text = json.dumps({"bed": repr(bed), "config": repr(dataclasses.replace(config, stiffness_n_m3=None)),
                       "source": _source_digest(), "pressurepose": __version__, "mujoco": mujoco.__version__,
                       "numpy": np.__version__, "scipy": scipy.__version__}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def settle_stiffness(bed: BedSpec, config: SettleConfig) -> float:
    """The foundation modulus (N/m^3) the settle model uses for ``bed`` and ``config``:
    :func:`calibrate_stiffness`'s fit (about 1.5-4 s), computed once and kept in :func:`cache_dir`
    under :func:`stiffness_cache_key`, so worker processes and later runs read it instead. A missing,
    unreadable or unwritable cache only costs the fit."""
    from pressurepose.files import write_json_atomic

    key = stiffness_cache_key(bed, config)
    root = cache_dir()
    path = None if root is None else root / f"settle-stiffness-{key[:32]}.json"
    if path is not None:
        try:
            cached = json.loads(path.read_text())
            k = float(cached["stiffness_n_m3"])
            if cached.get("key") == key and math.isfinite(k) and k > 0:
                return k
        except (OSError, ValueError, KeyError, TypeError):
            pass
    k = float(calibrate_stiffness(bed, config).stiffness)
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_json_atomic(path, {"key": key, "stiffness_n_m3": k})
        except OSError:
            pass
    return k
