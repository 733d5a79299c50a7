"""How realistic simulated pressure images are: per-image statistics, their distributions, and
distances between simulated and real sets.

Every function works on pressure images ``(N, rows, cols)`` in mmHg (row 0 at the head end) with
the mat's geometry (:class:`~pressurepose.mat.MatSpec`); none needs joint labels, so real and
simulated images are measured by the same rule.

Per image (:func:`image_stats`):

* ``contact_taxels`` / ``contact_cm2``: taxels above ``contact_mmhg`` (5 mmHg), and their area;
* ``peak_mmhg``: the highest reading; ``mean_mmhg``: the mean over the contact taxels;
* ``head_imprint``: the head touches the mat (:func:`head_imprint`);
* ``share_<region>``: the share of the image's load (sum of all readings) in each body region along
  the bed (:data:`REGIONS`; :func:`region_shares`); they sum to 1;
* ``off_mat`` (simulated images only, given their force and the body's mass): ``1 - F / (m g)``,
  the share of the body's weight that does not rest on the sensing area.

Regions (the image-only rule, :class:`RegionRule`): the body's extent along the bed runs from the
first to the last row with contact near the body's axis (:func:`core_contact`: within 16 cm across
the bed of the line through the rows' load centroids, so raised hands and a limb flung out do not
count). Where the head leaves no imprint the first such row is the shoulders', so the head end is
then put one head length (``bounds[0]`` of the whole extent) above it. The extent is cut at fixed
fractions from the head end, taken from standard segment lengths as fractions of stature measured
from the vertex (Drillis and Contini's body-segment proportions: chin/neck 0.13, lower tip of the
shoulder blades 0.28, iliac crest 0.40, gluteal fold 0.53, knee joint 0.715, ankle 0.93). A supine
body's head-to-heel contact extent is its stature less a few centimetres, so these fractions apply
to it; for bodies on their side with bent knees they are a coarser guide. Contact cut off by the
mat's foot end shortens the extent (the real-data readers note that tall subjects' heels run off
the FSA mat); this rule does not correct for it.

Head imprint (:func:`head_imprint`), on the contact near the axis: in the top ``top_fraction`` of
the extent, the widest row span (first to last contact column) of the first ``narrow_rows`` rows is
less than ``narrow_ratio`` of the widest span below them (a head, ~15 cm across, lies above
shoulders ~40 cm across), or a row's span dips to at most ``dip_ratio`` of the widest above it
before the spans widen again (the neck's gap between a head and the shoulders, in any posture).
Where the head does not touch, the first contact rows are the shoulder blades': already wide,
widening downward. On simulated bodies the rule agrees with a joint-based test (contact within
10 cm of the head joint) on about 3 images in 4 (``benchmarks/bench_realism.py``); most
disagreements are bodies lying askew with a hand or arm beside the head.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput, require_non_negative, require_whole
from pressurepose.mat import MatSpec

GRAVITY = 9.81  # as pressurepose.sim.sensor
REGIONS = ("head", "shoulders", "back", "pelvis", "thighs", "calves", "heels")
POSTURE_GROUPS = {"supine": "supine", "left": "lateral", "right": "lateral", "lateral": "lateral",
                  "prone": "prone"}
SCALAR_STATS = ("contact_taxels", "contact_cm2", "peak_mmhg", "mean_mmhg")


@dataclass(frozen=True)
class RegionRule:
    """How images are measured (see the module docstring).

    contact_mmhg: a taxel above it is in contact. bounds: the 6 cuts between the 7 :data:`REGIONS`
    as fractions of the head-to-heel contact extent from the head end. top_fraction: the part of
    the extent searched for a head. narrow_rows: rows at the top measured for the narrow test.
    narrow_ratio, dip_ratio: the head tests' thresholds. core_half_width_m: the head test and the
    body's extent look only at contact within this distance across the bed of the image's load
    centroid (hands raised beside or above the head lie outside it).
    """

    contact_mmhg: float = 5.0
    bounds: tuple[float, ...] = (0.13, 0.28, 0.40, 0.53, 0.715, 0.93)
    top_fraction: float = 0.30
    narrow_rows: int = 3
    narrow_ratio: float = 0.5
    dip_ratio: float = 0.5
    core_half_width_m: float = 0.16

    def __post_init__(self):
        b = np.asarray(self.bounds, dtype=np.float64)
        if b.shape != (len(REGIONS) - 1,) or np.any(np.diff(b) <= 0) or b[0] <= 0 or b[-1] >= 1:
            raise BadInput(f"region bounds {self.bounds!r}: expected {len(REGIONS) - 1} increasing fractions in (0, 1)")
        require_non_negative("region contact_mmhg", self.contact_mmhg)
        if not 0 < self.top_fraction <= 1:
            raise BadInput(f"region top_fraction is {self.top_fraction!r}; expected a fraction in (0, 1]")
        require_whole("region narrow_rows", self.narrow_rows, 1)


DEFAULT_RULE = RegionRule()


def _images(images) -> np.ndarray:
    p = np.asarray(images, dtype=np.float64)
    if p.ndim == 2:
        p = p[None]
    if p.ndim != 3 or p.shape[0] == 0:
        raise BadInput(f"pressure images have shape {p.shape}; expected (N, rows, cols) mmHg")
    if not np.all(np.isfinite(p)) or np.any(p < 0):
        raise BadInput("pressure images must be finite and non-negative (mmHg)")
    return p


def contact_area(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE) -> tuple[np.ndarray, np.ndarray]:
    """(taxels (N,) int, area (N,) cm^2) above ``rule.contact_mmhg``."""
    p = _images(images)
    _check_mat(p, mat)
    n = (p > rule.contact_mmhg).sum((1, 2))
    return n, n * mat.taxel_area_m2 * 1e4


def row_spans(contact) -> np.ndarray:
    """(N, rows) per row of contact maps (N, rows, cols) bool, taxels from the first to the last
    contact column (0 without contact)."""
    on = np.asarray(contact, bool)
    cols = np.arange(on.shape[2])
    first = np.where(on, cols, on.shape[2]).min(2)
    last = np.where(on, cols, -1).max(2)
    return np.where(last >= first, last - first + 1, 0)


def core_contact(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE) -> np.ndarray:
    """(N, rows, cols) bool: contact within ``rule.core_half_width_m`` across the bed of each image's
    body axis (the line through the rows' load centroids, fitted by load-weighted least squares, so a
    body lying askew is followed; raised hands mostly fall outside)."""
    p = _images(images)
    _check_mat(p, mat)
    cols = np.arange(p.shape[2]) + 0.5
    rows = np.arange(p.shape[1]) + 0.5
    w = p.sum(2)                                               # (N, rows) load per row
    c = (p @ cols) / np.maximum(w, 1e-12)                      # (N, rows) centroid column per row
    sw = np.maximum(w.sum(1), 1e-12)
    rm, cm = (w @ rows) / sw, (w * c).sum(1) / sw
    var = (w * (rows - rm[:, None]) ** 2).sum(1)
    slope = np.where(var > 0, (w * (rows - rm[:, None]) * (c - cm[:, None])).sum(1) / np.maximum(var, 1e-12), 0.0)
    axis = cm[:, None] + slope[:, None] * (rows - rm[:, None])  # (N, rows) axis column per row
    near = np.abs(cols[None, None, :] - axis[:, :, None]) * mat.pitch_col_m <= rule.core_half_width_m
    return (p > rule.contact_mmhg) & near


def contact_rows(contact) -> np.ndarray:
    """(N, 2) int first and last row with contact of contact maps (N, rows, cols) bool; (-1, -1)
    for a map without contact."""
    any_row = np.asarray(contact, bool).any(2)
    rows = np.arange(any_row.shape[1])
    first = np.where(any_row, rows, any_row.shape[1]).min(1)
    last = np.where(any_row, rows, -1).max(1)
    return np.where((last >= 0)[:, None], np.stack([first, last], 1), -1)


def head_imprint(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE) -> np.ndarray:
    """(N,) bool: the head leaves an imprint (the module docstring's narrow-top or neck-dip test,
    on :func:`core_contact`)."""
    core = core_contact(images, mat, rule)
    spans = row_spans(core)
    ext = contact_rows(core)
    out = np.zeros(len(spans), bool)
    for i, (first, last) in enumerate(ext):
        if first < 0:
            continue
        top = spans[i, first:first + max(2, int(math.ceil(rule.top_fraction * (last - first + 1))))]
        if len(top) <= rule.narrow_rows:
            continue
        narrow = top[:rule.narrow_rows].max() < rule.narrow_ratio * top[rule.narrow_rows:].max()
        above = np.maximum.accumulate(top)
        dip = np.any((top[1:] <= rule.dip_ratio * above[:-1]) & (np.maximum.accumulate(top[::-1])[::-1][1:] >
                                                                 top[1:]))
        out[i] = narrow or dip
    return out


def body_extent(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE, head=None) -> np.ndarray:
    """(N, 2) head end and foot end of the body along the bed, in rows (continuous: row r spans
    [r, r + 1)), from the first and last row of :func:`core_contact`; NaN without contact. ``head``
    (N,) bool: :func:`head_imprint` (computed if None); where it is False the head end is moved one
    head length above the first contact row."""
    ext = contact_rows(core_contact(images, mat, rule)).astype(np.float64)
    head = head_imprint(images, mat, rule) if head is None else np.asarray(head, bool)
    start, end = ext[:, 0], ext[:, 1] + 1.0
    h = rule.bounds[0]
    start = np.where(head, start, start - h / (1 - h) * (end - start))
    out = np.stack([start, end], 1)
    out[ext[:, 0] < 0] = np.nan
    return out


def _statures(height_m, n: int) -> np.ndarray:
    """(n,) statures in metres; BadInput naming the field and the first bad value otherwise."""
    h = np.asarray(height_m, dtype=np.float64).reshape(-1)
    if h.shape != (n,):
        raise BadInput(f"height_m has shape {h.shape}; expected ({n},): one stature (m) per image")
    bad = ~(np.isfinite(h) & (h > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise BadInput(f"height_m of image {i} is {h[i]:g} ({int(bad.sum())} of {n} not a positive number); "
                       f"expected positive statures in metres")
    return h


def extent_ratio(images, mat: MatSpec, height_m, rule: RegionRule = DEFAULT_RULE, head=None) -> np.ndarray:
    """(N,) the body's contact extent along the bed (:func:`body_extent`, m) over its stature
    ``height_m`` (N,) m: about 0.95 for a body lying long, less for bent or drawn-up legs and for
    legs spread out of the axis's reach; NaN without contact."""
    ext = body_extent(images, mat, rule, head)
    h = _statures(height_m, len(ext))
    return (ext[:, 1] - ext[:, 0]) * mat.pitch_row_m / h


PROFILE_BAND = 0.05   # load_profile's bands, fraction of the stature
PROFILE_REACH = 0.70  # how far below the head end it reaches (the legs' load lies beyond)


def load_profile(images, mat: MatSpec, height_m, rule: RegionRule = DEFAULT_RULE, head=None,
                 band: float = PROFILE_BAND, reach: float = PROFILE_REACH) -> np.ndarray:
    """(N, B) percent of each image's load in bands of ``band`` x its stature ``height_m`` (N,) m
    below the head end of its extent (:func:`body_extent`), out to ``reach`` x the stature (B =
    round(reach / band); load beyond it is not counted; NaN rows for images without contact).
    Unlike the region shares it does not scale with the extent, so it says where along the body
    the load lies however the legs lie (a side-lying shoulder's load, for one)."""
    p = _images(images)
    _check_mat(p, mat)
    h = _statures(height_m, len(p))
    if not (0 < band < reach <= 1.5):
        raise BadInput(f"profile band {band!r} and reach {reach!r}: expected 0 < band < reach <= 1.5")
    edges = np.linspace(0.0, band * round(reach / band), round(reach / band) + 1)
    ext = body_extent(p, mat, rule, head)
    load = p.sum(2)  # (N, rows)
    total = load.sum(1, keepdims=True)
    ok = np.isfinite(ext[:, 0]) & (total[:, 0] > 0)
    below = ((np.arange(p.shape[1]) + 0.5)[None] - ext[:, :1]) * mat.pitch_row_m / h[:, None]  # (N, rows)
    nbins = len(edges) - 1
    k = np.searchsorted(edges, below, side="right") - 1  # the band of each row, as np.histogram bins it
    k[below == edges[-1]] = nbins - 1  # histogram's last band is closed on the right
    inside = ok[:, None] & (k >= 0) & (k < nbins)
    out = np.zeros((len(p), nbins))
    share = np.divide(load, total, out=np.zeros_like(load), where=total > 0)
    np.add.at(out, (np.nonzero(inside)[0], k[inside]), share[inside])
    out *= 100
    out[~ok] = np.nan
    return out


MATCH_BINS = np.arange(0.5, 1.15, 0.05)  # extent ratio bins (open at both ends) for match_by


def match_by(sim_values, real_values, seed: int = 0, bins=MATCH_BINS,
             draws: int | None = None) -> tuple[np.ndarray, float]:
    """Indices into ``sim_values`` (N,) of a resample whose histogram over ``bins`` (edges; values
    beyond them fall in the end bins) follows ``real_values``' (M,): each bin gets a share of
    ``draws`` (default: as many as there are finite simulated values) equal to its share of the real
    values, drawn with replacement from the simulated values in it (seeded). More draws than values
    make a mean over the resample depend less on the draw. Returns (indices, coverage): coverage is
    the share of the real values whose bin holds any simulated value (the rest are not
    represented). NaNs are left out of both."""
    s, r = np.asarray(sim_values, float).reshape(-1), np.asarray(real_values, float).reshape(-1)
    s_ok, r = np.flatnonzero(np.isfinite(s)), r[np.isfinite(r)]
    if not len(s_ok) or not len(r):
        raise BadInput("matching needs finite values in both sets")
    edges = np.asarray(bins, float)
    sb, rb = np.digitize(s[s_ok], edges), np.digitize(r, edges)
    rng = np.random.default_rng(seed)
    want = np.bincount(rb, minlength=len(edges) + 1) / len(r)
    have = np.bincount(sb, minlength=len(edges) + 1)
    covered = want * (have > 0)
    coverage = float(covered.sum())
    if coverage == 0:
        raise BadInput("no simulated image falls in a bin that holds a real one; nothing to match")
    n = len(s_ok) if draws is None else int(draws)
    if n < 1:
        raise BadInput(f"draws is {draws}; expected at least 1")
    quota = n * covered / coverage  # largest remainders: the counts sum to n
    counts = np.floor(quota).astype(int)
    counts[np.argsort(counts - quota)[: n - counts.sum()]] += 1
    idx = [rng.choice(s_ok[sb == b], size=c, replace=True) for b, c in enumerate(counts) if c > 0]
    return np.sort(np.concatenate(idx)), coverage


def region_shares(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE, head=None) -> np.ndarray:
    """(N, 7) share of each image's load (sum of readings) in each of :data:`REGIONS`; rows sum to 1
    (NaN for an image without contact). A row's load is split between regions by how much of the
    row each covers; load outside the body's extent counts to the nearest end region."""
    p = _images(images)
    row_load = p.sum(2)
    ext = body_extent(p, mat, rule, head)
    out = np.full((len(p), len(REGIONS)), np.nan)
    for i, e in enumerate(ext):
        if not np.isfinite(e[0]) or row_load[i].sum() <= 0:
            continue
        out[i] = row_load[i] @ _region_cover(e, p.shape[1], rule) / row_load[i].sum()
    return out


def _region_cover(ext_row: np.ndarray, rows: int, rule: RegionRule) -> np.ndarray:
    """(rows, 7) how much of each image row falls in each region, for an extent (first, last) in rows."""
    a, b = ext_row
    cuts = np.concatenate([[-np.inf], rule.bounds, [np.inf]])
    f = (np.arange(rows + 1, dtype=np.float64) - a) / (b - a)  # row edges as fractions of the extent
    lo, hi = f[:-1], f[1:]
    cover = np.clip(np.minimum(hi[:, None], cuts[None, 1:]) - np.maximum(lo[:, None], cuts[None, :-1]), 0, None)
    return cover / (hi - lo)[:, None]


def region_contact(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE, head=None) -> np.ndarray:
    """(N, 7, 2) per image and region of :data:`REGIONS`: contact taxels (readings over
    ``rule.contact_mmhg``; a row split between regions as in :func:`region_shares`) and the mean
    reading over them, mmHg (NaN where a region has no contact). Where region shares differ, this
    says whether a region touches over too little area or presses too hard."""
    p = _images(images)
    on = p > rule.contact_mmhg
    count, load = on.sum(2).astype(np.float64), (p * on).sum(2)
    ext = body_extent(p, mat, rule, head)
    out = np.full((len(p), len(REGIONS), 2), np.nan)
    for i, e in enumerate(ext):
        if not np.isfinite(e[0]) or count[i].sum() <= 0:
            continue
        cover = _region_cover(e, p.shape[1], rule)
        taxels = count[i] @ cover
        out[i, :, 0] = taxels
        with np.errstate(invalid="ignore", divide="ignore"):
            out[i, :, 1] = np.where(taxels > 0, (load[i] @ cover) / taxels, np.nan)
    return out


def image_stats(images, mat: MatSpec, rule: RegionRule = DEFAULT_RULE, *, force_n=None, mass_kg=None) -> dict:
    """Per-image statistics {name: (N,) array} (see the module docstring). ``force_n`` (N, rows,
    cols) and ``mass_kg`` (N,) add ``off_mat``."""
    p = _images(images)
    _check_mat(p, mat)
    taxels, cm2 = contact_area(p, mat, rule)
    on = p > rule.contact_mmhg
    head = head_imprint(p, mat, rule)
    shares = region_shares(p, mat, rule, head)
    with np.errstate(invalid="ignore"):
        mean = np.where(taxels > 0, (p * on).sum((1, 2)) / np.maximum(taxels, 1), np.nan)
    out = {"contact_taxels": taxels.astype(np.float64), "contact_cm2": cm2, "peak_mmhg": p.max((1, 2)),
           "mean_mmhg": mean, "head_imprint": head}
    out.update({f"share_{r}": shares[:, k] for k, r in enumerate(REGIONS)})
    if force_n is not None and mass_kg is not None:
        f = np.asarray(force_n, dtype=np.float64).reshape(len(p), -1).sum(1)
        m = np.asarray(mass_kg, dtype=np.float64).reshape(-1)
        if m.shape != (len(p),):
            raise BadInput(f"mass_kg has shape {m.shape}; expected ({len(p)},)")
        out["off_mat"] = 1.0 - f / (m * GRAVITY)
    return out


def select(stats: dict, keep) -> dict:
    """The statistics of the images where ``keep`` (N,) is True."""
    return {k: np.asarray(v)[keep] for k, v in stats.items()}


# the statistics the realism report's headline compares, and how each is taken over images
HEADLINE_STATS: dict[str, str] = {"contact_taxels": "median", "head_imprint": "rate", "mean_mmhg": "median",
                                  "peak_mmhg": "median", **{f"share_{r}": "mean" for r in REGIONS}}


def real_intervals(stats: dict, cluster=None, n_boot: int = 1000, level: float = 0.9, seed: int = 0) -> dict:
    """How far the real people's headline statistics move when other people like them are drawn:
    {statistic: [low, high]}, the percentile interval at ``level`` of each :data:`HEADLINE_STATS`
    statistic (the median, rate or mean over images, as the report takes it) over ``n_boot``
    resamples of the images (``cluster`` (N,): of the people, each person's images together).
    A simulated statistic inside this interval cannot be told from the real one with this many
    people. ``stats``: :func:`image_stats` of the real images (NaN entries left out)."""
    values = {k: np.asarray(stats[k], float) for k in HEADLINE_STATS}
    n = len(values["head_imprint"])
    c = _cluster_labels(cluster, n)
    if c.shape != (n,) or not 0 < level < 1 or n_boot < 10:
        raise BadInput("cluster must have one label per image, level lie in (0, 1) and n_boot be at least 10")
    if not n:
        raise BadInput("no real images to resample")
    members = _members(c)
    rng = np.random.default_rng(seed)
    draws = {k: np.empty(n_boot) for k in HEADLINE_STATS}
    for b in range(n_boot):
        idx = _draw_people(rng, members)
        for k, how in HEADLINE_STATS.items():
            v = values[k][idx]
            v = v[np.isfinite(v)]
            draws[k][b] = np.nan if not v.size else (np.median(v) if how == "median" else v.mean())
    q = [100 * (1 - level) / 2, 100 * (1 + level) / 2]
    return {k: [float(x) for x in np.nanpercentile(v, q)] if np.isfinite(v).any() else None
            for k, v in draws.items()}


def summarise(stats: dict) -> dict:
    """Distribution summaries: for each numeric statistic {n, median, q1, q3, mean}; for
    ``head_imprint`` {n, rate}. NaNs (images without contact) are left out."""
    out = {}
    for k, v in stats.items():
        v = np.asarray(v)
        if k == "head_imprint":
            out[k] = {"n": int(v.size), "rate": float(v.mean()) if v.size else None}
            continue
        v = v[np.isfinite(v)].astype(np.float64)
        if v.size == 0:
            out[k] = {"n": 0, "median": None, "q1": None, "q3": None, "mean": None}
            continue
        q1, med, q3 = np.percentile(v, [25, 50, 75])
        out[k] = {"n": int(v.size), "median": float(med), "q1": float(q1), "q3": float(q3), "mean": float(v.mean())}
    return out


def ks_statistic(a, b) -> float:
    """Two-sample Kolmogorov-Smirnov statistic: the largest gap between the empirical CDFs."""
    a, b = np.sort(np.asarray(a, float)), np.sort(np.asarray(b, float))
    x = np.concatenate([a, b])
    return float(np.max(np.abs(np.searchsorted(a, x, "right") / len(a) - np.searchsorted(b, x, "right") / len(b))))


def wasserstein(a, b) -> float:
    """Earth mover's (Wasserstein-1) distance between two samples, in their unit."""
    a, b = np.sort(np.asarray(a, float)), np.sort(np.asarray(b, float))
    x = np.sort(np.concatenate([a, b]))
    dx = np.diff(x)
    ca = np.searchsorted(a, x[:-1], "right") / len(a)
    cb = np.searchsorted(b, x[:-1], "right") / len(b)
    return float(np.sum(np.abs(ca - cb) * dx))


def compare(sim: dict, real: dict) -> dict:
    """Distances between simulated and real per-image statistics (both as :func:`image_stats`).

    Per numeric statistic: ``median_ratio`` (simulated median / real median), ``ks`` and
    ``wasserstein``; for region shares also ``mean_diff_pp``, the difference of the mean shares in
    percentage points; for ``head_imprint`` ``rate_diff`` (simulated - real rate).
    """
    out = {}
    for k in real:
        if k not in sim or k == "off_mat":
            continue
        s, r = np.asarray(sim[k]), np.asarray(real[k])
        if k == "head_imprint":
            if s.size and r.size:
                out[k] = {"rate_diff": float(s.mean() - r.mean())}
            continue
        s, r = s[np.isfinite(s)].astype(float), r[np.isfinite(r)].astype(float)
        if s.size == 0 or r.size == 0:
            continue
        rm = float(np.median(r))
        d = {"median_ratio": float(np.median(s) / rm) if rm else None, "ks": ks_statistic(s, r),
             "wasserstein": wasserstein(s, r)}
        if k.startswith("share_"):
            d["mean_diff_pp"] = float(100 * (s.mean() - r.mean()))
        out[k] = d
    return out


def _cluster_labels(cluster, n: int) -> np.ndarray:
    """Whole-number labels of each image's person (``cluster`` (n,), any labels), or each image its
    own (None)."""
    if cluster is None:
        return np.arange(n)
    return np.unique(np.asarray(cluster).astype(str), return_inverse=True)[1].reshape(-1)


def _members(labels: np.ndarray) -> list[np.ndarray]:
    """The image indices of each label's person."""
    return [np.flatnonzero(labels == k) for k in np.unique(labels)]


def _draw_people(rng: np.random.Generator, members: list[np.ndarray]) -> np.ndarray:
    """Image indices of as many people drawn with replacement as there are, each with all their images."""
    return np.concatenate([members[k] for k in rng.integers(0, len(members), len(members))])


def share_gap_interval(sim_shares, real_shares, real_cluster=None, sim_weight=None, n_boot: int = 1000,
                       level: float = 0.9, seed: int = 0) -> dict:
    """Bootstrap intervals of the simulated-minus-real mean region shares, percentage points.

    sim_shares (n, R) and real_shares (m, R): per-image shares (NaN rows, images without contact,
    are left out). ``real_cluster`` (m,): images of one person move together (a person's postures
    are not independent draws), else each image is its own; ``sim_weight`` (n,): how often each
    simulated image counts (a matched resample's multiplicities), resampled as distinct images.
    Returns {'regions': (R, 2) [low, high] of each region's gap, 'worst': [low, high] of the largest
    absolute gap, 'level', 'n_boot', 'by': 'cluster' | 'image'}; percentile intervals, seeded."""
    s, r = np.asarray(sim_shares, float), np.asarray(real_shares, float)
    if s.ndim != 2 or r.ndim != 2 or s.shape[1] != r.shape[1]:
        raise BadInput(f"shares of shape {s.shape} and {r.shape}; expected (n, R) and (m, R)")
    w = np.ones(len(s)) if sim_weight is None else np.asarray(sim_weight, float).reshape(-1)
    c = _cluster_labels(real_cluster, len(r))
    if w.shape != (len(s),) or c.shape != (len(r),) or not 0 < level < 1 or n_boot < 10:
        raise BadInput("sim_weight must have one weight per simulated image, real_cluster one label per real "
                       "image, level lie in (0, 1) and n_boot be at least 10")
    ks, kr = np.all(np.isfinite(s), 1) & (w > 0), np.all(np.isfinite(r), 1)
    s, w, r, c = s[ks], w[ks], r[kr], c[kr]
    if not len(s) or not len(r):
        raise BadInput("no simulated or no real image with contact to compare shares of")
    members = _members(c)
    rng = np.random.default_rng(seed)
    gaps = np.empty((n_boot, s.shape[1]))
    for b in range(n_boot):
        i = rng.integers(0, len(s), len(s))
        sim_mean = (w[i] @ s[i]) / w[i].sum()
        gaps[b] = 100 * (sim_mean - r[_draw_people(rng, members)].mean(0))
    q = [100 * (1 - level) / 2, 100 * (1 + level) / 2]
    return {"regions": np.percentile(gaps, q, axis=0).T.tolist(),
            "worst": np.percentile(np.abs(gaps).max(1), q).tolist(), "level": level, "n_boot": n_boot,
            "by": "cluster" if real_cluster is not None else "image"}


def posture_group(labels) -> np.ndarray:
    """(N,) 'supine', 'lateral', 'prone' or '' (not compared) of posture labels (supine, left,
    right, lateral, prone, others)."""
    return np.array([POSTURE_GROUPS.get(str(x), "") for x in np.asarray(labels).reshape(-1)], dtype=object).astype(str)


def _check_mat(p: np.ndarray, mat: MatSpec) -> None:
    if not isinstance(mat, MatSpec):
        raise BadInput(f"mat is {type(mat).__name__}; expected a MatSpec")
    if p.shape[1:] != mat.shape:
        raise BadInput(f"pressure images are {p.shape[1]} x {p.shape[2]}; the {mat.name} mat is "
                       f"{mat.rows} x {mat.cols}")
