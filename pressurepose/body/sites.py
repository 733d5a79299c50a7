"""Body sites where pressure injuries form, and the pressure each carries on a mat.

The sites are the bony prominences a clinician checks (NPIAP / EPUAP pressure-injury guideline):
lying supine the occiput, scapulae, elbows, sacrum and heels; on the side the ear, shoulder,
greater trochanter, knee and ankle (malleolus) of the side lain on. :data:`SITES` names them;
``other`` is the rest of the body.

Every vertex of a body model gets one site (:func:`vertex_sites`), from the model's own arrays, so
the shipped open models and SMPL-format files (any topology) both work. The rules work on the mean
shape at rest (SMPL's y-up model frame: +y toward the head, +z forward, +x the body's left), with
each vertex's *region* the joint with the largest skinning weight, and lengths scaled by the rest
height over 1.65 m (``s``). In order, the first rule that holds wins:

===================== =====================================================================
site                  rule
===================== =====================================================================
``head``              region head or neck, above the neck joint less 2 s cm (occiput; the ear on the side)
``left_heel``         region ankle or foot, more than 2 s cm below the ankle along the leg and
                      behind a plane 3 s cm in front of the ankle joint (back and bottom of the heel)
``left_ankle``        region knee, ankle or foot within 5 s cm of the ankle along the leg (the malleoli)
``left_knee``         region hip or knee within 7 s cm of the knee along the leg
``left_elbow``        region shoulder, elbow or wrist within 7 s cm of the elbow along the arm
``left_trochanter``   region pelvis, spine1 or hip, from 12 s cm below to 6 s cm above the hip
                      joints, in the outer half between the hip joint and the side of the body
``sacrum``            region pelvis, spine1, spine2 or hip, from 15 s cm below the hip joints
                      to 8 s cm above spine1, behind the pelvis joint, between the hip joints
                      (the sacrum and the inner buttocks, which carry the pelvis lying on the back)
``left_shoulder``     within 11 s cm of the shoulder joint, outside it (|x| >= the joint's)
``scapulae``          region spine2, spine3, collar or shoulder, from 12 s cm below spine3 to
                      4 s cm above the shoulders, behind spine3, between the shoulder joints
``other``             everything else (mid back, thighs, calves, arms, hands, front of the body)
===================== =====================================================================

(right sites mirror the left ones). The site maps of the shipped models are drawn in
``docs/monitoring.md``.

:func:`taxel_sites` gives each loaded taxel of a pressure image the site of the body lying on it,
once the body is moved by whole taxels onto the image's print (:func:`fit_offset`): of the vertex
of the lowest triangle over the taxel's centre nearest that centre, else of the nearest such
vertex; and :func:`site_loads` the peak and mean pressure, contact area and share of the load of
each site; :func:`vertex_pressure` puts the pressure on the (moved) body's surface. Pure numpy over
arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.body.joints import JOINT_NAMES
from pressurepose.body.mesh import lower_surface, mesh_volume
from pressurepose.errors import BadInput, require_non_negative
from pressurepose.mat import MatSpec

SITES: tuple[str, ...] = (
    "head", "scapulae", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "sacrum",
    "left_trochanter", "right_trochanter", "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_heel", "right_heel", "other",
)
OTHER = SITES.index("other")
NO_SITE = -1  # a taxel nothing is assigned to: no load on it
# sites that carry the load lying on the back and lying on the side (NPIAP / EPUAP guideline)
SUPINE_SITES: tuple[str, ...] = ("head", "scapulae", "left_elbow", "right_elbow", "sacrum", "left_heel", "right_heel")
LATERAL_SITES: tuple[str, ...] = ("head", "left_shoulder", "right_shoulder", "left_trochanter", "right_trochanter",
                                  "left_knee", "right_knee", "left_ankle", "right_ankle")
SITE_RULE_HEIGHT_M = 1.65  # the site rules' lengths are for a body this tall; other heights scale them


def site_label(name: str) -> str:
    """A site's name for people: 'left_heel' -> 'left heel', 'left_trochanter' -> 'left hip
    (trochanter)', 'other' -> 'rest of the body'."""
    if name == "other":
        return "rest of the body"
    if name.endswith("trochanter"):
        return name.replace("trochanter", "hip (trochanter)").replace("_", " ")
    return name.replace("_", " ")


def site_index(name: str) -> int:
    """Index into :data:`SITES` of a site name; BadInput naming the known ones."""
    try:
        return SITES.index(name)
    except ValueError:
        raise BadInput(f"unknown body site {name!r}; expected one of {', '.join(SITES)}") from None


def vertex_sites(model) -> np.ndarray:
    """(V,) int8 index into :data:`SITES` of every vertex of a body model (a
    :class:`~pressurepose.body.BodyModel`, :class:`SmplArrays` or the torch
    :class:`~pressurepose.body.lbs_torch.BodyLayer`), by the rules of the module doc."""
    arrays = getattr(model, "arrays", model)
    try:
        v, weights, jreg = (np.asarray(_numpy(getattr(arrays, k)), dtype=np.float64)
                            for k in ("v_template", "weights", "J_regressor"))
    except AttributeError:
        raise BadInput(f"model is {type(model).__name__}; expected a BodyModel, SmplArrays or BodyLayer") from None
    if jreg.shape[0] != len(JOINT_NAMES) or weights.shape != (len(v), len(JOINT_NAMES)):
        raise BadInput(f"the body model has {jreg.shape[0]} joints; body sites need SMPL's {len(JOINT_NAMES)}")
    J = jreg @ v  # the rest joints of the mean shape
    region = np.argmax(weights, axis=1)
    s = (v[:, 1].max() - v[:, 1].min()) / SITE_RULE_HEIGHT_M
    j = {n: J[i] for i, n in enumerate(JOINT_NAMES)}
    ji = {n: i for i, n in enumerate(JOINT_NAMES)}
    out = np.full(len(v), -1, dtype=np.int64)

    def regions(*names):
        return np.isin(region, [ji[n] for n in names])

    def claim(name, mask):
        free = (out < 0) & mask
        out[free] = SITES.index(name)

    def along(a, b, p):
        """Signed distance (V,) of the vertices from point p along the unit direction a -> b."""
        u = (b - a) / np.linalg.norm(b - a)
        return (v - p) @ u

    claim("head", regions("head", "neck") & (v[:, 1] > j["neck"][1] - 0.02 * s))
    for side in ("left", "right"):
        knee, ankle, hip = j[f"{side}_knee"], j[f"{side}_ankle"], j[f"{side}_hip"]
        down = along(knee, ankle, ankle)  # + below the ankle along the shin
        claim(f"{side}_heel", regions(f"{side}_ankle", f"{side}_foot") & (down > 0.02 * s)
              & (v[:, 2] < ankle[2] + 0.03 * s))
        claim(f"{side}_ankle", regions(f"{side}_knee", f"{side}_ankle", f"{side}_foot") & (np.abs(down) < 0.05 * s))
        claim(f"{side}_knee", regions(f"{side}_hip", f"{side}_knee") & (np.abs(along(hip, ankle, knee)) < 0.07 * s))
        shoulder, elbow, wrist = j[f"{side}_shoulder"], j[f"{side}_elbow"], j[f"{side}_wrist"]
        claim(f"{side}_elbow", regions(f"{side}_shoulder", f"{side}_elbow", f"{side}_wrist")
              & (np.abs(along(shoulder, wrist, elbow)) < 0.07 * s))
    hip_y = 0.5 * (j["left_hip"][1] + j["right_hip"][1])
    hips = regions("pelvis", "spine1", "left_hip", "right_hip")
    band = hips & (v[:, 1] > hip_y - 0.12 * s) & (v[:, 1] < hip_y + 0.06 * s)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        inner = sign * j[f"{side}_hip"][0]
        outer = (sign * v[band, 0]).max() if band.any() else inner
        claim(f"{side}_trochanter", band & (sign * v[:, 0] > inner + 0.5 * (outer - inner)))
    claim("sacrum", regions("pelvis", "spine1", "spine2", "left_hip", "right_hip") & (v[:, 1] > hip_y - 0.15 * s)
          & (v[:, 1] < j["spine1"][1] + 0.08 * s) & (v[:, 2] < j["pelvis"][2])
          & (np.abs(v[:, 0]) < 0.5 * abs(j["left_hip"][0] - j["right_hip"][0])))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        shoulder = j[f"{side}_shoulder"]
        claim(f"{side}_shoulder", (np.linalg.norm(v - shoulder, axis=1) < 0.11 * s)
              & (sign * v[:, 0] >= sign * shoulder[0]))
    shoulder_y = 0.5 * (j["left_shoulder"][1] + j["right_shoulder"][1])
    half = 0.5 * abs(j["left_shoulder"][0] - j["right_shoulder"][0])
    claim("scapulae", regions("spine2", "spine3", "left_collar", "right_collar", "left_shoulder", "right_shoulder")
          & (v[:, 1] > j["spine3"][1] - 0.12 * s) & (v[:, 1] < shoulder_y + 0.04 * s)
          & (v[:, 2] < j["spine3"][2]) & (np.abs(v[:, 0]) < half))
    out[out < 0] = OTHER
    return out.astype(np.int8)


def _numpy(x):
    return x.detach().cpu().numpy() if hasattr(x, "detach") else x


# ---------------------------------------------------------------------------------------- taxels
def _check_images(pressure, what: str = "pressure") -> np.ndarray:
    p = np.asarray(pressure, dtype=np.float64)
    if p.ndim == 2:
        p = p[None]
    if p.ndim != 3 or not np.all(np.isfinite(p)):
        raise BadInput(f"{what} has shape {np.shape(pressure)}; expected finite (B, R, C) or (R, C) mmHg")
    return p


def taxel_sites(pressure, vertices, faces, vertex_site, mat: MatSpec, min_mmhg: float = 0.0) -> np.ndarray:
    """(B, R, C) int8 site (index into :data:`SITES`) of every loaded taxel, ``NO_SITE`` (-1) elsewhere.

    pressure (B, R, C) mmHg on ``mat``; vertices (B, V, 3) the bodies lying on it (bed frame, m:
    taxel (r, c) covers x in [c, c+1) pitch_col_m, y in [r, r+1) pitch_row_m) and faces (F, 3)
    their triangles; vertex_site (V,) from :func:`vertex_sites` (or (B, V), one per body). A taxel
    is loaded when it reads more than ``min_mmhg``; it takes its site in :func:`body_site_map`
    (each body first moved onto its image: :func:`fit_offset`, which counts the same taxels as loaded).
    """
    p, verts, tris, vsite = _check_inputs(pressure, vertices, faces, vertex_site, mat)
    return np.where(p > min_mmhg, body_site_map(verts, tris, vsite, mat, p, min_mmhg), NO_SITE).astype(np.int8)


def body_site_map(vertices, faces, vertex_site, mat: MatSpec, pressure=None, min_mmhg: float = 0.0) -> np.ndarray:
    """(B, R, C) int8: the site of the body over every taxel of ``mat``, loaded or not: the site of
    the vertex nearest the taxel's centre of the lowest triangle over that centre (the skin that
    lies on the mat there); where no triangle lies over the centre, the site of the nearest (in
    x, y) of those vertices. ``NO_SITE`` only for a body nowhere over the mat. vertices (B, V, 3) bed
    frame, m; faces (F, 3); vertex_site (V,) from :func:`vertex_sites`, or (B, V) one per body
    (bodies of different models with one topology). ``pressure`` (B, R, C) mmHg, the images the
    bodies were read from: each body is first moved onto its image (:func:`fit_offset`, a taxel
    loaded when it reads more than ``min_mmhg``); None: the bodies as they are."""
    verts = np.asarray(vertices, dtype=np.float64)
    verts = verts[None] if verts.ndim == 2 else verts
    tris = np.asarray(faces, dtype=np.int64)
    vsite = np.broadcast_to(np.asarray(vertex_site, dtype=np.int64), verts.shape[:2])
    closed = _closed(tris)
    p = None if pressure is None else _check_images(pressure)
    if p is not None and p.shape != (len(verts), *mat.shape):
        raise BadInput(f"pressure has shape {p.shape}; expected ({len(verts)}, {mat.rows}, {mat.cols}), one image "
                       f"per body")
    out = []
    for b in range(len(verts)):
        v, skin = (verts[b], _skin(verts[b], tris, mat, closed)) if p is None else \
            _aligned(p[b], verts[b], tris, mat, closed, min_mmhg)
        out.append(_site_map(v, vsite[b], skin, mat))
    return np.stack(out).reshape(len(verts), *mat.shape)


# how far (m) an estimated body may be moved across the mat onto its image: the shipped model's
# bodies lie 3-4 cm (one SD, in x and in y) from the simulated truth (benchmarks/bench_sites.py)
OFFSET_REACH_M = 0.03


def fit_offset(pressure, heights, mat: MatSpec, reach_m: float = OFFSET_REACH_M,
               min_mmhg: float = 0.0) -> tuple[int, int]:
    """(rows, cols): the whole-taxel move of a body across ``mat``, at most ``reach_m`` each way
    (at least one taxel), that best explains one pressure image (R, C) mmHg by the body's lower
    surface ``heights`` (R, C) m over the taxel centres (+inf where no body).

    A body pressed into a bed of springs loads each taxel in proportion to how far its skin there
    is below a common level; the level is set so that as many taxels are loaded as the image has
    (readings above ``min_mmhg``; those at or below it count as 0, as in :func:`taxel_sites`),
    and the move whose loads correlate best with the image wins ((0, 0) on a tie, an empty image or
    a body nowhere over the mat). Moving the estimated body onto its image's print before its skin
    is read off gives each loaded taxel the site of the body part that made it, not of its
    neighbour. On 400 held-out simulated images (benchmarks/bench_sites.py's 100 of seed 1420, and
    300 more of seeds 2101-2103, 5 per gender of each partition) it brings the per-site share error
    from 1.80 and 1.74 pp to 1.70 and 1.70 pp; the most loaded site is named right in 85 % and 86 %
    of images (80 % and 86 % without it). Finer moves (a third or a fifth of a taxel), a longer
    reach, a turn or roll of the body, or a move per patch of the print named the most loaded site
    at most about a point more often, within the noise (docs/not-adopted.md, "Reading body sites")."""
    if not isinstance(mat, MatSpec):
        raise BadInput(f"mat is {type(mat).__name__}; expected a pressurepose.mat.MatSpec")
    p = np.asarray(pressure, dtype=np.float64)
    h = np.asarray(heights, dtype=np.float64)
    if p.shape != mat.shape or not np.all(np.isfinite(p)):
        raise BadInput(f"pressure has shape {p.shape}; expected one finite ({mat.rows}, {mat.cols}) image in mmHg")
    if h.shape != mat.shape or np.isnan(h).any():
        raise BadInput(f"heights has shape {h.shape}; expected ({mat.rows}, {mat.cols}) metres over the taxel "
                       f"centres (+inf where no body), no NaN")
    require_non_negative("reach_m (metres)", reach_m)
    require_non_negative("min_mmhg", min_mmhg)
    p = np.where(p > min_mmhg, p, 0.0)
    n = int((p > 0).sum())
    if not n or not np.isfinite(h).any():
        return 0, 0
    reach = (max(1, round(reach_m / mat.pitch_row_m)), max(1, round(reach_m / mat.pitch_col_m)))
    best, score = (0, 0), -np.inf
    flat = p.ravel() - p.mean()
    for dr, dc in sorted(((r, c) for r in range(-reach[0], reach[0] + 1) for c in range(-reach[1], reach[1] + 1)),
                         key=lambda m: abs(m[0]) + abs(m[1])):
        moved = _moved(h, dr, dc, np.inf)
        seen = np.sort(moved[np.isfinite(moved)])
        if not len(seen):
            continue
        sink = np.maximum(seen[min(n, len(seen)) - 1] - moved, 0.0)
        sink[~np.isfinite(sink)] = 0.0
        sink = sink.ravel() - sink.mean()
        norm = np.linalg.norm(sink)
        s = float(flat @ sink / norm) if norm > 0 else -np.inf
        if s > score and (score == -np.inf or s - score > 1e-9 * abs(score)):  # a tie keeps the smaller move
            best, score = (dr, dc), s
    return best


def _moved(a: np.ndarray, dr: int, dc: int, fill) -> np.ndarray:
    """(R, C) map ``a`` moved by dr rows and dc columns, ``fill`` where it moved from beyond the mat."""
    out = np.full_like(a, fill)
    R, C = a.shape
    out[max(dr, 0):R + min(dr, 0), max(dc, 0):C + min(dc, 0)] = a[max(-dr, 0):R + min(-dr, 0), max(-dc, 0):C + min(-dc, 0)]
    return out


def _aligned(p: np.ndarray, verts: np.ndarray, tris: np.ndarray, mat: MatSpec, closed: bool, min_mmhg: float = 0.0,
             ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """One body (V, 3) and its :func:`_skin`, moved by whole taxels onto its image p (R, C)
    (:func:`fit_offset`, loaded above ``min_mmhg``)."""
    heights, nearest = _skin(verts, tris, mat, closed)
    dr, dc = fit_offset(p, heights.reshape(mat.shape), mat, min_mmhg=min_mmhg)
    if (dr, dc) == (0, 0):
        return verts, (heights, nearest)
    return (verts + [dc * mat.pitch_col_m, dr * mat.pitch_row_m, 0.0],
            (_moved(heights.reshape(mat.shape), dr, dc, np.inf).ravel(),
             _moved(nearest.reshape(mat.shape), dr, dc, -1).ravel()))


def _site_map(verts: np.ndarray, vsite: np.ndarray, skin, mat: MatSpec) -> np.ndarray:
    """(R * C,) int8 site map of one body (V, 3) with sites (V,) from its :func:`_skin`."""
    from scipy.spatial import cKDTree

    nearest = skin[1]
    out = np.full(mat.rows * mat.cols, NO_SITE, dtype=np.int8)
    on = np.flatnonzero(nearest >= 0)
    if not len(on):
        return out
    out[on] = vsite[nearest[on]]
    missing = np.flatnonzero(nearest < 0)
    if len(missing):
        _, k = cKDTree(verts[nearest[on], :2]).query(_centres(mat)[missing])
        out[missing] = vsite[nearest[on][k]]
    return out


def _centres(mat: MatSpec) -> np.ndarray:
    """(R * C, 2) bed-frame x, y of the taxel centres, row-major."""
    return np.stack(np.meshgrid((np.arange(mat.cols) + 0.5) * mat.pitch_col_m,
                                (np.arange(mat.rows) + 0.5) * mat.pitch_row_m), -1).reshape(-1, 2)


def _closed(faces: np.ndarray) -> bool:
    """Whether triangles (F, 3) close a surface: every edge is shared by exactly two of them."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    return bool(len(faces)) and bool(np.all(count == 2))


def _skin(vertices: np.ndarray, faces: np.ndarray, mat: MatSpec, closed: bool = False,
          ) -> tuple[np.ndarray, np.ndarray]:
    """One body's lower surface over the taxel centres of ``mat``, row-major: heights (R * C,) m
    (+inf where no triangle) and the vertex of the lowest triangle nearest each centre (R * C,)
    (-1 where none). Of a ``closed`` mesh only the triangles facing down can be lowest: the others
    are left out (half the work)."""
    down = faces
    if closed:
        e1, e2 = vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]]
        normal_z = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        down = faces[normal_z * np.sign(float(mesh_volume(vertices[None], faces)[0])) < 0]
    heights, nearest = lower_surface(vertices, down, (0.0, 0.0), (mat.pitch_col_m, mat.pitch_row_m), mat.shape,
                                     return_vertex=True)
    return heights.ravel(), nearest.ravel()


def lowest_vertices(vertices: np.ndarray, mat: MatSpec) -> tuple[np.ndarray, np.ndarray]:
    """The lowest vertex over each taxel a vertex of ``vertices`` (V, 3) lies over: (flat taxel
    indices r * C + c (K,), vertex indices (K,)), one per covered taxel."""
    row = np.floor(vertices[:, 1] / mat.pitch_row_m).astype(np.int64)
    col = np.floor(vertices[:, 0] / mat.pitch_col_m).astype(np.int64)
    inside = np.flatnonzero((row >= 0) & (row < mat.rows) & (col >= 0) & (col < mat.cols))
    flat = row[inside] * mat.cols + col[inside]
    order = np.lexsort((vertices[inside, 2], flat))
    flat, idx = flat[order], inside[order]
    first = np.r_[True, flat[1:] != flat[:-1]]
    return flat[first], idx[first]


def _check_inputs(pressure, vertices, faces, vertex_site, mat):
    if not isinstance(mat, MatSpec):
        raise BadInput(f"mat is {type(mat).__name__}; expected a pressurepose.mat.MatSpec")
    p = _check_images(pressure)
    if p.shape[1:] != mat.shape:
        raise BadInput(f"pressure has shape {p.shape[1:]} per image; the mat {mat.name} is {mat.rows} x {mat.cols}")
    verts = np.asarray(vertices, dtype=np.float64)
    if verts.ndim == 2:
        verts = verts[None]
    if verts.ndim != 3 or verts.shape[-1] != 3 or len(verts) != len(p) or not np.all(np.isfinite(verts)):
        raise BadInput(f"vertices has shape {np.shape(vertices)}; expected finite ({len(p)}, V, 3) metres, one "
                       f"body per pressure image")
    tris = np.asarray(faces)
    if tris.ndim != 2 or tris.shape[1] != 3 or tris.dtype.kind not in "iu" or (
            tris.size and (tris.min() < 0 or tris.max() >= verts.shape[1])):
        raise BadInput(f"faces has shape {tris.shape} and dtype {tris.dtype}; expected (F, 3) vertex indices "
                       f"below {verts.shape[1]}")
    vsite = np.asarray(vertex_site)
    if vsite.shape not in ((verts.shape[1],), verts.shape[:2]) or vsite.dtype.kind not in "iu" or (
            vsite.size and (vsite.min() < 0 or vsite.max() >= len(SITES))):
        raise BadInput(f"vertex_site has shape {vsite.shape} and dtype {vsite.dtype}; expected ({verts.shape[1]},) "
                       f"or ({len(verts)}, {verts.shape[1]}) indices into SITES")
    return p, verts, tris.astype(np.int64), vsite.astype(np.int64)


# ---------------------------------------------------------------------------------------- loads
@dataclass(frozen=True)
class SiteLoads:
    """Per-site load of B pressure images, each array (B, S) over :data:`SITES`.

    peak_mmhg, mean_mmhg: highest and mean reading of the site's loaded taxels (0 without any);
    area_cm2: their area; share: the site's part of the image's total load (sum of pressure x area,
    i.e. force), summing to 1 over the sites of an image with any load (0 for an empty image);
    taxel_site (B, R, C) int8: each taxel's site (``NO_SITE`` where unloaded).
    """

    peak_mmhg: np.ndarray
    mean_mmhg: np.ndarray
    area_cm2: np.ndarray
    share: np.ndarray
    taxel_site: np.ndarray

    def __len__(self) -> int:
        return int(self.share.shape[0])

    def most_loaded(self, named: bool = False) -> list[str]:
        """The site carrying the largest share of each image ('' for an empty image); with ``named``
        the named body site carrying the most, 'other' (the rest of the body) left out ('' when only
        'other' carries load)."""
        share = np.where(np.arange(len(SITES)) == OTHER, 0.0, self.share) if named else self.share
        return [SITES[int(np.argmax(s))] if s.max() > 0 else "" for s in share]

    def to_records(self) -> list[dict]:
        """One JSON-ready dict per image: {site: {peak_mmhg, mean_mmhg, area_cm2, share}} for every site."""
        return [{name: {"peak_mmhg": round(float(self.peak_mmhg[b, k]), 3),
                        "mean_mmhg": round(float(self.mean_mmhg[b, k]), 3),
                        "area_cm2": round(float(self.area_cm2[b, k]), 3),
                        "share": round(float(self.share[b, k]), 5)} for k, name in enumerate(SITES)}
                for b in range(len(self))]


def site_stats(pressure, taxel_site, mat: MatSpec) -> SiteLoads:
    """Per-site load of pressure images (B, R, C) mmHg on ``mat`` whose taxels carry the sites
    ``taxel_site`` (B, R, C) (indices into :data:`SITES`; ``NO_SITE`` for unloaded taxels, whose
    readings are left out)."""
    if not isinstance(mat, MatSpec):
        raise BadInput(f"mat is {type(mat).__name__}; expected a pressurepose.mat.MatSpec")
    p = _check_images(pressure)
    t = np.asarray(taxel_site)
    if t.ndim == 2:
        t = t[None]
    if t.shape != p.shape or p.shape[1:] != mat.shape or t.dtype.kind not in "iu":
        raise BadInput(f"pressure {p.shape} and taxel_site {np.shape(taxel_site)} must be integer sites and readings "
                       f"of one shape (B, {mat.rows}, {mat.cols})")
    if t.size and (t.min() < NO_SITE or t.max() >= len(SITES)):
        raise BadInput(f"taxel_site holds {t.min()}..{t.max()}; expected -1 (no site) or indices into SITES")
    B, S = len(p), len(SITES)
    on = t >= 0
    img = np.broadcast_to(np.arange(B)[:, None, None], t.shape)[on]
    key = img * S + t[on].astype(np.int64)
    vals = p[on]
    count = np.bincount(key, minlength=B * S).reshape(B, S)
    total = np.bincount(key, weights=vals, minlength=B * S).reshape(B, S)
    peak = np.zeros(B * S)
    np.maximum.at(peak, key, vals)
    whole = total.sum(1, keepdims=True)
    return SiteLoads(peak_mmhg=peak.reshape(B, S), mean_mmhg=np.where(count > 0, total / np.maximum(count, 1), 0.0),
                     area_cm2=count * mat.taxel_area_m2 * 1e4,
                     share=np.where(whole > 0, total / np.where(whole > 0, whole, 1.0), 0.0),
                     taxel_site=t.astype(np.int8))


def site_loads(pressure, vertices, faces, vertex_site, mat: MatSpec, min_mmhg: float = 0.0) -> SiteLoads:
    """Per-site load of pressure images (B, R, C) mmHg under bodies ``vertices`` (B, V, 3) with
    triangles ``faces`` (F, 3) and sites ``vertex_site`` (V,) or (B, V): :func:`taxel_sites` then
    :func:`site_stats`."""
    return site_stats(pressure, taxel_sites(pressure, vertices, faces, vertex_site, mat, min_mmhg), mat)


def vertex_pressure(pressure, vertices, faces, mat: MatSpec, reach_m: float = 0.02) -> np.ndarray:
    """(B, V) mmHg on the body's surface: each vertex reads the taxel under it when it lies within
    ``reach_m`` of the body's lower surface over that taxel (the skin on the mat: the lowest
    triangle over the taxel's centre, or its lowest vertex), else 0; vertices beyond the mat read 0.
    Each body is first moved onto its image (:func:`fit_offset`).
    pressure (B, R, C) mmHg; vertices (B, V, 3) bed frame, m; faces (F, 3)."""
    p, verts, tris, _ = _check_inputs(pressure, vertices, faces, np.zeros(np.shape(vertices)[-2], np.int64), mat)
    closed = _closed(tris)
    return np.stack([_vertex_pressure(p[b], *_aligned(p[b], verts[b], tris, mat, closed), mat, reach_m)
                     for b in range(len(p))])


def _vertex_pressure(p: np.ndarray, verts: np.ndarray, skin, mat: MatSpec, reach_m: float) -> np.ndarray:
    """(V,) mmHg on one body's surface (:func:`vertex_pressure`) from its :func:`_skin`."""
    row = np.floor(verts[:, 1] / mat.pitch_row_m).astype(np.int64)
    col = np.floor(verts[:, 0] / mat.pitch_col_m).astype(np.int64)
    inside = (row >= 0) & (row < mat.rows) & (col >= 0) & (col < mat.cols)
    flat = np.where(inside, row * mat.cols + col, 0)
    floor = skin[0].copy()
    cell, low = lowest_vertices(verts, mat)
    floor[cell] = np.minimum(floor[cell], verts[low, 2])
    near = inside & (verts[:, 2] <= floor[flat] + reach_m)
    out = np.zeros(len(verts))
    out[near] = p.ravel()[flat[near]]
    return out


def body_loads(pressure, vertices, faces, vertex_site, mat: MatSpec, min_mmhg: float = 0.0,
               reach_m: float = 0.02) -> tuple[SiteLoads, np.ndarray]:
    """:func:`site_loads` and :func:`vertex_pressure` together, each body's lower surface found once."""
    p, verts, tris, vsite = _check_inputs(pressure, vertices, faces, vertex_site, mat)
    vsite = np.broadcast_to(vsite, verts.shape[:2])
    taxel, on_skin, closed = np.empty(p.shape, np.int8), np.zeros(verts.shape[:2]), _closed(tris)
    for b in range(len(p)):
        v, skin = _aligned(p[b], verts[b], tris, mat, closed, min_mmhg)
        taxel[b] = np.where(p[b] > min_mmhg, _site_map(v, vsite[b], skin, mat).reshape(mat.shape), NO_SITE)
        on_skin[b] = _vertex_pressure(p[b], v, skin, mat, reach_m)
    return site_stats(p, taxel, mat), on_skin
