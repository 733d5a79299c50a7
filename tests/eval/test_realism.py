"""Realism statistics on hand-made images with known answers, and the realism verb end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pressurepose.errors import BadInput
from pressurepose.eval import realism as R
from pressurepose.mat import MatSpec, get_mat
from tests.data.realfolders import write_labelled

MAT = get_mat("boditrak_bt3510")
SUPINE_ROOT = np.array([0.0, -np.pi / np.sqrt(2), -np.pi / np.sqrt(2)])  # pi about (0, -1, -1)/sqrt(2)


def body(head: bool = True, arms_up: bool = False) -> np.ndarray:
    """A supine footprint (64, 27) mmHg: head rows 2-7 (5 taxels wide, 20 mmHg), shoulders and
    back rows 10-19 (15 wide, 10 mmHg), pelvis and thighs rows 20-49 (11 wide, 15 mmHg), calves
    and heels rows 50-59 (9 wide, 8 mmHg)."""
    img = np.zeros((64, 27))
    if head:
        img[2:8, 11:16] = 20.0
    img[10:20, 6:21] = 10.0
    img[20:50, 8:19] = 15.0
    img[50:60, 9:18] = 8.0
    if arms_up:  # one forearm and hand raised above the head, far to the side
        img[0:6, 1:3] = 12.0
    return img


def test_contact_area_counts_taxels_over_threshold():
    img = np.zeros((64, 27))
    img[10:20, 5:10] = 6.0   # 50 over 5 mmHg
    img[30:32, 5:10] = 5.0   # exactly 5: not contact
    img[40, 0] = 100.0       # 1 more
    n, cm2 = R.contact_area(img, MAT)
    assert n.tolist() == [51]
    assert cm2[0] == pytest.approx(51 * 2.86 ** 2)


def test_region_shares_sum_to_one_and_follow_the_rule():
    img = body()
    shares = R.region_shares(img, MAT)[0]
    assert shares.sum() == pytest.approx(1.0)
    # extent rows 2..59 (58 rows from y = 2 to y = 60); head region 0 .. 0.13 of it: rows 2 .. 9.54
    a, b = 2.0, 60.0
    cut = a + 0.13 * (b - a)
    row_load = img.sum(1)
    head = row_load[:int(cut)].sum() + (cut - int(cut)) * row_load[int(cut)]
    assert shares[0] == pytest.approx(head / img.sum())
    # the heels region (0.93 .. 1 of the extent, rows 55.94 .. 60) holds the calves' 8 mmHg x 9 taxels rows
    heel = (60 - (a + 0.93 * (b - a))) * 9 * 8.0
    assert shares[-1] == pytest.approx(heel / img.sum())


def test_head_imprint_narrow_head_above_shoulders():
    imgs = np.stack([body(), body(head=False), body(arms_up=True), body(head=False, arms_up=True)])
    assert R.head_imprint(imgs, MAT).tolist() == [True, False, True, False]


def test_no_head_puts_the_head_end_a_head_length_above_the_shoulders():
    shares = R.region_shares(body(head=False), MAT)[0]
    assert shares[0] == 0.0
    assert shares.sum() == pytest.approx(1.0)
    ext = R.body_extent(body(head=False), MAT)[0]
    assert ext[1] == 60.0
    assert (10.0 - ext[0]) / (ext[1] - ext[0]) == pytest.approx(0.13)


def test_image_stats_pressures_and_off_mat():
    img = body()
    force = img * MAT.taxel_area_m2 * 133.322
    mass = force.sum() / 9.81 / 0.9  # 10 % of the weight off the mat
    s = R.image_stats(img[None], MAT, force_n=force[None], mass_kg=[mass])
    assert s["peak_mmhg"][0] == 20.0
    on = img > 5
    assert s["mean_mmhg"][0] == pytest.approx(img[on].mean())
    assert s["off_mat"][0] == pytest.approx(0.1)
    assert s["head_imprint"][0]
    empty = R.image_stats(np.zeros((1, 64, 27)), MAT)
    assert empty["contact_taxels"][0] == 0 and np.isnan(empty["share_head"][0]) and not empty["head_imprint"][0]


def test_summaries_and_distances():
    a = np.arange(1.0, 101.0)
    s = R.summarise({"x": a, "head_imprint": np.array([True, False, True, True])})
    assert s["x"]["median"] == 50.5 and s["x"]["q1"] == pytest.approx(25.75)
    assert s["head_imprint"]["rate"] == 0.75
    assert R.ks_statistic(a, a) == 0.0
    assert R.ks_statistic(a, a + 1000) == 1.0
    assert R.wasserstein(a, a + 3.0) == pytest.approx(3.0)
    d = R.compare({"contact_taxels": a * 2, "share_head": np.full(4, 0.1)},
                  {"contact_taxels": a, "share_head": np.full(4, 0.05)})
    assert d["contact_taxels"]["median_ratio"] == pytest.approx(2.0)
    assert d["share_head"]["mean_diff_pp"] == pytest.approx(5.0)


def test_bad_input_names_the_problem():
    with pytest.raises(BadInput, match="64 x 27"):
        R.image_stats(np.zeros((2, 10, 10)), MAT)
    with pytest.raises(BadInput, match="non-negative"):
        R.image_stats(-np.ones((1, 64, 27)), MAT)
    with pytest.raises(BadInput, match="bounds"):
        R.RegionRule(bounds=(0.5, 0.4, 0.6, 0.7, 0.8, 0.9))
    img = np.stack([body(), body()])
    with pytest.raises(BadInput, match=r"height_m of image 1 is nan \(1 of 2 not a positive number\)"):
        R.extent_ratio(img, MAT, [1.7, float("nan")])
    with pytest.raises(BadInput, match=r"height_m has shape \(1,\); expected \(2,\)"):
        R.load_profile(img, MAT, [1.7])


def test_realism_verb_end_to_end(tmp_path):
    from pressurepose.cli import main
    from pressurepose.eval.posture import posture_of

    rng = np.random.default_rng(0)
    real = np.stack([body() * rng.uniform(0.9, 1.1) for _ in range(4)] + [body(head=False)] * 2)
    write_labelled(tmp_path / "real", real, ["supine"] * 6, {"preset": "boditrak_bt3510", "units": "mmHg"})
    pose = np.zeros((3, 72))
    pose[:, :3] = SUPINE_ROOT
    assert set(posture_of(pose)) == {"supine"}
    sim = np.stack([body(), body(head=False), body()])
    force = sim * MAT.taxel_area_m2 * 133.322
    np.savez(tmp_path / "sim.npz", pressure=sim, force=force, pose=pose, mass=force.sum((1, 2)) / 9.81)
    out = tmp_path / "out"
    assert main(["realism", "--real", str(tmp_path / "real"), "--synthetic", str(tmp_path / "sim.npz"),
                 "--out", str(out)]) == 0
    rep = json.loads((out / "realism.json").read_text())
    sup = rep["postures"]["supine"]
    # the realism targets, judged on the headline: head imprint 2/3 < 0.8 is not met
    goals = {v["goal"]: v for v in rep["goals"] if v["posture"] == "supine"}
    assert goals["head imprint rate"]["value"] == pytest.approx(2 / 3) and not goals["head imprint rate"]["met"]
    assert goals["contact area ratio"]["value"] == pytest.approx(rep["headline"][0]["area_ratio"])
    assert sup["real"]["head_imprint"]["rate"] == pytest.approx(4 / 6)
    assert sup["simulated"]["head_imprint"]["rate"] == pytest.approx(2 / 3)
    assert sup["simulated"]["off_mat"]["median"] == pytest.approx(0.0, abs=1e-9)
    assert sum(sup["real"][f"share_{r}"]["mean"] for r in R.REGIONS) == pytest.approx(1.0)
    # per region, the median contact taxels and reading, as region_contact says of each image
    want = np.nanmedian(R.region_contact(sim, MAT), axis=0)
    assert list(sup["regions"]) == list(R.REGIONS)
    assert [sup["regions"][r]["taxels_sim"] for r in R.REGIONS] == pytest.approx(want[:, 0])
    assert [sup["regions"][r]["mmhg_sim"] for r in R.REGIONS] == pytest.approx(want[:, 1])
    assert sup["regions"]["heels"]["mmhg_real"] == pytest.approx(8.0, rel=0.15)
    assert (out / "realism.png").stat().st_size > 10_000
    # the real people's intervals: one person's images (no subject recorded: each image its own)
    ci = sup["real_interval"]
    assert set(ci) == set(R.HEADLINE_STATS)
    assert ci["head_imprint"][0] <= 4 / 6 <= ci["head_imprint"][1] and ci["head_imprint"][1] <= 1.0
    assert ci["contact_taxels"][0] <= sup["real"]["contact_taxels"]["median"] <= ci["contact_taxels"][1]
    assert rep["headline"][0]["real_interval"] == ci
    assert main(["realism", "--real", str(tmp_path / "real"), "--synthetic", str(tmp_path / "nope.npz"),
                 "--out", str(out)]) == 2
    # like postures: needs the simulated statures, then reports how the match went
    args = ["realism", "--real", str(tmp_path / "real"), "--synthetic", str(tmp_path / "sim.npz"), "--out", str(out),
            "--match-extent"]
    assert main(args) == 2
    np.savez(tmp_path / "sim.npz", pressure=sim, force=force, pose=pose, mass=force.sum((1, 2)) / 9.81,
             height=np.full(3, 1.75))
    assert main(args) == 0
    rep = json.loads((out / "realism.json").read_text())
    sup = rep["postures"]["supine"]
    m = sup["match"]
    assert m["coverage"] > 0 and m["distinct_sim_images"] >= 1
    assert rep["headline"][0]["n_sim"] == m["distinct_sim_images"]  # images, not draws of the resample
    assert set(sup["regions"]) == set(R.REGIONS)  # per region, over the matched resample
    # with both sets' statures known, the load along the body is reported too
    prof = sup["profile"]
    assert prof["band"] == R.PROFILE_BAND and len(prof["real"]) == len(prof["simulated"]) == 14
    assert 0 < sum(prof["simulated"]) <= 100 + 1e-9
    # a corrupt or NaN-holding .npz: a clear error naming it, no traceback
    (tmp_path / "half.npz").write_bytes((tmp_path / "sim.npz").read_bytes()[:500])
    np.savez(tmp_path / "nan.npz", pressure=np.full((1, 64, 27), np.nan), force=force[:1], pose=pose[:1],
             mass=np.ones(1))
    for bad, says in (("half.npz", "is corrupt|not a readable .npz"), ("nan.npz", "nan.npz: pressure holds NaN")):
        with pytest.raises(BadInput, match=says):
            from pressurepose.eval.realism_report import load_synthetic
            load_synthetic(tmp_path / bad)
        assert main(["realism", "--real", str(tmp_path / "real"), "--synthetic", str(tmp_path / bad),
                     "--out", str(out)]) == 2
    # only the wedge postures: this folder has none
    assert main(["realism", "--real", str(tmp_path / "real"), "--synthetic", str(tmp_path / "sim.npz"),
                 "--out", str(out), "--only-wedge"]) == 2


def test_load_synthetic_reads_a_dataset_directory(tmp_path):
    from pressurepose.data.schema import GenerationConfig, Sample
    from pressurepose.data.store import write_dataset
    from pressurepose.eval.realism_report import load_synthetic

    pose = np.zeros(72, np.float32)
    pose[:3] = SUPINE_ROOT
    imgs = [body(), body(head=False)]
    samples = [Sample(pressure=p.astype(np.float32), force=(p * MAT.taxel_area_m2 * 133.322).astype(np.float32),
                      depth=np.where(p > 0, -0.01, 1.0).astype(np.float32), contact=p > 0,
                      betas=np.zeros(10, np.float32), pose=pose, transl=np.zeros(3, np.float32),
                      joints=np.zeros((24, 3), np.float32), gender="f", mass=70.0, height=1.7,
                      partition="general_supine", index=i) for i, p in enumerate(imgs)]
    write_dataset(tmp_path / "ds", GenerationConfig("general_supine", "f", count=2, producer="synthetic"), samples)
    s = load_synthetic(tmp_path / "ds")
    assert s.mat == MAT and s.posture.tolist() == ["supine", "supine"]
    st = s.stats()
    assert st["head_imprint"].tolist() == [True, False]
    assert st["off_mat"] == pytest.approx(1 - np.array([p.sum() for p in imgs]) * MAT.taxel_area_m2 * 133.322
                                          / (70.0 * 9.81), rel=1e-3)


def test_match_by_follows_the_real_histogram_and_reports_coverage():
    """The resample's histogram follows the real one; bins with no simulated value are not covered."""
    sim = np.concatenate([np.full(80, 0.72), np.full(20, 0.97)])  # mostly short bodies
    real = np.concatenate([np.full(30, 0.73), np.full(70, 0.96)])  # mostly long ones
    idx, cov = R.match_by(sim, real, seed=1)
    assert cov == 1.0 and len(idx) == 100
    assert np.isclose(np.mean(sim[idx] > 0.9), 0.7, atol=0.02)
    idx2, _ = R.match_by(sim, real, seed=1)
    assert np.array_equal(idx, idx2)  # seeded
    _, cov = R.match_by(sim[:80], real, seed=1)  # no long simulated body: 70 % of the real mass uncovered
    assert np.isclose(cov, 0.3)
    with pytest.raises(BadInput):
        R.match_by(np.array([np.nan]), real)
    # more draws than values: the same histogram, and a mean over the resample that hardly depends on the draw
    idx, _ = R.match_by(sim, real, seed=1, draws=2000)
    assert len(idx) == 2000 and np.mean(sim[idx] > 0.9) == pytest.approx(0.7, abs=0.001)
    values = np.random.default_rng(0).normal(size=100) + np.where(sim > 0.9, 1.0, 0.0)
    spread = lambda draws: np.ptp([values[R.match_by(sim, real, seed=k, draws=draws)[0]].mean()  # noqa: E731
                                   for k in range(20)])
    assert spread(2000) < 0.5 * spread(100)
    with pytest.raises(BadInput, match="draws"):
        R.match_by(sim, real, draws=0)


def test_extent_ratio_is_extent_over_stature():
    mat = MatSpec("m", 64, 27, 0.0286, 0.0286, 100.0)
    img = np.zeros((1, 64, 27))
    img[0, 2:62, 10:17] = 20.0  # a body lying long, no head shape: the rule adds a head length
    ext = R.body_extent(img, mat)
    ratio = R.extent_ratio(img, mat, [1.75])
    assert np.isclose(ratio[0], (ext[0, 1] - ext[0, 0]) * 0.0286 / 1.75)
    with pytest.raises(BadInput):
        R.extent_ratio(img, mat, [0.0])


def test_share_gap_interval_covers_the_known_gap_and_widens_for_clustered_people():
    rng = np.random.default_rng(0)
    base = np.array([0.1, 0.2, 0.15, 0.25, 0.15, 0.1, 0.05])
    real = base + rng.normal(0, 0.02, (60, 7))
    sim = base + rng.normal(0, 0.02, (200, 7))
    sim[:, 3] += 0.10  # 10 pp more on the pelvis
    out = R.share_gap_interval(sim, real, n_boot=400)
    lo, hi = np.array(out["regions"]).T
    gap = 100 * (sim.mean(0) - real.mean(0))
    assert np.all((lo < gap) & (gap < hi))  # each interval holds its point estimate
    assert 8.5 < lo[3] and hi[3] < 11.5  # the known gap stands out
    assert np.all((lo[[0, 1, 2]] < 0.5) & (hi[[0, 1, 2]] > -0.5))
    assert out["worst"][0] > 8 and out["by"] == "image"
    # six people, ten images each, whose own shares differ: resampling people gives a wider interval
    people = np.repeat(np.arange(6), 10)
    real_p = real.copy()
    real_p[:, 3] += rng.normal(0, 0.04, 6)[people]
    by_image = np.diff(R.share_gap_interval(sim, real_p, n_boot=400)["regions"][3])[0]
    by_person = np.diff(R.share_gap_interval(sim, real_p, real_cluster=people, n_boot=400)["regions"][3])[0]
    assert by_person > 1.5 * by_image
    # a weight is a multiplicity: weights of 2 and 0 equal the duplicated and the dropped images
    w = np.r_[np.full(100, 2.0), np.zeros(100)]
    a = R.share_gap_interval(sim, real, sim_weight=w, n_boot=50, seed=1)
    b = R.share_gap_interval(sim[:100], real, n_boot=50, seed=1)
    assert a["regions"] == b["regions"]
    sim_nan = sim.copy()
    sim_nan[:5] = np.nan  # images without contact are left out
    assert np.isfinite(R.share_gap_interval(sim_nan, real, n_boot=20)["worst"]).all()
    with pytest.raises(BadInput):
        R.share_gap_interval(sim, real[:, :5])


def _column(first_row: int, rows: int, heavy_row: int) -> np.ndarray:
    """A narrow column of contact from ``first_row`` for ``rows`` rows, with most of its load on
    ``heavy_row``."""
    img = np.zeros((MAT.rows, MAT.cols))
    c = MAT.cols // 2
    img[first_row: first_row + rows, c - 1: c + 2] = 10.0
    img[heavy_row, c - 3: c + 4] = 200.0
    return img


def test_load_profile_puts_the_load_where_it_lies_below_the_head_end():
    height = MAT.rows * MAT.pitch_row_m  # the stature spans the mat, so a band of 5 % is 3.2 rows
    img = _column(4, 50, 4 + 13)  # the heavy row 13 rows (20 % of the stature) below the head end
    prof = R.load_profile(img, MAT, [height])
    assert prof.shape == (1, 14)
    assert np.argmax(prof[0]) == 4  # the 20-25 % band
    # the same body 6 rows further down the mat has the same profile
    np.testing.assert_allclose(R.load_profile(_column(10, 50, 10 + 13), MAT, [height]), prof)
    # a person half as tall: the same rows are twice the fraction of the stature
    assert np.argmax(R.load_profile(img, MAT, [height / 2])[0]) == 8
    # only load within the reach counts: here the rows beyond 70 % of the stature are left out
    assert prof.sum() == pytest.approx(100 * img[:4 + 45].sum() / img.sum())
    assert np.isnan(R.load_profile(np.zeros((MAT.rows, MAT.cols)), MAT, [1.7])).all()


def test_load_profile_refuses_bad_input():
    img = _column(4, 50, 17)
    with pytest.raises(BadInput, match="height_m"):
        R.load_profile(np.stack([img, img]), MAT, [1.7])
    with pytest.raises(BadInput, match="height_m"):
        R.load_profile(img, MAT, [0.0])
    with pytest.raises(BadInput, match="band"):
        R.load_profile(img, MAT, [1.7], band=0.8, reach=0.7)


def test_region_contact_counts_the_taxels_and_their_mean_reading_per_region():
    img = body()
    on = img > R.DEFAULT_RULE.contact_mmhg
    got = R.region_contact(img, MAT)[0]
    # the taxels add up to the contact area, and taxel-weighted means give back the mean over the contact
    assert got[:, 0].sum() == pytest.approx(on.sum())
    assert (got[:, 0] * got[:, 1]).sum() == pytest.approx(img[on].sum())
    # the heels region (rows 55.94 .. 60 of an extent 2 .. 60) holds 9 taxels of 8 mmHg a row
    a, b = 2.0, 60.0
    assert got[-1, 0] == pytest.approx((b - (a + 0.93 * (b - a))) * 9)
    assert got[-1, 1] == pytest.approx(8.0)
    assert np.isnan(R.region_contact(np.zeros((1, MAT.rows, MAT.cols)), MAT)).all()


def test_goal_verdicts_judge_each_goal_at_its_bounds():
    from pressurepose.eval.realism_report import goal_verdicts

    def row(area, head, worst, interval):
        return {"posture": "lateral", "area_ratio": area, "head_sim": head, "share_worst_pp": worst,
                "share_worst_pp_interval": interval}

    def met(rows):
        return [(v["goal"], v["met"]) for v in goal_verdicts(rows)]

    assert [m for _, m in met([row(0.8, 0.8, 5.0, (3.0, 7.0))])] == [True, True, True]  # bounds count as met
    assert [m for _, m in met([row(0.79, 0.79, 5.01, None)])] == [False, False, False]
    assert [m for _, m in met([row(1.21, 1.0, float("nan"), None)])] == [False, True, False]
    share = goal_verdicts([row(1.0, 1.0, 6.0, (4.8, 7.5))])[2]
    assert share["goal"].startswith("worst region share gap") and not share["met"]
    assert share["interval"] == [4.8, 7.5] and share["interval_holds_goal"]
    assert goal_verdicts([row(1.0, 1.0, 6.0, (5.2, 7.5))])[2]["interval_holds_goal"] is False
    assert goal_verdicts([row(1.0, 1.0, 4.0, None)])[2]["interval_holds_goal"] is None


def test_the_realism_figure_is_sized_by_the_images_there(tmp_path, monkeypatch):
    """Asking for more example images than a posture has draws a figure of the images there: its
    grid of examples has as many columns as the images (and the colour bar), not as asked."""
    import pressurepose.files as files
    from pressurepose.eval.realism_report import (
        draw_report,
        load_real,
        load_synthetic,
        realism_report,
    )

    write_labelled(tmp_path / "real", np.stack([body()] * 3), ["supine"] * 3,
                   {"preset": "boditrak_bt3510", "units": "mmHg"})
    pose = np.zeros((2, 72))
    pose[:, :3] = SUPINE_ROOT
    sim = np.stack([body(), body(head=False)])
    force = sim * MAT.taxel_area_m2 * 133.322
    np.savez(tmp_path / "sim.npz", pressure=sim, force=force, pose=pose, mass=force.sum((1, 2)) / 9.81)
    s = load_synthetic(tmp_path / "sim.npz")
    r = load_real(tmp_path / "real", s.mat)
    figures = []
    monkeypatch.setattr(files, "save_figure_atomic", lambda fig, path, **kw: figures.append(fig))
    draw_report(r, s, realism_report(r, s), tmp_path / "x.png", examples=40)
    image_axes = [ax for ax in figures[0].axes if ax.images]
    assert len(image_axes) == 3 + 2
    assert {ax.get_subplotspec().get_gridspec().ncols for ax in image_axes} == {2 * 3 + 1}


def test_real_intervals_are_tight_for_alike_people_and_widen_with_their_spread():
    n, people = 60, np.repeat(np.arange(6), 10)
    stats = {"contact_taxels": np.full(n, 400.0), "head_imprint": np.ones(n, bool), "mean_mmhg": np.full(n, 14.0),
             "peak_mmhg": np.full(n, 70.0), **{f"share_{r}": np.full(n, 1 / len(R.REGIONS)) for r in R.REGIONS}}
    same = R.real_intervals(stats, people, n_boot=100)
    assert same["contact_taxels"] == [400.0, 400.0] and same["head_imprint"] == [1.0, 1.0]
    assert same["share_pelvis"] == pytest.approx([1 / len(R.REGIONS)] * 2)
    # six people whose pelvis shares are 0.2 ... 0.3: the mean over resampled people stays inside
    # their range, and spans much of it
    spread = dict(stats, share_pelvis=np.linspace(0.2, 0.3, 6)[people])
    lo, hi = R.real_intervals(spread, people, n_boot=400)["share_pelvis"]
    assert 0.2 < lo < 0.25 < hi < 0.3 and hi - lo > 0.03
    # with each image counted on its own the same images look surer than resampling people says
    lo_i, hi_i = R.real_intervals(spread, None, n_boot=400)["share_pelvis"]
    assert hi_i - lo_i < 0.6 * (hi - lo)
    # NaN images (no contact) are left out; a statistic no image has is None
    gaps = dict(stats, mean_mmhg=np.full(n, np.nan))
    assert R.real_intervals(gaps, people, n_boot=20)["mean_mmhg"] is None
    with pytest.raises(BadInput):
        R.real_intervals(stats, people[:5], n_boot=20)
