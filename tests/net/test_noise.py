import torch

from pressurepose.net.noise import NoiseConfig, add_noise

torch.set_num_threads(1)


def _clean(b=2000):
    x = torch.zeros(b, 16, 8)
    x[:, 2:14, 2:6] = 40.0  # 48 loaded taxels at 40 mmHg per image
    return x


def test_noise_statistics_over_many_draws():
    x = _clean()
    noisy, mask, sigma = add_noise(x, torch.Generator().manual_seed(1))
    on = mask.bool()
    assert torch.equal(mask, (x > 0).float())
    assert torch.all(noisy[~on] == 0)  # zero taxels stay zero
    assert noisy.min() >= 0 and noisy.max() <= 100
    vals = noisy[:, 2:14, 2:6].reshape(len(x), -1)
    # per-image factor: the image mean / 40 ~ N(1, 0.2) (the taxel noise averages out over 48)
    factor = vals.mean(1) / 40
    assert abs(float(factor.mean()) - 1) < 0.02
    assert abs(float(factor.std()) - 0.2) < 0.02
    # per-taxel additive noise about the image's own level: std 14
    resid = vals - vals.mean(1, keepdim=True)
    assert abs(float(resid.std()) * (48 / 47) ** 0.5 - 14) < 0.5
    assert abs(float(sigma.mean()) - 0.5) < 0.02 and abs(float(sigma.std()) - 0.2) < 0.02
    assert sigma.min() >= 0


def test_noise_is_seeded():
    x = _clean(8)
    a = add_noise(x, torch.Generator().manual_seed(3))
    b = add_noise(x, torch.Generator().manual_seed(3))
    c = add_noise(x, torch.Generator().manual_seed(4))
    assert all(torch.equal(u, v) for u, v in zip(a, b))
    assert not torch.equal(a[0], c[0])


def test_noise_config_zero_is_identity_and_clip_applies():
    x = _clean(4)
    quiet = NoiseConfig(mult_std=0, add_std=0, blur_std=0)
    noisy, _, sigma = add_noise(x, torch.Generator().manual_seed(0), quiet)
    assert torch.equal(noisy, x) and torch.all(sigma == 0.5)
    loud = NoiseConfig(mult_std=0, add_std=0, clip_max=30.0)
    assert add_noise(x, torch.Generator().manual_seed(0), loud)[0].max() == 30.0


def test_a_mat_shorter_than_the_body_cuts_images_at_the_foot_end():
    x = _clean(400)  # contact on rows 2..13
    paper = add_noise(x, torch.Generator().manual_seed(5))
    cut_cfg = NoiseConfig(cut_feet_p=0.5, cut_feet_rows=4)
    noisy, mask, sigma = add_noise(x, torch.Generator().manual_seed(5), cut_cfg)
    # the paper's noise is drawn first and unchanged; only whole rows at the foot end are dropped
    assert torch.equal(sigma, paper[2])
    kept = mask.amax(dim=2) > 0  # (B, R)
    last = torch.where(kept, torch.arange(16), torch.full((16,), -1)).amax(dim=1)
    cut = 13 - last  # rows lost per image
    assert set(cut.tolist()) == {0, 1, 2, 3, 4}
    assert abs(float((cut > 0).float().mean()) - 0.5) < 0.08
    for k in range(1, 5):  # 1..4 rows, evenly
        assert abs(float((cut == k).float().mean()) - 0.125) < 0.05
    rows_kept = kept[:, 2:14].sum(1)
    assert torch.equal(rows_kept, 12 - cut)  # contiguous from the head end: nothing else lost
    assert torch.equal(noisy * mask, noisy) and torch.equal(noisy[mask.bool()], paper[0][mask.bool()])
    # an image without contact is left alone
    empty = add_noise(torch.zeros(3, 16, 8), torch.Generator().manual_seed(0), NoiseConfig(cut_feet_p=1.0))
    assert torch.all(empty[0] == 0)
