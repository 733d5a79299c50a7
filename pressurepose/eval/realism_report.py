"""The realism report: statistics of real and simulated pressure images, side by side by posture.

* :func:`load_real`: a real-data folder (PMD or a generic labelled folder, through
  :func:`pressurepose.data.readers.real.read_real`) prepared as the simulated images are made:
  weight-normalised mmHg resampled onto the simulated mat
  (:meth:`~pressurepose.data.readers.images.RealImages.model_input`, the road every real image takes);
  inclined-bed and weak recordings, and (by default) images whose source posture names a wedge,
  are left out.
* :func:`load_synthetic`: a generated dataset (directory) or a ``pressurepose simulate`` ``.npz``;
  the posture of each sample is its body's (roll of the root, :func:`pressurepose.eval.posture.posture_of`).
* :func:`realism_report`: per posture group (supine, lateral, prone) the summaries of both sets
  (:func:`pressurepose.eval.realism.summarise`) and their distances (:func:`~.realism.compare`).
* :func:`draw_report`: the distributions side by side and example images at one colour scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pressurepose.errors import BadInput
from pressurepose.eval import realism as R
from pressurepose.mat import MATS, MatSpec, get_mat


@dataclass(frozen=True, eq=False)
class ImageSet:
    """N pressure images (N, rows, cols) mmHg on ``mat`` with their posture group (N,) str, for
    simulated images taxel forces (N, rows, cols) N and body masses (N,) kg (else None), the
    people's statures (N,) m where known (for :func:`realism_report`'s ``match``), and for real
    images who each one is (N,) str where known (their region shares are resampled by person)."""

    name: str
    pressure: np.ndarray
    posture: np.ndarray
    mat: MatSpec
    force: np.ndarray | None = None
    mass: np.ndarray | None = None
    height: np.ndarray | None = None
    subject: np.ndarray | None = None

    def stats(self, rule: R.RegionRule = R.DEFAULT_RULE) -> dict:
        return R.image_stats(self.pressure, self.mat, rule, force_n=self.force, mass_kg=self.mass)


def real_selection(real, *, exclude_detail: tuple[str, ...] = ("wedge",), weak_fraction: float = 0.1,
                   only_detail: tuple[str, ...] = ()) -> np.ndarray:
    """(N,) bool: the images of a ``RealImages`` (``pressurepose.data.readers.real.read_real``) that
    :func:`load_real` keeps: a flat-bed supine, lateral or prone label, none of ``exclude_detail``'s
    words in the source posture (all of ``only_detail``'s if given), not a barely recorded mat."""
    from pressurepose.eval.real import detail_has, weak_images

    keep = (R.posture_group(real.posture) != "") & ~detail_has(real.detail, exclude_detail) \
        & ~weak_images(real, weak_fraction)
    if only_detail:
        keep &= detail_has(real.detail, only_detail)
    return keep


def load_real(folder, mat: MatSpec, *, exclude_detail: tuple[str, ...] = ("wedge",), frames: str = "one",
              weak_fraction: float = 0.1, only_detail: tuple[str, ...] = ()) -> ImageSet:
    """Real images of ``folder`` as weight-normalised mmHg on ``mat`` (see the module docstring);
    ``only_detail``: keep only images whose source posture names one of these words (e.g. "wedge")."""
    from pressurepose.data.readers.real import read_real

    real = read_real(folder, frames=frames)
    group = R.posture_group(real.posture)
    keep = real_selection(real, exclude_detail=exclude_detail, weak_fraction=weak_fraction, only_detail=only_detail)
    if not keep.any():
        raise BadInput(f"{folder}: no real image with a flat-bed supine, lateral or prone posture label"
                       + (f" naming {' or '.join(only_detail)}" if only_detail else ""))
    r = real.select(keep)
    x = r.model_input(mat)
    return ImageSet(f"real ({r.layout}, {Path(folder).name})", x.astype(np.float64), group[keep], mat,
                    height=np.asarray(r.height_m, dtype=np.float64), subject=np.asarray(r.subject, dtype=str))


def _mat_for_shape(shape, mat_name: str | None) -> MatSpec:
    if mat_name is not None:
        mat = get_mat(mat_name)
        if mat.shape != tuple(shape):
            raise BadInput(f"the images are {shape[0]} x {shape[1]}; mat {mat_name!r} is {mat.rows} x {mat.cols}")
        return mat
    found = [m for m in MATS.values() if m.shape == tuple(shape)]
    if len(found) != 1:
        raise BadInput(f"cannot tell the mat of {shape[0]} x {shape[1]} images ({len(found)} presets fit); give --mat")
    return found[0]


def load_synthetic(path, mat_name: str | None = None) -> ImageSet:
    """Simulated images of a generated dataset (a directory or folder of datasets) or of a
    ``pressurepose simulate`` output (``.npz``, read without pickle; its mat found from the image
    shape unless ``mat_name`` is given)."""
    from pressurepose.eval.posture import posture_of

    p = Path(path)
    if p.is_file():
        from pressurepose.files import load_npz

        arr = load_npz(p, "simulated images (a `pressurepose simulate` .npz)")
        missing = [k for k in ("pressure", "force", "pose", "mass") if k not in arr]
        if missing:
            raise BadInput(f"{p} lacks {', '.join(missing)}; expected a `pressurepose simulate` .npz")
        pressure = np.asarray(arr["pressure"])
        if pressure.ndim != 3:
            raise BadInput(f"{p}: pressure has shape {pressure.shape}; expected (N, rows, cols) images")
        if not np.all(np.isfinite(pressure)) or np.any(pressure < 0):
            raise BadInput(f"{p}: pressure holds NaN, infinite or negative values; expected finite mmHg >= 0")
        mat = _mat_for_shape(arr["pressure"].shape[1:], mat_name)
    elif p.is_dir():
        from pressurepose.data.dataset import DatasetReader

        reader = DatasetReader(p)
        arr = reader.load_arrays(("pressure", "force", "pose", "mass", "height"), image_dtype=np.float32,
                                 label_dtype=np.float64)
        mat = reader.datasets[0].config.grid
        if mat_name is not None and get_mat(mat_name) != mat:
            raise BadInput(f"{p} was made on mat {mat.name!r}, not {mat_name!r}; a dataset knows its mat, so leave "
                           f"--mat out")
    else:
        raise BadInput(f"synthetic data {str(p)!r} does not exist; expected a dataset directory or a simulate .npz")
    group = R.posture_group(posture_of(np.asarray(arr["pose"], dtype=np.float64)))
    return ImageSet(f"simulated ({p.name})", np.asarray(arr["pressure"], dtype=np.float64), group, mat,
                    np.asarray(arr["force"], dtype=np.float64), np.asarray(arr["mass"], dtype=np.float64).reshape(-1),
                    np.asarray(arr["height"], dtype=np.float64).reshape(-1) if "height" in arr else None)


# The like-postures resample draws this many images per simulated image of a posture (with repeats), so
# that its means hardly depend on the draw; its summaries' counts are draws, its headline counts distinct images.
MATCH_DRAWS_PER_IMAGE = 20


def realism_report(real: ImageSet, sim: ImageSet, rule: R.RegionRule = R.DEFAULT_RULE, match: bool = False,
                   seed: int = 0) -> dict:
    """{'rule', 'mat', 'postures': {group: {'real': summary, 'simulated': summary, 'distance':
    compare(...)}}} over the posture groups present in both sets (BadInput when none is). Where
    both sets know their people's statures, each group also has ``profile`` {'band', 'real',
    'simulated'}: the mean percent of the load per band of the stature below the head end
    (:func:`~.realism.load_profile`). Each group's ``regions`` holds, per region, the median contact
    taxels and mean reading over them, real and simulated (:func:`~.realism.region_contact`), and
    ``real_interval`` the 90 % interval of each headline statistic over resamples of the real people
    (:func:`~.realism.real_intervals`).

    ``match``: compare like postures: within each group the simulated images are resampled (seeded;
    :data:`MATCH_DRAWS_PER_IMAGE` draws per image) so that their extent ratio (:func:`~.realism.extent_ratio`: contact extent over stature, how
    long the body lies) follows the real images' (:func:`~.realism.match_by`), and each group also
    reports ``match`` {'coverage', 'extent_ratio_real', 'extent_ratio_sim_before', 'extent_ratio_sim',
    'distinct_sim_images'}. Region shares are
    fractions of the extent, so sampled poses with bent or spread legs put the pelvis in the thigh
    band; matching takes that posture difference out of the comparison of the physics."""
    if real.mat.shape != sim.mat.shape:
        raise BadInput(f"real images are on a {real.mat.shape} mat, simulated ones on {sim.mat.shape}")
    rs, ss = real.stats(rule), sim.stats(rule)
    groups = [g for g in ("supine", "lateral", "prone") if (real.posture == g).any() and (sim.posture == g).any()]
    if not groups:
        raise BadInput(f"real ({sorted(set(real.posture))}) and simulated ({sorted(set(sim.posture))}) images "
                       f"share no posture")
    out = {"rule": {"contact_mmhg": rule.contact_mmhg, "regions": list(R.REGIONS), "bounds": list(rule.bounds)},
           "mat": {"name": sim.mat.name, "rows": sim.mat.rows, "cols": sim.mat.cols,
                   "pitch_m": [sim.mat.pitch_row_m, sim.mat.pitch_col_m]},
           "real_name": real.name, "simulated_name": sim.name, "postures": {}}
    if match:
        if real.height is None or sim.height is None:
            raise BadInput("matching by extent ratio needs the statures of both sets' people")
        r_ratio = R.extent_ratio(real.pressure, real.mat, real.height, rule)
        s_ratio = R.extent_ratio(sim.pressure, sim.mat, sim.height, rule)
        out["match"] = {"by": "extent_ratio", "bins": [float(b) for b in R.MATCH_BINS], "seed": seed}
    for g in groups:
        r, s = R.select(rs, real.posture == g), R.select(ss, sim.posture == g)
        entry = {}
        rsel, ssel = np.flatnonzero(real.posture == g), np.flatnonzero(sim.posture == g)
        weight = np.ones(len(ssel))
        if match:
            pick, coverage = R.match_by(s_ratio[ssel], r_ratio[rsel], seed, draws=MATCH_DRAWS_PER_IMAGE * len(ssel))
            entry["match"] = {"coverage": coverage, "extent_ratio_real": _median(r_ratio[rsel]),
                              "extent_ratio_sim_before": _median(s_ratio[ssel]),
                              "extent_ratio_sim": _median(s_ratio[ssel][pick]),
                              "distinct_sim_images": int(len(np.unique(pick)))}
            s = R.select(ss, ssel[pick])
            weight = np.bincount(pick, minlength=len(ssel)).astype(float)
        shares = lambda st, idx: np.stack([st[f"share_{k}"][idx] for k in R.REGIONS], 1)  # noqa: E731
        try:
            entry["share_interval"] = R.share_gap_interval(
                shares(ss, ssel), shares(rs, rsel), None if real.subject is None else real.subject[rsel], weight,
                seed=seed)
        except BadInput:  # no image with contact on one side: no interval
            pass
        entry["real_interval"] = R.real_intervals(r, None if real.subject is None else real.subject[rsel], seed=seed)
        if real.height is not None and sim.height is not None:
            entry["profile"] = _profiles(real, sim, rsel, ssel, weight, rule)
        entry["regions"] = _region_contacts(real.pressure[rsel], sim.pressure[ssel], sim.mat, rule,
                                            pick if match else None)
        out["postures"][g] = {"real": R.summarise(r), "simulated": R.summarise(s), "distance": R.compare(s, r),
                              **entry}
    return out


def _profiles(real: ImageSet, sim: ImageSet, rsel, ssel, weight, rule: R.RegionRule) -> dict:
    """{'band', 'real', 'simulated'}: the mean :func:`~.realism.load_profile` (percent of the load
    per band of the stature below the head end) of the real images ``rsel`` and of the simulated
    images ``ssel`` weighted by ``weight`` (the matched resample's counts)."""
    def mean(st: ImageSet, idx, w) -> list:
        prof = R.load_profile(st.pressure[idx], st.mat, st.height[idx], rule)
        ok = np.isfinite(prof).all(1) & (w > 0)
        return [float(v) for v in np.average(prof[ok], axis=0, weights=w[ok])] if ok.any() else []

    return {"band": R.PROFILE_BAND, "real": mean(real, rsel, np.ones(len(rsel))), "simulated": mean(sim, ssel, weight)}


def _region_contacts(real_images, sim_images, mat: MatSpec, rule: R.RegionRule, sim_pick=None) -> dict:
    """{region: {'taxels_real', 'taxels_sim', 'mmhg_real', 'mmhg_sim'}}: medians over the images of
    :func:`~.realism.region_contact` (contact taxels in the region, mean reading over them), which say
    whether a region whose share differs touches over too little area or presses too hard. ``sim_pick``:
    indices into ``sim_images`` of a resample (repeats included) to take the simulated medians over."""
    r, s = R.region_contact(real_images, mat, rule), R.region_contact(sim_images, mat, rule)
    if sim_pick is not None:
        s = s[np.asarray(sim_pick)]
    return {k: {"taxels_real": _median(r[:, j, 0]), "taxels_sim": _median(s[:, j, 0]),
                "mmhg_real": _median(r[:, j, 1]), "mmhg_sim": _median(s[:, j, 1])}
            for j, k in enumerate(R.REGIONS)}


def _median(v) -> float | None:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if len(v) else None


def headline(report: dict) -> list[dict]:
    """One row per posture: the numbers the realism targets judge (contact area, head imprint, load
    share per region), the pressures and the load off the mat."""
    rows = []
    for g, d in report["postures"].items():
        r, s = d["real"], d["simulated"]
        n_sim = d["match"]["distinct_sim_images"] if "match" in d else s["contact_taxels"]["n"]
        rows.append({
            "posture": g, "n_real": r["contact_taxels"]["n"], "n_sim": n_sim,
            "area_real": r["contact_taxels"]["median"], "area_sim": s["contact_taxels"]["median"],
            "area_ratio": d["distance"]["contact_taxels"]["median_ratio"],
            "head_real": r["head_imprint"]["rate"], "head_sim": s["head_imprint"]["rate"],
            "mean_real": r["mean_mmhg"]["median"], "mean_sim": s["mean_mmhg"]["median"],
            "peak_real": r["peak_mmhg"]["median"], "peak_sim": s["peak_mmhg"]["median"],
            "share_real": {k: r[f"share_{k}"]["mean"] for k in R.REGIONS},
            "share_sim": {k: s[f"share_{k}"]["mean"] for k in R.REGIONS},
            "share_worst_pp": max(abs(d["distance"][f"share_{k}"]["mean_diff_pp"]) for k in R.REGIONS),
            "share_worst_pp_interval": d.get("share_interval", {}).get("worst"),
            "real_interval": d.get("real_interval"),
            "off_mat_sim": s.get("off_mat", {}).get("median"),
        })
    return rows


# The realism targets: the simulated contact area within 20 % of the real (median ratio), a head
# imprint in at least 80 % of simulated images, and every region's mean load share within 5 percentage points.
AREA_RATIO_TOLERANCE = 0.2
AREA_RATIO_GOAL = (1.0 - AREA_RATIO_TOLERANCE, 1.0 + AREA_RATIO_TOLERANCE)
HEAD_IMPRINT_GOAL = 0.8
SHARE_GAP_GOAL_PP = 5.0


def goal_verdicts(rows: list[dict]) -> list[dict]:
    """The realism targets checked on :func:`headline` rows: per posture and target, ``{'posture', 'goal',
    'value', 'target', 'met'}``, and for the share goal ``'interval'`` (the worst gap's 90 % interval
    from resampling the real people, or None) and ``'interval_holds_goal'`` (whether that interval
    reaches the goal: with few real people a gap just over 5 pp may not differ from it)."""
    out = []
    lo, hi = AREA_RATIO_GOAL
    for r in rows:
        g = r["posture"]
        area, head, worst = r["area_ratio"], r["head_sim"], r["share_worst_pp"]
        out.append({"posture": g, "goal": "contact area ratio", "value": area, "target": f"{lo:g}-{hi:g}",
                    "met": bool(area is not None and np.isfinite(area) and lo <= area <= hi)})
        out.append({"posture": g, "goal": "head imprint rate", "value": head, "target": f">= {HEAD_IMPRINT_GOAL:g}",
                    "met": bool(head is not None and np.isfinite(head) and head >= HEAD_IMPRINT_GOAL)})
        ci = r.get("share_worst_pp_interval")
        out.append({"posture": g, "goal": "worst region share gap, pp", "value": worst,
                    "target": f"<= {SHARE_GAP_GOAL_PP:g}",
                    "met": bool(worst is not None and np.isfinite(worst) and worst <= SHARE_GAP_GOAL_PP),
                    "interval": None if ci is None else [float(ci[0]), float(ci[1])],
                    "interval_holds_goal": None if ci is None else bool(ci[0] <= SHARE_GAP_GOAL_PP)})
    return out


def draw_report(real: ImageSet, sim: ImageSet, report: dict, path, rule: R.RegionRule = R.DEFAULT_RULE,
                examples: int = 3, seed: int = 0):
    """PNG at ``path``: per posture, box plots of contact area, mean and peak pressure and region
    load shares (real vs simulated), the mean load along the body (where the report has it), and
    ``examples`` real and simulated images at one colour scale (at most as many as a posture has:
    the figure is sized by the images there, not by the number asked for)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pressurepose.files import save_figure_atomic

    groups = list(report["postures"])
    examples = min(int(examples), max([int(np.sum(s.posture == g)) for s in (real, sim) for g in groups] + [0]))
    rs, ss = real.stats(rule), sim.stats(rule)
    rng = np.random.default_rng(seed)
    fig = plt.figure(figsize=(17, 6.2 * len(groups)))
    outer = fig.add_gridspec(2 * len(groups), 1, height_ratios=[1, 1.35] * len(groups), hspace=0.5,
                             top=1 - 0.7 / len(groups) / 6.2, bottom=0.03)
    colours = {"real": "tab:orange", "simulated": "tab:blue"}
    vmax = float(np.percentile(np.concatenate([real.pressure[real.pressure > rule.contact_mmhg],
                                               sim.pressure[sim.pressure > rule.contact_mmhg]]), 99))
    for gi, g in enumerate(groups):
        r_sel, s_sel = real.posture == g, sim.posture == g
        row = outer[2 * gi].subgridspec(1, 7, width_ratios=[1, 1, 1, 0.2, 3.2, 0.15, 1.8], wspace=0.35)
        for k, (key, label) in enumerate((("contact_cm2", "contact area, cm$^2$"), ("mean_mmhg", "mean contact, mmHg"),
                                          ("peak_mmhg", "peak, mmHg"))):
            ax = fig.add_subplot(row[k])
            data = [_finite(rs[key][r_sel]), _finite(ss[key][s_sel])]
            bp = ax.boxplot(data, widths=0.6, patch_artist=True, showfliers=True)
            for patch, c in zip(bp["boxes"], colours.values()):
                patch.set_facecolor(c)
                patch.set_alpha(0.6)
            ax.set_xticks([1, 2], [f"real\n{len(data[0])}", f"sim\n{len(data[1])}"], fontsize=9)
            ax.set_title(f"{g}:\n{label}", fontsize=9)
        ax = fig.add_subplot(row[4])
        x = np.arange(len(R.REGIONS))
        for off, (name, st, sel) in zip((-0.2, 0.2), (("real", rs, r_sel), ("simulated", ss, s_sel))):
            vals = [_finite(st[f"share_{reg}"][sel]) for reg in R.REGIONS]
            bp = ax.boxplot(vals, positions=x + off, widths=0.35, patch_artist=True, showfliers=False)
            for patch in bp["boxes"]:
                patch.set_facecolor(colours[name])
                patch.set_alpha(0.6)
        head = report["postures"][g]
        ax.set_xticks(x, [f"{reg}" for reg in R.REGIONS], fontsize=9)
        ax.set_xlim(-0.6, len(R.REGIONS) - 0.4)
        ax.set_ylabel("share of the image's load")
        ax.set_title(f"{g}: load share by region (orange real, blue simulated)", fontsize=10)
        ax.set_xlabel(f"head imprint: real {head['real']['head_imprint']['rate']:.0%}, simulated "
                      f"{head['simulated']['head_imprint']['rate']:.0%}", fontsize=10)
        profile = head.get("profile")
        if profile and profile["real"] and profile["simulated"]:
            ax = fig.add_subplot(row[6])
            for name in ("real", "simulated"):
                y = np.asarray(profile[name])
                ax.plot(y, 100 * profile["band"] * (np.arange(len(y)) + 0.5), color=colours[name], marker="o", ms=3,
                        label=name)
            ax.legend(fontsize=7)
            ax.invert_yaxis()
            ax.set_ylabel("below the head end, % of stature")
            ax.set_xlabel("% of the load per band")
            ax.set_title(f"{g}: load along the body", fontsize=10)
        imgs = outer[2 * gi + 1].subgridspec(1, 2 * examples + 1, wspace=0.08, width_ratios=[1] * 2 * examples + [0.08])
        im = None
        for j, (name, st, sel, ps) in enumerate((("real", rs, r_sel, real.pressure),
                                                 ("simulated", ss, s_sel, sim.pressure))):
            idx = np.flatnonzero(sel)
            pick = rng.choice(idx, size=min(examples, len(idx)), replace=False) if len(idx) else []
            for e, i in enumerate(pick):
                ax = fig.add_subplot(imgs[j * examples + e])
                im = ax.imshow(ps[i], vmin=0, vmax=vmax, cmap="viridis", aspect="equal")
                ax.set_title(f"{name} {g}\n{int(st['contact_taxels'][i])} taxels, head "
                             f"{'yes' if st['head_imprint'][i] else 'no'}", fontsize=8)
                ax.set_xticks([])
                ax.set_yticks([])
        if im is not None:
            # the scale ends at the 99th percentile of contact pressures: the few above it saturate
            fig.colorbar(im, cax=fig.add_subplot(imgs[-1]), label="mmHg", extend="max")
    fig.suptitle(f"{real.name} vs {sim.name} on the {sim.mat.name} mat (contact > {rule.contact_mmhg:g} mmHg)",
                 fontsize=12, y=0.999)
    save_figure_atomic(fig, path, dpi=90)
    plt.close(fig)
    return Path(path)


def _finite(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v[np.isfinite(v)]
