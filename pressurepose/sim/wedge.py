"""A foam positioning wedge behind a half-turned body: its shape, its place, and its load on the mat.

Nurses prop a patient turned 30-60 degrees toward a side with a foam wedge behind the back (PMD
experiment I records such postures: "right 30 deg (wedge)" and so on). The wedge is a right
triangular prism lying along the body: its base on the mattress, its inclined face under the back,
its vertical back face away from the body. Geometry, bed frame (z up, the unloaded mattress top at
z = 0), all in metres:

* ``toe`` (3,): the middle of the line where the inclined face meets the mattress;
* ``axis`` (3,): horizontal unit vector along the wedge's length; ``rise`` (3,): horizontal unit
  vector across it, from the toe toward the high back face;
* ``angle_rad``: the face's inclination; ``height_m``: the back face's height (the base is
  ``height / tan(angle)`` wide); ``length_m``; ``mass_kg``.

In the settle (:mod:`pressurepose.sim.settle`) the wedge is a rigid box whose top face is the
inclined face, fixed in place (a foam wedge pressed down by a leaning back does not slide on a
sheet), touching the body only. Where the face lies is taken from the body's start pose
(:func:`wedge_behind`): tangent to the back of the trunk's capsules, inclined as the trunk is rolled.

On the mat (:func:`wedge_load`) the wedge presses with its own weight and passes down the
vertical part of the body's load on its face. Positioning wedges are firm foam, much stiffer than
a mattress, so its base is taken as a rigid footing on the mattress: the pressure under it is
linear across and along the base, with the force and moment of the loads it carries (the
classic result for a rigid footing on an elastic foundation). The body presses the mattress
beside the wedge as before (:func:`pressurepose.sim.press.press`), less the load the wedge carries:
:func:`relieved_body` gives the mass and centre of mass that the mattress alone must balance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput
from pressurepose.pose import partitions
from pressurepose.sim.foundation import PressFailed
from pressurepose.sim.sensor import GRAVITY

FOAM_DENSITY = 30.0    # kg/m^3: polyurethane positioning foam (about 25-40)
MIN_HEIGHT_M = 0.18    # a positioning wedge's back face (wedges are sold about 15-30 cm high)
OVER_CONTACT_M = 0.08  # the back face rises this far above the highest point the trunk may lean on
TOE_BELOW_M = 0.1      # the box realising the face runs on below the toe, into the mattress
LEAN_RAD = 0.0         # the face is this much flatter than the trunk is rolled (the body leans back onto it)
BOX_HALF_THICKNESS_M = 0.05
# a Wedge as one row of numbers (Wedge.as_array, Wedge.from_array)
FIELDS = ("toe_x", "toe_y", "toe_z", "axis_x", "axis_y", "axis_z", "rise_x", "rise_y", "rise_z",
          "angle_rad", "height_m", "length_m", "mass_kg")


def constants() -> dict:
    """The module's constants that shape every wedge (for a dataset's provenance)."""
    return {"foam_density_kg_m3": FOAM_DENSITY, "min_height_m": MIN_HEIGHT_M, "over_contact_m": OVER_CONTACT_M,
            "length_m": partitions.WEDGE_LENGTH_M, "toe_below_m": TOE_BELOW_M,
            "box_half_thickness_m": BOX_HALF_THICKNESS_M, "lean_rad": LEAN_RAD,
            "trunk": list(partitions.WEDGE_TRUNK)}


@dataclass(frozen=True, eq=False)
class Wedge:
    """A wedge on the bed; see the module docstring for the geometry."""

    toe: np.ndarray
    axis: np.ndarray
    rise: np.ndarray
    angle_rad: float
    height_m: float
    length_m: float
    mass_kg: float

    @property
    def base_width_m(self) -> float:
        return self.height_m / math.tan(self.angle_rad)

    @property
    def normal(self) -> np.ndarray:
        """(3,) unit normal of the inclined face, pointing out of the wedge (toward the body)."""
        return np.array([0.0, 0.0, 1.0]) * math.cos(self.angle_rad) - self.rise * math.sin(self.angle_rad)

    def as_array(self) -> np.ndarray:
        """(13,) the wedge as numbers, in :data:`FIELDS` order."""
        return np.concatenate([self.toe, self.axis, self.rise,
                               [self.angle_rad, self.height_m, self.length_m, self.mass_kg]])

    @staticmethod
    def from_array(row) -> "Wedge | None":
        """The wedge of a :meth:`as_array` row, or None for a row that is not one (e.g. all NaN)."""
        r = np.asarray(row, dtype=np.float64)
        if r.shape != (len(FIELDS),) or not np.all(np.isfinite(r)):
            return None
        return Wedge(r[0:3], r[3:6], r[6:9], float(r[9]), float(r[10]), float(r[11]), float(r[12]))

    def moved(self, transform: np.ndarray) -> "Wedge":
        """The wedge after a rigid motion (4, 4) of the bed frame that keeps z up (a shift and a yaw)."""
        R, t = transform[:3, :3], transform[:3, 3]
        return Wedge(R @ self.toe + t, R @ self.axis, R @ self.rise, self.angle_rad, self.height_m,
                     self.length_m, self.mass_kg)

    def box(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rigid box whose top face is the inclined face (extended TOE_BELOW_M down past the
        toe): (half sizes (3,), centre (3,), rotation (3, 3) whose columns are the box's axes)."""
        up = np.array([0.0, 0.0, 1.0])
        along_face = self.rise * math.cos(self.angle_rad) + up * math.sin(self.angle_rad)
        n = self.normal
        axis = self.axis if np.cross(along_face, self.axis) @ n > 0 else -self.axis
        lo = -TOE_BELOW_M / math.sin(self.angle_rad)
        hi = self.height_m / math.sin(self.angle_rad)
        half = np.array([(hi - lo) / 2, self.length_m / 2, BOX_HALF_THICKNESS_M])
        centre = self.toe + along_face * (lo + hi) / 2 - n * BOX_HALF_THICKNESS_M
        return half, centre, np.stack([along_face, axis, n], axis=1)


def wedge_behind(capsule_ends: np.ndarray, radius: np.ndarray, root_rotation: np.ndarray) -> Wedge:
    """The wedge that props a half-turned body: its face tangent to the back of the trunk's
    capsules (``partitions.WEDGE_TRUNK``), inclined as the trunk is rolled (less ``LEAN_RAD``),
    running ``partitions.WEDGE_LENGTH_M`` from the top of the trunk toward the feet.

    capsule_ends (20, 2, 3) and radius (20,): the ragdoll's capsules (bed frame,
    :data:`pressurepose.body.capsules.CAPSULE_NAMES` order) where the body starts;
    root_rotation (3, 3): the root body's world rotation (its rest body faces -y, head +z).
    """
    from pressurepose.body.capsules import CAPSULE_NAMES

    ends = np.asarray(capsule_ends, dtype=np.float64)
    W = np.asarray(root_rotation, dtype=np.float64)
    if ends.shape != (len(CAPSULE_NAMES), 2, 3) or W.shape != (3, 3):
        raise BadInput(f"capsule ends {ends.shape} / rotation {W.shape}; expected (20, 2, 3) and (3, 3)")
    head = W[:, 2].copy()
    head[2] = 0.0
    if np.linalg.norm(head) < 0.5:
        raise BadInput("the body's long axis is not level enough to prop it with a wedge")
    axis = head / np.linalg.norm(head)
    n = -W[:, 1]                          # the body's front: the face pushes the back forward
    n = n - (n @ axis) * axis
    n /= np.linalg.norm(n)
    angle = math.acos(float(np.clip(n[2], -1.0, 1.0)))
    if not math.radians(10) <= angle <= math.radians(80):
        raise BadInput(f"a wedge props bodies rolled 10-80 deg; this one is rolled {math.degrees(angle):.0f} deg")
    rise = -n.copy()
    rise[2] = 0.0
    rise /= np.linalg.norm(rise)
    if LEAN_RAD > 0:  # a flatter face, touching the trunk where it first meets it
        angle = max(math.radians(10), angle - LEAN_RAD)
        n = np.array([0.0, 0.0, math.cos(angle)]) - rise * math.sin(angle)
    k = [CAPSULE_NAMES.index(c) for c in partitions.WEDGE_TRUNK]
    pts, r = ends[k].reshape(-1, 3), np.repeat(np.asarray(radius, dtype=np.float64)[k], 2)
    offset = pts @ n - r
    d = float(offset.min())               # the face: n . x = d, touching the trunk's back
    touch = pts[int(np.argmin(offset))] - r[int(np.argmin(offset))] * n
    centre = pts.mean(0)
    base = np.array([centre[0], centre[1], 0.0])
    toe = base + (d - base @ n) / (rise @ n) * rise
    along = pts @ axis
    mid = float(along.max()) - partitions.WEDGE_LENGTH_M / 2
    toe = toe + (mid - toe @ axis) * axis
    height = max(MIN_HEIGHT_M, float(touch[2]) + OVER_CONTACT_M)
    base_width = height / math.tan(angle)
    mass = FOAM_DENSITY * 0.5 * base_width * height * partitions.WEDGE_LENGTH_M
    return Wedge(toe, axis, rise, angle, height, partitions.WEDGE_LENGTH_M, mass)


def wedge_load(wedge: Wedge, points, force_z, xs, ys) -> np.ndarray:
    """(len(ys), len(xs)) newtons the wedge puts on each cell of a bed-frame grid with cell centres
    ``xs`` (nx,), ``ys`` (ny,): its base on the mattress as a rigid footing on an elastic
    (Winkler) foundation. The wedge's weight and the vertical loads ``force_z`` (K,) N (>= 0,
    downward on the wedge) acting on its face at ``points`` (K, 3) add up to a resultant F at
    (e_u, e_v) from the base's centre (along, across); the footing then presses
    ``F / A (1 + 12 e_u u / L^2 + 12 e_v v / b^2)`` at (u, v) (the linear pressure under a rigid
    footing that balances force and moment), clipped at zero where the resultant lies outside
    the base's middle third and scaled back to F. Cells are counted by their centres; the result
    sums to F when the base covers at least one cell (else zeros)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(force_z, dtype=np.float64).reshape(-1)
    if len(p) != len(f) or not (np.all(np.isfinite(p)) and np.all(np.isfinite(f))) or np.any(f < 0):
        raise BadInput(f"wedge loads: {len(p)} points and {len(f)} forces; expected as many finite forces >= 0 N")
    X, Y = np.meshgrid(np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))
    L, b = wedge.length_m, wedge.base_width_m
    u = (X - wedge.toe[0]) * wedge.axis[0] + (Y - wedge.toe[1]) * wedge.axis[1]
    v = (X - wedge.toe[0]) * wedge.rise[0] + (Y - wedge.toe[1]) * wedge.rise[1] - b / 2
    on_base = (np.abs(u) <= L / 2) & (np.abs(v) <= b / 2)
    out = np.zeros(X.shape)
    if not on_base.any():
        return out
    weight = GRAVITY * wedge.mass_kg
    rel = p[:, :2] - wedge.toe[:2]
    pu, pv = rel @ wedge.axis[:2], rel @ wedge.rise[:2] - b / 2
    total = weight + f.sum()
    # the wedge's own weight acts at its centroid, a third of the base from the high back face
    eu, ev = (f @ pu) / total, (f @ pv + weight * b / 6) / total
    q = np.clip(1.0 + 12.0 * eu * u / L**2 + 12.0 * ev * v / b**2, 0.0, None) * on_base
    if q.sum() <= 0:
        q = on_base.astype(np.float64)
    return total * q / q.sum()


def relieved_body(mass_kg: float, com_xy, points, force_z) -> tuple[float, np.ndarray]:
    """(mass kg, centre of mass (2,)) of the load the mattress must carry when the wedge holds the
    vertical forces ``force_z`` (K,) N at ``points`` (K, 3) of a body of ``mass_kg`` whose centre of
    mass is at ``com_xy``: the same total force and moments about the bed's horizontal axes.
    Raises :class:`~pressurepose.sim.foundation.PressFailed` when the wedge holds over 95 % of the body."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(force_z, dtype=np.float64).reshape(-1)
    w = GRAVITY * float(mass_kg) - float(f.sum())
    if w <= 0.05 * GRAVITY * mass_kg:
        raise PressFailed(f"the wedge holds {f.sum():.0f} N of a {GRAVITY * mass_kg:.0f} N body; "
                          "the mattress carries almost nothing")
    c = (GRAVITY * mass_kg * np.asarray(com_xy, dtype=np.float64) - f @ p[:, :2]) / w
    return w / GRAVITY, c


def with_wedge(result, wedge: Wedge, points, force_z, bed):
    """A :class:`~pressurepose.sim.press.PressResult` of the body beside the wedge, with the
    wedge's load (:func:`wedge_load`) added to the mat's forces and read again through the sensor.
    ``bed_force`` then sums to the body's and the wedge's weight; depth and contact stay the body's."""
    import dataclasses

    from pressurepose.sim.press import press_grid
    from pressurepose.sim.sensor import read_sensor

    grid = press_grid(bed)
    xs, ys = grid.centers()
    bed_force = result.bed_force + grid.per_taxel(wedge_load(wedge, points, force_z, xs, ys))
    force = bed_force[bed.full_grid.sensing_slice].copy()
    return dataclasses.replace(result, bed_force=bed_force, force=force, pressure=read_sensor(force, bed))
