import torch

from pressurepose.net.noise import add_noise
from pressurepose.net.train_config import NoiseConfig

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
