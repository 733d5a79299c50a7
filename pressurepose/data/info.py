"""Summaries of a dataset: counts by partition and gender, rejection rates, pressure statistics
(its picture: :mod:`pressurepose.viz.dataset`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pressurepose.data.dataset import DatasetReader
from pressurepose.data.store import read_shard_arrays
from pressurepose.errors import BadInput

GRAVITY = 9.81


@dataclass
class Summary:
    root: Path
    mat: str
    shape: tuple[int, int]
    samples: int
    datasets: int
    counts: dict[tuple[str, str, bool], int] = field(default_factory=dict)  # (partition, gender, plo)
    attempts: int = 0
    rejections: dict[str, int] = field(default_factory=dict)
    incomplete: list[str] = field(default_factory=list)
    beds: list[str] = field(default_factory=list)  # the beds given to `generate --bed`, one line each
    repressed_from: list[str] = field(default_factory=list)  # sources of `repress`ed datasets
    settles: list[str] = field(default_factory=list)  # how the bodies came to rest, one line each
    pressure_mean: float = 0.0        # mmHg over all taxels
    pressure_mean_loaded: float = 0.0  # mmHg over taxels with pressure > 0
    pressure_max: float = 0.0
    pressure_p99: float = 0.0         # of loaded taxels (from the histogram)
    contact_fraction: float = 0.0
    load_ratio_mean: float = 0.0      # mat force / body weight
    pressure_hist: tuple[np.ndarray, np.ndarray] | None = None  # (counts, edges) of loaded taxels
    load_ratio: np.ndarray | None = None
    examples: list[tuple[str, np.ndarray]] = field(default_factory=list)

    @property
    def rejection_rate(self) -> float:
        return sum(self.rejections.values()) / self.attempts if self.attempts else 0.0


def summarize(root: str | Path, *, verify: bool = True, examples: int = 6) -> Summary:
    """Read every shard once (streaming) and gather the statistics of :class:`Summary`."""
    reader = DatasetReader(root, verify=verify, allow_incomplete=True)
    first = reader.datasets[0].config
    mats = sorted({f"{d.config.mat} ({d.config.grid.rows} x {d.config.grid.cols})" for d in reader.datasets})
    if len(mats) > 1:  # pressures of different mats do not pool into one histogram
        raise BadInput(f"{root} holds datasets on {len(mats)} mats ({', '.join(mats)}); summarise each mat's "
                       f"datasets on their own")
    mat = first.grid
    s = Summary(Path(root), mat.name, mat.shape, len(reader), len(reader.datasets))
    for part in reader.datasets:
        c, m = part.config, part.manifest
        key = (c.partition, c.gender, bool(c.limbs_on_bed))
        s.counts[key] = s.counts.get(key, 0) + m.samples_done
        s.attempts += m.attempts
        for cause, n in m.rejections.items():
            s.rejections[cause] = s.rejections.get(cause, 0) + n
        if not m.complete:
            s.incomplete.append(f"{part.path} ({len(m.shards)} of {c.num_shards} shards)")
        if c.bed:
            b = c.bed_spec()
            line = (f"k_A {b.stiffness_n_m3:.3g} N/m^3, tissue {b.tissue_modulus_pa:.3g} Pa, threshold "
                    f"{b.sensor_threshold_mmhg:.2g} mmHg, bone fractions "
                    + " ".join(f"{v:.2g}" for v in b.tissue_bone_fraction))
            if line not in s.beds:
                s.beds.append(line)
        settle = settle_line(m.provenance.get("settle"))
        if settle and settle not in s.settles:
            s.settles.append(settle)
        source = m.provenance.get("repressed_from")
        if isinstance(source, dict) and source.get("path") not in s.repressed_from:
            s.repressed_from.append(str(source.get("path")))
    edges = np.linspace(0.0, mat.max_mmhg * 1.5, 151)
    hist = np.zeros(len(edges) - 1)
    total = loaded = contact = 0.0
    n_taxels = n_loaded = 0
    pmax = 0.0
    ratios = []
    step = max(1, len(reader.shards) // max(1, examples))
    per_shard = -(-examples // max(1, len(reader.shards)))  # a dataset of few shards shows several of each
    for k, ref in enumerate(reader.shards):
        a = read_shard_arrays(ref.path, ["pressure", "force", "contact", "mass", "gender", "partition", "index"])
        p = a["pressure"].astype(np.float64)
        total += p.sum()
        n_taxels += p.size
        nz = p[p > 0]
        loaded += nz.sum()
        n_loaded += nz.size
        pmax = max(pmax, float(p.max()))
        contact += a["contact"].sum()
        hist += np.histogram(np.clip(nz, 0, edges[-1]), edges)[0]
        ratios.append(a["force"].sum((1, 2)) / (a["mass"] * GRAVITY))
        if k % step == 0 and len(s.examples) < examples:
            for i in np.unique(np.linspace(0, len(p) - 1, min(per_shard, len(p))).round().astype(int)):
                if len(s.examples) < examples:
                    s.examples.append((f"{a['partition'][i]}\n{a['gender'][i]} #{a['index'][i]}", a["pressure"][i]))
    if n_taxels:
        s.pressure_mean = total / n_taxels
        s.pressure_mean_loaded = loaded / max(n_loaded, 1)
        s.pressure_max = pmax
        s.contact_fraction = contact / n_taxels
        cdf = np.cumsum(hist) / max(hist.sum(), 1)
        s.pressure_p99 = float(edges[1:][np.searchsorted(cdf, 0.99)]) if hist.sum() else 0.0
        s.pressure_hist = (hist, edges)
        s.load_ratio = np.concatenate(ratios)
        s.load_ratio_mean = float(s.load_ratio.mean())
    return s


def settle_line(record) -> str:
    """The joint springs and time step a manifest's settle provenance (``SettleConfig`` as a dict)
    rested bodies with, in words ("" when the manifest has none, as for non-physics producers)."""
    keys = ("relaxed_neck", "spine_stiffness", "timestep_s", "coarse_factor", "coarse_after_steps")
    if not isinstance(record, dict) or not all(k in record for k in keys):
        return ""
    neck = "relaxed neck" if record["relaxed_neck"] else "the paper's stiff neck"
    k = record["spine_stiffness"]
    spine = "the paper's stiff spine" if k is None else f"relaxed spine ({k:g} N m/rad)"
    dt, factor = record["timestep_s"], record["coarse_factor"]
    step = (f"step {dt:g} s throughout" if factor == 1.0 else
            f"step {dt:g} s, {factor * dt:g} s from {record['coarse_after_steps']} steps after touching")
    return f"{neck}, {spine}, {step}"


def format_summary(s: Summary) -> str:
    rows, cols = s.shape
    lines = [f"{s.root}: {s.datasets} dataset(s), {s.samples} samples, mat {s.mat} ({rows} x {cols})", ""]
    lines.append(f"{'partition':24s} {'limbs on bed':>12s} {'f':>8s} {'m':>8s} {'total':>8s}")
    keys = sorted({(p, plo) for p, _, plo in s.counts})
    for p, plo in keys:
        f, m = s.counts.get((p, "f", plo), 0), s.counts.get((p, "m", plo), 0)
        lines.append(f"{p:24s} {'yes' if plo else 'no':>12s} {f:8d} {m:8d} {f + m:8d}")
    tf = sum(n for (_, g, _), n in s.counts.items() if g == "f")
    tm = sum(n for (_, g, _), n in s.counts.items() if g == "m")
    lines.append(f"{'total':24s} {'':>12s} {tf:8d} {tm:8d} {tf + tm:8d}")
    lines.append("")
    rej = ", ".join(f"{c} {n} ({100.0 * n / s.attempts:.1f}%)" for c, n in
                    sorted(s.rejections.items(), key=lambda kv: -kv[1])) if s.attempts else "none"
    lines.append(f"attempts {s.attempts}, rejected {100.0 * s.rejection_rate:.1f}%" + (f": {rej}" if s.rejections else ""))
    lines.append(f"pressure (mmHg): mean {s.pressure_mean:.2f} over all taxels, {s.pressure_mean_loaded:.2f} "
                 f"over loaded taxels, 99th percentile {s.pressure_p99:.1f}, max {s.pressure_max:.1f}")
    lines.append(f"contact: {100.0 * s.contact_fraction:.1f}% of taxels; force on the mat / body weight: "
                 f"mean {s.load_ratio_mean:.3f}")
    for settle in s.settles:
        lines.append(f"settled with: {settle}")
    for bed in s.beds:
        lines.append(f"made on a given bed (generate --bed or repress): {bed}")
    by_parent: dict[str, list[str]] = {}
    for src in s.repressed_from:
        by_parent.setdefault(str(Path(src).parent), []).append(src)
    for parent, srcs in by_parent.items():
        where = srcs[0] if len(srcs) == 1 else f"{len(srcs)} datasets under {parent}"
        lines.append(f"re-pressed (pressurepose repress) from the resting bodies of {where}")
    for inc in s.incomplete:
        lines.append(f"incomplete: {inc}")
    return "\n".join(lines)

