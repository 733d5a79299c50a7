"""A night on the mat: posture, turns and the load on each body site over time, with alerts.

A recording is T pressure frames (T, R, C) mmHg on a model's mat at times (T,) s. :func:`monitor`
reads it with PressureNet: a frame is estimated only when its load has changed by more than
``change`` (relative L1: sum |p - p_ref| / max(sum p, sum p_ref)) since the last estimated frame;
the frames between share that frame's body. Every frame's own readings are then split over the
body sites of that frame's site map (:func:`pressurepose.body.sites.body_site_map`, its loaded
taxels read again by a site network as ``estimate()`` reads them, by default the one shipped
for the mat: :mod:`pressurepose.net.sitenet`), so per-site pressure follows every frame while the networks run
only when the person moves. The rest are pure functions over arrays:

* posture: each body's roll (:func:`pressurepose.pose.posture.roll_angle`) gives its class,
  'supine', 'left' / 'right' (the side lain on) or 'prone'; a frame with fewer than
  ``min_contact_taxels`` taxels over ``contact_mmhg`` is 'empty' (nobody on the mat), and a frame
  whose image does not look like a person lying on the mat (:mod:`pressurepose.net.plausibility`:
  a person sitting, an object, sensor noise) is 'unclear': the network's body means nothing there.
  A posture held for less than ``min_posture_s`` is a movement, not a posture: it joins the
  posture before it. A turn is a change between two lying postures (an 'empty' or 'unclear' spell
  between them is passed over).
* per site and frame: peak, mean and share of the load (:func:`pressurepose.body.sites.site_stats`).
* time above the threshold per site (default 32 mmHg, the capillary closing pressure most cited in
  the pressure-injury literature: Landis, Heart 15:209, 1930), its longest stretch, and an alert
  for each stretch longer than the repositioning interval (default 2 hours, the common
  repositioning schedule), for every named site ('other', the rest of the body, has its time above
  the threshold but no alerts). A site counts as loaded where its peak is over the threshold in
  most frames of a window of ``relief_s`` around the frame (a reading that wanders over and back
  for less than that is noise, either way), and a stretch ends when it stays unloaded for
  ``relief_s``: shorter reliefs do not relieve the skin.

Times: seconds from the first frame. Frame ``t`` lasts until frame ``t + 1`` (the last one lasts the
median frame interval); a gap between frames longer than ``max_gap_s`` is refused (the recording
lacks that time: the clock of a site's load would be wrong).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pressurepose.body.sites import NO_SITE, SITES, site_stats
from pressurepose.errors import BadInput, require_non_negative, require_positive, require_whole
from pressurepose.mat import MAX_TAXELS, MatSpec
from pressurepose.net.plausibility import Plausibility
from pressurepose.pose.posture import posture_index

CAPILLARY_CLOSING_MMHG = 32.0  # Landis 1930
REPOSITION_S = 2 * 3600.0
POSTURES = ("supine", "left", "prone", "right")  # in the order of pose.posture.POSTURES
EMPTY = "empty"
UNCLEAR = "unclear"  # a frame that does not look like a person lying on the mat
NOT_LYING = (EMPTY, UNCLEAR)
_CHUNK = 2048  # frames per block of the per-site statistics (bounded memory on a night of frames)


@dataclass(frozen=True)
class MonitorConfig:
    """Settings of a timeline (see the module doc): threshold_mmhg, reposition_s, relief_s, change,
    min_posture_s, contact_mmhg, min_contact_taxels, max_gap_s (seconds and mmHg)."""

    threshold_mmhg: float = CAPILLARY_CLOSING_MMHG
    reposition_s: float = REPOSITION_S
    relief_s: float = 60.0
    change: float = 0.1
    min_posture_s: float = 60.0
    contact_mmhg: float = 1.0
    min_contact_taxels: int = 20
    max_gap_s: float = 60.0

    def __post_init__(self):
        for name in ("threshold_mmhg", "reposition_s", "max_gap_s"):
            require_positive(name, getattr(self, name))
        for name in ("relief_s", "change", "min_posture_s", "contact_mmhg"):
            require_non_negative(name, getattr(self, name))
        require_whole("min_contact_taxels", self.min_contact_taxels, 1, MAX_TAXELS)


# ---------------------------------------------------------------------------------------- time
def frame_times(count: int, fps: float | None = None, timestamps=None, max_gap_s: float = 60.0) -> np.ndarray:
    """(count,) seconds from the first frame, from a frame rate ``fps`` (Hz) or ``timestamps``
    (count,) seconds (any origin). BadInput without either, with both, for timestamps that are not
    a 1-D sequence of ``count`` numbers or do not increase, or for a gap between frames longer than
    ``max_gap_s``."""
    if (fps is None) == (timestamps is None):
        raise BadInput("a recording needs its timing: a frame rate (fps, frames per second) or a timestamp per "
                       "frame, not both" if fps is not None else
                       "a recording needs its timing: give its frame rate (fps, frames per second) or a timestamp "
                       "per frame")
    require_whole("count (frames)", count, 0)
    require_positive("max_gap_s", max_gap_s)
    if fps is not None:
        require_positive("frame rate (frames per second)", fps)
        t = np.arange(count, dtype=np.float64) / float(fps)
        check_times(t, count, max_gap_s)
        return t
    t = check_times(timestamps, count, max_gap_s, "timestamps")
    return t - t[0] if len(t) else t


def check_times(times, count: int, max_gap_s: float, what: str = "times") -> np.ndarray:
    """``times`` as (count,) float64 seconds, as given; BadInput naming ``what`` unless they are one
    finite number per frame in a 1-D sequence, increasing, with no gap between frames longer than
    ``max_gap_s``."""
    if times is None or isinstance(times, (str, bytes, dict)):
        raise BadInput(f"{what} are {times!r:.80}; expected a number of seconds per frame")
    try:
        raw = np.asarray(times)
    except (TypeError, ValueError):  # ragged
        raise BadInput(f"{what} are {times!r:.80}; expected a number of seconds per frame") from None
    if raw.dtype.kind in "mM":  # their unit is not seconds
        raise BadInput(f"{what} hold {raw.dtype} values; expected a number of seconds per frame (not dates or "
                       f"durations)")
    if raw.ndim != 1:  # a (T, 1) column or a (2, T/2) table read flat would pass as T times
        raise BadInput(f"{what} have shape {raw.shape}; expected a 1-D sequence of {count} (one number of seconds "
                       f"per frame)")
    try:
        t = raw.astype(np.float64)
    except (TypeError, ValueError):
        raise BadInput(f"{what} hold {raw.dtype} values that are not numbers; expected a number of seconds per "
                       f"frame") from None
    if t.shape != (count,):
        raise BadInput(f"{t.size} {what} for {count} frames; expected one per frame")
    if not np.all(np.isfinite(t)):
        raise BadInput(f"{what} hold NaN or infinite values")
    step = np.diff(t)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0))
        raise BadInput(f"{what} must increase: frame {k + 1} is at {t[k + 1]:g} s, frame {k} at {t[k]:g} s")
    if len(step) and step.max() > max_gap_s:
        k = int(np.argmax(step))
        raise BadInput(f"the recording has a gap of {step[k]:.0f} s between frames {k} and {k + 1} (at "
                       f"{t[k] - t[0]:.0f} s), longer than {max_gap_s:g} s: the time in it is not recorded. Split the "
                       f"recording there, or allow longer gaps (max_gap_s; --max-gap-s)")
    return t


def frame_durations(times: np.ndarray) -> np.ndarray:
    """(T,) seconds each frame stands for: until the next frame; the last one the median interval."""
    t = np.asarray(times, dtype=np.float64)
    step = np.diff(t)
    return np.r_[step, np.median(step) if len(step) else 0.0]


# ---------------------------------------------------------------------------------------- frames
@dataclass(frozen=True)
class FrameSelection:
    """Which frames a recording's timeline estimates. occupied (T,) bool: somebody is on the mat;
    estimated (T,) bool: the network reads this frame; ref (T,) int: the estimated frame whose
    body frame t shares (-1 for empty frames)."""

    occupied: np.ndarray
    estimated: np.ndarray
    ref: np.ndarray


def load_change(a: np.ndarray, b: np.ndarray) -> float:
    """Relative L1 change between two pressure images: sum |a - b| / max(sum a, sum b) (0 for two
    empty images)."""
    whole = max(float(a.sum()), float(b.sum()))
    return float(np.abs(a - b).sum() / whole) if whole > 0 else 0.0


def select_frames(frames, config: MonitorConfig = MonitorConfig()) -> FrameSelection:
    """The frames (T, R, C) mmHg to estimate: the first occupied frame after an empty spell, and each
    frame whose :func:`load_change` from the last estimated frame exceeds ``config.change``."""
    p = np.asarray(frames, dtype=np.float32)
    if p.ndim != 3:
        raise BadInput(f"frames have shape {p.shape}; expected (T, rows, cols)")
    occupied = (p > config.contact_mmhg).sum((1, 2)) >= config.min_contact_taxels
    estimated = np.zeros(len(p), bool)
    ref = np.full(len(p), -1, dtype=np.int64)
    last = -1
    for t in range(len(p)):
        if not occupied[t]:
            last = -1
            continue
        if last < 0 or load_change(p[t], p[last]) > config.change:
            estimated[t] = True
            last = t
        ref[t] = last
    return FrameSelection(occupied=occupied, estimated=estimated, ref=ref)


# ---------------------------------------------------------------------------------------- timeline
@dataclass(frozen=True)
class Turn:
    """A change of lying posture at ``time_s`` (frame ``frame``): from one posture to another, the
    body's roll changed by ``roll_change_deg`` (median roll of the new posture less the old one's,
    in (-180, 180])."""

    time_s: float
    frame: int
    before: str
    after: str
    roll_change_deg: float


@dataclass(frozen=True)
class Alert:
    """A site loaded above the threshold from ``start_s`` to ``end_s`` without relief, longer than
    the repositioning interval: ``due_s`` is when the interval ran out; ``peak_mmhg`` the highest
    reading of the site in that time."""

    site: str
    start_s: float
    end_s: float
    duration_s: float
    due_s: float
    peak_mmhg: float


@dataclass(frozen=True)
class Timeline:
    """A recording read over time (see the module doc).

    times_s (T,); posture (T,) str ('supine', 'left', 'right', 'prone', 'empty' or 'unclear' (the
    frames :attr:`doubtful` marks), after the
    movements shorter than ``min_posture_s`` are joined to the posture before them); roll_deg (T,)
    the body's roll (NaN on empty frames); estimated (T,) bool; peak_mmhg, mean_mmhg, share (T, S)
    per site of :data:`~pressurepose.body.sites.SITES`; turns; posture_s {posture: seconds};
    above_s, longest_above_s {site: seconds loaded above the threshold (:func:`loaded_frames`), in
    all and the longest stretch};
    alerts; config; plausibility: whether each frame looks like a person lying on the mat
    (:func:`pressurepose.net.plausibility.check_plausible`; None: not checked), read through
    :attr:`doubtful`; sites_read_by: how each taxel got its site, 'site network' or 'estimated
    body' (:attr:`pressurepose.net.infer.Estimate.sites_read_by`); site_network: which site network
    (:attr:`pressurepose.net.sitenet.SiteNet.source`: 'shipped' or its file), None for none.
    """

    times_s: np.ndarray
    posture: np.ndarray
    roll_deg: np.ndarray
    estimated: np.ndarray
    peak_mmhg: np.ndarray
    mean_mmhg: np.ndarray
    share: np.ndarray
    turns: list[Turn]
    posture_s: dict[str, float]
    above_s: dict[str, float]
    longest_above_s: dict[str, float]
    alerts: list[Alert]
    config: MonitorConfig = field(default_factory=MonitorConfig)
    plausibility: Plausibility | None = None
    sites_read_by: str = "estimated body"
    site_network: str | None = None

    def __len__(self) -> int:
        return int(len(self.times_s))

    @property
    def doubtful(self) -> np.ndarray:
        """(T,) bool: frames that carry a body read by the network (not empty) but whose image does
        not look like a person lying on the mat (noise, an object, a person sitting ...): their
        posture and body sites mean nothing. All False when the frames were not checked."""
        return doubtful_frames(self.plausibility, self.roll_deg)

    def summary(self) -> dict:
        """The timeline's findings as a strict-JSON-ready dict (no per-frame rows)."""
        return {
            "frames": len(self), "frames_estimated": int(self.estimated.sum()),
            "frames_doubtful": int(self.doubtful.sum()),
            "duration_s": _num(float(frame_durations(self.times_s).sum())),
            "settings": dataclasses.asdict(self.config), "sites_read_by": self.sites_read_by,
            "site_network": self.site_network,
            "turns": [{k: _num(v) for k, v in dataclasses.asdict(t).items()} for t in self.turns],
            "posture_s": {k: _num(v) for k, v in self.posture_s.items()},
            "above_threshold_s": {k: _num(v) for k, v in self.above_s.items()},
            "longest_above_threshold_s": {k: _num(v) for k, v in self.longest_above_s.items()},
            "alerts": [{k: _num(v) for k, v in dataclasses.asdict(a).items()} for a in self.alerts],
        }

    def segments(self) -> list[dict]:
        """One dict per stretch of one posture (after the movements are joined): posture, start_s,
        end_s, duration_s, first_frame, frames, roll_deg (its median roll; None when empty), and per
        site its highest peak (``peak_mmhg``) and its time-weighted mean share of the load (``share``)."""
        dur = frame_durations(self.times_s)
        cut = np.flatnonzero(self.posture[1:] != self.posture[:-1]) + 1
        return [{"posture": str(self.posture[s]), "start_s": _num(float(self.times_s[s])),
                 "end_s": _num(float(self.times_s[e - 1] + dur[e - 1])), "duration_s": _num(float(dur[s:e].sum())),
                 "first_frame": int(s), "frames": int(e - s), **self._loads(s, e, dur)}
                for s, e in zip(np.r_[0, cut], np.r_[cut, len(self)]) if e > s]

    def per_interval(self, interval_s: float = 60.0) -> list[dict]:
        """One dict per ``interval_s`` of the recording, counted from its first frame (an interval
        holding no frame is left out): start_s, end_s, duration_s (the time its frames stand for),
        posture (the one held longest in it), frames, frames_estimated, roll_deg (median), and per
        site the highest peak (``peak_mmhg``) and the time-weighted mean share of the load (``share``)."""
        require_positive("interval_s (seconds)", interval_s)
        dur = frame_durations(self.times_s)
        k = np.floor(self.times_s / interval_s).astype(np.int64)
        starts = np.flatnonzero(np.r_[True, k[1:] != k[:-1]]) if len(self) else np.zeros(0, np.int64)
        out = []
        for s, e in zip(starts, np.r_[starts[1:], len(self)]):
            names, where = np.unique(self.posture[s:e], return_inverse=True)
            held = np.bincount(where, weights=dur[s:e], minlength=len(names))
            out.append({"start_s": _num(float(k[s] * interval_s)), "end_s": _num(float((k[s] + 1) * interval_s)),
                        "duration_s": _num(float(dur[s:e].sum())), "posture": str(names[int(np.argmax(held))]),
                        "frames": int(e - s), "frames_estimated": int(self.estimated[s:e].sum()),
                        **self._loads(s, e, dur)})
        return out

    def _loads(self, s: int, e: int, dur: np.ndarray) -> dict:
        """Median roll and per-site highest peak and time-weighted mean share of frames s to e
        (exclusive); dur (T,) the frames' durations."""
        d = dur[s:e]
        w = d / d.sum() if d.sum() > 0 else np.full(e - s, 1.0 / (e - s))
        return {"roll_deg": _num(_median_roll(self.roll_deg[s:e]), 1),
                "peak_mmhg": {site: _num(float(self.peak_mmhg[s:e, k].max())) for k, site in enumerate(SITES)},
                "share": {site: _num(float(w @ self.share[s:e, k]), 5) for k, site in enumerate(SITES)}}

    def to_dict(self, interval_s: float = 60.0) -> dict:
        """:meth:`summary`, the sites, the posture segments (:meth:`segments`) and the recording per
        ``interval_s`` (:meth:`per_interval`), strict JSON (NaN written as null). The rows of every
        frame are :meth:`to_csv`'s."""
        intervals = self.per_interval(interval_s)  # first: BadInput for a bad interval_s
        return {**self.summary(), "sites": list(SITES), "interval_s": _num(float(interval_s)),
                "segments": self.segments(), "per_interval": intervals}

    def to_csv(self) -> str:
        """One line per frame: time_s, posture, roll_deg, estimated, then ``<site>_peak_mmhg`` and
        ``<site>_share`` for every site, then doubtful (1: see :attr:`doubtful`)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["time_s", "posture", "roll_deg", "estimated", *[f"{s}_peak_mmhg" for s in SITES],
                    *[f"{s}_share" for s in SITES], "doubtful"])
        doubtful = self.doubtful
        for t in range(len(self)):
            roll = "" if not np.isfinite(self.roll_deg[t]) else f"{self.roll_deg[t]:.1f}"
            w.writerow([f"{self.times_s[t]:.3f}", self.posture[t], roll, int(self.estimated[t]),
                        *[f"{v:.2f}" for v in self.peak_mmhg[t]], *[f"{v:.4f}" for v in self.share[t]],
                        int(doubtful[t])])
        return buf.getvalue()


def _num(v, digits: int = 3):
    if isinstance(v, float):
        return round(v, digits) if math.isfinite(v) else None
    return v


def doubtful_frames(plausibility: Plausibility | None, roll) -> np.ndarray:
    """(T,) bool: frames with a body (finite ``roll`` (T,)) whose image ``plausibility`` doubts;
    all False when the frames were not checked (None)."""
    body = np.isfinite(np.asarray(roll, dtype=np.float64))
    return body & ~plausibility.ok if plausibility is not None else np.zeros(len(body), dtype=bool)


def posture_names(roll) -> np.ndarray:
    """(T,) 'supine', 'left', 'prone' or 'right' for rolls (T,) radians; 'empty' where NaN."""
    r = np.asarray(roll, dtype=np.float64)
    out = np.full(r.shape, EMPTY, dtype=object)
    ok = np.isfinite(r)
    out[ok] = np.array(POSTURES)[posture_index(r[ok])]
    return out.astype(str)


def posture_runs(posture, durations, min_posture_s: float) -> list[tuple[str, int, int]]:
    """Runs (posture, first frame, end frame exclusive) of a per-frame posture sequence, a run
    shorter than ``min_posture_s`` (from ``durations`` (T,) s) joined to the run before it (the
    first run, when short, to the one after it), runs of one posture merged."""
    p = np.asarray(posture)
    d = np.asarray(durations, dtype=np.float64)
    if not len(p):
        return []
    cut = np.flatnonzero(p[1:] != p[:-1]) + 1
    starts, ends = np.r_[0, cut], np.r_[cut, len(p)]
    out: list[list] = []
    for s, e in zip(starts, ends):
        short = d[s:e].sum() < min_posture_s
        if out and (short or out[-1][0] == p[s]):
            out[-1][2] = e
        else:
            out.append([str(p[s]), int(s), int(e)])
    if len(out) >= 2 and d[out[0][1]:out[0][2]].sum() < min_posture_s:
        out[1][1] = 0
        out.pop(0)
    merged: list[list] = []
    for _, s, e in out:  # a run is named for the posture held longest in it (a whole short recording too)
        names = sorted(set(p[s:e].tolist()))
        lab = max(names, key=lambda n: (d[s:e][p[s:e] == n].sum(), n not in NOT_LYING))
        if merged and merged[-1][0] == lab:
            merged[-1][2] = e
        else:
            merged.append([lab, s, e])
    return [(lab, s, e) for lab, s, e in merged]


def _wrap_deg(a: float) -> float:
    return float((a + 180.0) % 360.0 - 180.0) if np.isfinite(a) else float("nan")


def find_turns(runs, roll_deg, times) -> list[Turn]:
    """The turns between consecutive lying runs of different postures ('empty' and 'unclear' runs
    passed over)."""
    lying = [r for r in runs if r[0] not in NOT_LYING]
    out = []
    for (a, s0, e0), (b, s1, e1) in zip(lying, lying[1:]):
        if a == b:
            continue
        before, after = _median_roll(roll_deg[s0:e0]), _median_roll(roll_deg[s1:e1])
        out.append(Turn(time_s=float(times[s1]), frame=int(s1), before=a, after=b,
                        roll_change_deg=_wrap_deg(after - before)))
    return out


def _median_roll(roll_deg) -> float:
    """Circular median-like centre of rolls (deg): the median after unwrapping around their mean direction."""
    r = np.asarray(roll_deg, dtype=np.float64)
    r = r[np.isfinite(r)]
    if not len(r):
        return float("nan")
    centre = math.degrees(math.atan2(np.sin(np.radians(r)).mean(), np.cos(np.radians(r)).mean()))
    return float(centre + np.median([_wrap_deg(x - centre) for x in r]))


def loaded_frames(above, durations, relief_s: float) -> np.ndarray:
    """(T,) bool: the frames where a site counts as loaded, from ``above`` (T,) bool (its peak over
    the threshold): more than half of the frames within ``relief_s`` / 2 either side are above, so a
    reading that wanders over and back under the threshold for less than that is noise, either way."""
    a = np.asarray(above, bool)
    d = np.asarray(durations, dtype=np.float64)
    step = float(np.median(d)) if len(d) else 0.0
    width = int(round(relief_s / step)) if step > 0 else 1
    if width <= 1 or not a.any():
        return a
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(a.astype(np.float64), width | 1, mode="nearest") > 0.5


def above_stretches(above, times, durations, relief_s: float) -> list[tuple[int, int]]:
    """Stretches (first frame, end frame exclusive) where a site is loaded (:func:`loaded_frames`
    of ``above`` (T,) bool), a relief shorter than ``relief_s`` between two of them not ending the
    stretch."""
    a = loaded_frames(above, durations, relief_s)
    if not a.any():
        return []
    edges = np.diff(np.r_[0, a.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    out = [[int(starts[0]), int(ends[0])]]
    for s, e in zip(starts[1:], ends[1:]):
        gap = times[s] - (times[out[-1][1] - 1] + durations[out[-1][1] - 1])
        if gap < relief_s:
            out[-1][1] = int(e)
        else:
            out.append([int(s), int(e)])
    return [(s, e) for s, e in out]


def timeline(times, frames, selection: FrameSelection, roll, site_maps, mat: MatSpec,
             config: MonitorConfig = MonitorConfig(), plausibility: Plausibility | None = None) -> Timeline:
    """The timeline of a recording: times (T,) s from :func:`frame_times`; frames (T, R, C) mmHg on
    ``mat``; ``selection`` from :func:`select_frames`; roll (E,) radians of the bodies of the E
    estimated frames and ``site_maps`` (E, R, C) their site maps
    (:func:`pressurepose.body.sites.body_site_map`), in frame order; ``plausibility``: the frames'
    check (:func:`pressurepose.net.plausibility.check_plausible`), or None."""
    t = np.asarray(times, dtype=np.float64)
    p = np.asarray(frames, dtype=np.float32)
    est = np.flatnonzero(selection.estimated)
    roll = np.asarray(roll, dtype=np.float64)
    maps = np.asarray(site_maps)
    if p.ndim != 3 or p.shape[1:] != mat.shape or len(t) != len(p) or len(selection.ref) != len(p):
        raise BadInput(f"frames {p.shape} and times {t.shape} must be T frames on the {mat.rows} x {mat.cols} mat "
                       f"and T times")
    if roll.shape != (len(est),) or maps.shape != (len(est), *mat.shape):
        raise BadInput(f"roll {roll.shape} and site maps {maps.shape} must hold one body per estimated frame "
                       f"({len(est)})")
    if plausibility is not None and len(plausibility) != len(p):
        raise BadInput(f"a plausibility check of {len(plausibility)} frames for {len(p)} frames")
    dur = frame_durations(t)
    which = np.full(len(t), -1, dtype=np.int64)  # each frame's body: index into the estimated frames
    which[selection.ref >= 0] = np.searchsorted(est, selection.ref[selection.ref >= 0])
    roll_frame = np.full(len(t), np.nan)  # NaN where nobody is on the mat (every frame, when no body was read)
    roll_frame[which >= 0] = roll[which[which >= 0]]
    S = len(SITES)
    peak, mean, share = (np.zeros((len(t), S)) for _ in range(3))
    for s in range(0, len(t), _CHUNK):
        sl = slice(s, s + _CHUNK)
        w = which[sl]
        taxel = np.where((p[sl] > config.contact_mmhg) & (w >= 0)[:, None, None],
                         maps[np.maximum(w, 0)] if len(maps) else NO_SITE, NO_SITE).astype(np.int8)
        loads = site_stats(p[sl], taxel, mat)
        peak[sl], mean[sl], share[sl] = loads.peak_mmhg, loads.mean_mmhg, loads.share
    names = posture_names(roll_frame).astype(object)
    names[doubtful_frames(plausibility, roll_frame)] = UNCLEAR  # a body, but not a lying person's image
    runs = posture_runs(names, dur, config.min_posture_s)
    posture = np.empty(len(t), dtype=object)
    for lab, s, e in runs:
        posture[s:e] = lab
    roll_deg = np.degrees(roll_frame)
    posture_s = {k: 0.0 for k in (*POSTURES, *NOT_LYING)}
    for lab, s, e in runs:
        posture_s[lab] += float(dur[s:e].sum())
    above_s, longest, alerts = {}, {}, []
    for k, site in enumerate(SITES):
        above = peak[:, k] > config.threshold_mmhg
        above_s[site] = float(dur[loaded_frames(above, dur, config.relief_s)].sum())
        stretches = above_stretches(above, t, dur, config.relief_s)
        lengths = [float(t[e - 1] + dur[e - 1] - t[s]) for s, e in stretches]
        longest[site] = max(lengths, default=0.0)
        for (s, e), length in zip(stretches, lengths):
            if length > config.reposition_s and site != "other":
                alerts.append(Alert(site=site, start_s=float(t[s]), end_s=float(t[e - 1] + dur[e - 1]),
                                    duration_s=length, due_s=float(t[s] + config.reposition_s),
                                    peak_mmhg=float(peak[s:e, k].max())))
    alerts.sort(key=lambda a: (a.due_s, a.site))
    return Timeline(times_s=t, posture=posture.astype(str), roll_deg=roll_deg, estimated=selection.estimated.copy(),
                    peak_mmhg=peak, mean_mmhg=mean, share=share, turns=find_turns(runs, roll_deg, t),
                    posture_s=posture_s, above_s=above_s, longest_above_s=longest, alerts=alerts, config=config,
                    plausibility=plausibility)


# ---------------------------------------------------------------------------------------- the network
def monitor(frames, times, gender, model=None, config: MonitorConfig = MonitorConfig(), batch_size: int = 64,
            chunk: int = 512, progress: bool = True, *, mat=None, units: str | None = None, weight_kg=None,
            gain: float | None = None, head_row: str = "first", site_net="auto") -> Timeline:
    """The timeline of a recording read by PressureNet: frames (T, R, C) mmHg on the model's mat (or
    a recording file or folder of them), times (T,) s (:func:`frame_times`), gender 'f' / 'm'; model and
    site_net as :func:`pressurepose.net.infer.estimate`'s. With ``mat`` (preset name, mat.json or MatSpec),
    frames are a recording on that mat as it was recorded (an array (T, rows, cols) or a recording
    file or folder, :func:`~pressurepose.data.readers.recording.read_frames`), in ``units`` ('raw'
    or 'mmHg'; raw readings become mmHg by ``weight_kg`` or ``gain``), with the head at ``head_row``:
    they take :func:`recording_input`'s road onto the model's mat first, as the ``monitor`` verb's do.
    Only the frames :func:`select_frames` picks are estimated, ``chunk`` at a time (bounded memory),
    ``batch_size`` per network call. Every frame is checked for looking like a person lying on the
    mat (:attr:`Timeline.doubtful`). progress: a progress bar over the chunks on stderr (default
    True, as for every function that runs over a recording). BadInput for times that are not one
    increasing number per frame, or that leave a gap longer than ``config.max_gap_s``
    (:func:`check_times`), before any frame is estimated."""
    from pressurepose.body.sites import body_site_map
    from pressurepose.data.readers.recording import read_frames, resolve_mat
    from pressurepose.net.infer import (
        _genders,
        check_pressure,
        estimate,
        refuse_recording_settings,
        resolve_model,
    )
    from pressurepose.net.plausibility import check_plausible
    from pressurepose.net.sitenet import read_taxel_sites, resolve_site_net
    from pressurepose.pose.posture import roll_angle

    if not isinstance(config, MonitorConfig):
        raise BadInput(f"config is {type(config).__name__}; expected a MonitorConfig")
    require_whole("chunk (frames estimated at a time)", chunk, 1)
    require_whole("batch size", batch_size, 1)
    if isinstance(gender, bool) or not isinstance(gender, (str, int, np.integer)):
        raise BadInput(f"gender is {gender!r:.80}; expected f or m (the person of the recording)")
    gender = _genders(gender, 1)[0]
    net = resolve_model(model)
    grid = net.config.grid
    site_net = resolve_site_net(site_net, grid)
    if mat is None:
        refuse_recording_settings(units, weight_kg, gain, head_row)
    if isinstance(frames, (str, Path)):  # frames as stored, on the recording's mat or else the model's
        frames = read_frames(frames, (grid if mat is None else resolve_mat(mat)[0]).shape)
    if mat is not None:
        frames, _ = recording_input(frames, mat, units, grid, weight_kg=weight_kg, gain=gain, head_row=head_row)
    p = check_pressure(frames, grid.shape, "recording")
    t = check_times(times, len(p), config.max_gap_s)
    selection = select_frames(p, config)
    idx = np.flatnonzero(selection.estimated)
    roll = np.zeros(len(idx))
    maps = np.zeros((len(idx), *grid.shape), dtype=np.int8)
    read_by = "estimated body" if site_net is None else "site network"  # as Estimate.sites_read_by says
    from tqdm import tqdm

    for s in tqdm(range(0, len(idx), chunk), desc="monitor", unit="chunk", disable=not progress):
        part = idx[s:s + chunk]
        est = estimate(p[part], gender, net, batch_size=batch_size, progress=False, site_net=site_net)  # in monitor's bar
        roll[s:s + len(part)] = roll_angle(est.pose)
        body = body_site_map(est.vertices, est.faces, est.vertex_site, grid, p[part])
        if site_net is not None:  # the loaded taxels' sites read by the site network, as estimate() reads them
            read = read_taxel_sites(site_net, p[part], np.where(p[part] > 0, body, NO_SITE))
            body = np.where(read >= 0, read, body)
        maps[s:s + len(part)] = body
    tl = timeline(t, p, selection, roll, maps, grid, config, check_plausible(p, grid))
    return dataclasses.replace(tl, sites_read_by=read_by, site_network=None if site_net is None else site_net.source)


def recording_input(frames, mat, units: str, dst: MatSpec, weight_kg=None, gain: float | None = None,
                    head_row: str = "first", chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """A recording's frames (T, rows, cols) on ``mat`` (preset, mat.json or MatSpec) as the model's
    input: (T, dst.rows, dst.cols) float32 mmHg and occupied (T,) bool. Frames that carry a body
    take the road every real image takes (:func:`pressurepose.data.readers.recording.read_recording`
    then :meth:`~pressurepose.data.readers.images.RealImages.model_input`: cleaned, in mmHg by
    ``gain`` or ``weight_kg``, resampled onto ``dst``); a frame whose total reading is under a fifth
    of the median of the recording's non-zero frames is empty (nobody on the mat) and stays 0."""
    from pressurepose.data.readers.recording import read_recording
    from pressurepose.data.realprep import valid_frames

    real = read_recording(np.asarray(frames), mat, units, weight_kg=weight_kg, gain=gain, head_row=head_row)
    occupied = valid_frames(real.images, low=0.2, high=np.inf)
    out = np.zeros((len(real), *dst.shape), dtype=np.float32)
    idx = np.flatnonzero(occupied)
    for s in range(0, len(idx), chunk):
        part = idx[s:s + chunk]
        out[part] = real.select(part).model_input(dst)
    return out, occupied
