"""Body shape and placement on the bed: the default (people as they lie) and the paper's options."""

import numpy as np
import pytest
from scipy import stats

from pressurepose.errors import BadInput
from pressurepose.pose import SamplerConfig, sample_bodies
from pressurepose.pose.config import DEFAULT_MATTRESS, paper_sampler
from pressurepose.pose.root import draw_betas, truncated_normal

LIMB_JOINTS = [4, 5, 7, 8, 10, 11, 18, 19, 20, 21, 22, 23]


def test_default_shapes_are_smpls_population_truncated():
    rng = np.random.default_rng(0)
    b = np.concatenate([draw_betas(rng, SamplerConfig(), 10) for _ in range(300)])
    assert np.abs(b).max() <= 3.0
    assert stats.kstest(b, stats.truncnorm(-3, 3).cdf).pvalue > 1e-3
    u = np.concatenate([draw_betas(rng, paper_sampler(), 10) for _ in range(300)])
    assert stats.kstest((u + 3) / 6, "uniform").pvalue > 1e-3
    assert truncated_normal(rng, 0.0, 1.0) == 0.0


def test_extreme_shapes_are_rare_by_default(female):
    """BMI under 17 or over 35 (from the body model's own mass and stature): a sixth of the paper's
    uniform shapes, a few percent of the default's."""
    rng = np.random.default_rng(1)

    def extreme_share(cfg):
        betas = np.stack([draw_betas(rng, cfg, 10) for _ in range(300)])
        bmi = female.mass(betas) / female.height(betas) ** 2
        return np.mean((bmi < 17) | (bmi > 35))

    assert extreme_share(paper_sampler()) > 0.12
    assert extreme_share(SamplerConfig()) < 0.06


@pytest.fixture(scope="module")
def centred(female):
    return sample_bodies("general_supine", "f", 80, 5, body=female)


def test_default_placement_centres_the_body_with_the_head_at_the_top(female, centred):
    b = centred
    x0, x1, y0, _ = DEFAULT_MATTRESS
    across = b.joints[:, 0, 0] - (x0 + x1) / 2
    assert abs(across.mean()) < 0.015 and 0.015 < across.std() < 0.05
    assert np.abs(b.yaw).max() <= np.pi / 6 and 0.06 < b.yaw.std() < 0.15
    verts, _ = female.forward(b.betas, b.pose, b.transl)
    head = np.asarray(female.arrays.weights).argmax(1) == 15
    crown = verts[:, head, 1].min(1) - y0  # from the mattress's head end
    assert abs(np.median(crown) - SamplerConfig().head_gap_m) < 0.025 and crown.std() < 0.07  # slid for raised arms


def test_default_limbs_start_over_the_mattress_clear_of_its_sides(centred):
    x0, x1, y0, y1 = DEFAULT_MATTRESS
    m = SamplerConfig().side_margin_m
    p = centred.joints[:, LIMB_JOINTS, :2]
    assert np.all((p[..., 0] >= x0 + m) & (p[..., 0] <= x1 - m) & (p[..., 1] >= y0) & (p[..., 1] <= y1))


def test_arms_above_the_head_slide_the_body_down_the_bed(female):
    """prone_hands_up: the hands, not the crown, keep head_gap_m from the head end (as far as the
    foot end allows)."""
    b = sample_bodies("prone_hands_up", "f", 30, 8, body=female)
    _, _, y0, y1 = DEFAULT_MATTRESS
    gap = SamplerConfig().head_gap_m
    top, bottom = b.joints[:, :, 1].min(1), b.joints[:, :, 1].max(1)
    assert np.all((top >= y0 + gap - 1e-9) | (bottom >= y1 - 0.05 - 1e-9))
    assert np.median(top - y0) < gap + 0.03  # slid no further than needed


def test_paper_placement_is_uniform_about_the_mattress_centre(female):
    b = sample_bodies("general_supine", "f", 60, 6, body=female, config=paper_sampler())
    x0, x1, y0, y1 = DEFAULT_MATTRESS
    off = b.joints[:, 0, :2] - [(x0 + x1) / 2, (y0 + y1) / 2]
    assert np.all(np.abs(off) <= 0.2 + 1e-9) and off.std(0).min() > 0.08  # U(-0.2, 0.2): sd 0.115
    assert b.yaw.std() > 0.2


@pytest.mark.parametrize("field,value", [("placement", "middle"), ("shapes", "gauss"), ("hanging_limbs", "no"),
                                         ("across_sd_m", -0.1), ("beta_sd", float("nan"))])
def test_bad_settings_are_named(field, value):
    with pytest.raises(BadInput, match=field):
        SamplerConfig(**{field: value})


def test_lateral_bodies_spread_wider_across_the_bed():
    """The across-bed sd follows the roll: across_sd_m supine or prone, across_sd_lateral_m on the
    side (real lateral people lie 8-9 cm (sd) about their mean, supine ones 1.5 cm)."""
    from pressurepose.pose.root import draw_placement

    cfg = SamplerConfig()
    centre = cfg.mattress_centre[0]
    for roll, sd in ((0.0, cfg.across_sd_m), (np.pi / 2, cfg.across_sd_lateral_m), (np.pi, cfg.across_sd_m),
                     (np.pi / 4, np.hypot(cfg.across_sd_m, cfg.across_sd_lateral_m) / np.sqrt(2))):
        rng = np.random.default_rng(1)
        x = np.array([draw_placement(rng, cfg, 0.9, roll)[1][0] for _ in range(4000)]) - centre
        assert abs(x.std() - sd) < 0.05 * sd, (roll, x.std(), sd)
    with pytest.raises(BadInput, match="across_sd_lateral_m"):
        SamplerConfig(across_sd_lateral_m=-0.01)


def test_fuller_collision_capsules_reject_more_arms_across_the_chest(female):
    """collision_radius_scale widens the capsules of the self-collision tests only (the
    public sampler's capsules are fuller than ours): more candidates are rejected for collisions and
    fewer wrists end over the chest, with the same seed."""
    from benchmarks.bench_sampler_fidelity import geometry_shares

    runs = {s: sample_bodies("general_supine", "f", 120, 3, body=female, config=paper_sampler(collision_radius_scale=s))
            for s in (1.0, 1.4)}
    def collisions(b):
        return b.rejections["self_collision"] + b.rejections["limb_collision"]

    assert collisions(runs[1.4]) > collisions(runs[1.0])
    shares = {s: geometry_shares(b.pose, female)["medial_wrists"] for s, b in runs.items()}
    assert shares[1.4] < shares[1.0], shares
    with pytest.raises(BadInput, match="collision_radius_scale"):
        SamplerConfig(collision_radius_scale=0.0)
