import numpy as np
import pytest
import torch
from scipy import ndimage

from pressurepose.errors import BadInput
from pressurepose.net.transforms import (
    InputConfig,
    apply_floor,
    contact_map,
    gaussian_blur,
    input_channels,
    normalise_per_image,
    sobel_magnitude,
    upsample,
)

torch.set_num_threads(1)


def _images(b=3, h=64, w=27, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 50, (b, h, w)) * (rng.uniform(size=(b, h, w)) < 0.4)
    return torch.tensor(x)


def test_normalise_sums_to_one_and_keeps_zero_images():
    x = _images()
    x[1] = 0
    y = normalise_per_image(x)
    assert torch.allclose(y.sum((-2, -1))[[0, 2]], torch.ones(2, dtype=x.dtype))
    assert torch.all(y[1] == 0)
    assert torch.allclose(normalise_per_image(x, total=7.0).sum((-2, -1))[0], torch.tensor(7.0, dtype=x.dtype))
    # scale invariant: an image and 3x it normalise alike
    assert torch.allclose(normalise_per_image(3 * x[:1]), y[:1])


@pytest.mark.parametrize("sigma", [0.5, 1.3])
def test_blur_matches_scipy_and_keeps_total(sigma):
    x = _images()
    y = gaussian_blur(x, sigma)
    for i in range(x.shape[0]):
        ref = ndimage.gaussian_filter(x[i].numpy(), sigma, mode="reflect", truncate=4.0)
        np.testing.assert_allclose(y[i].numpy(), ref, atol=1e-10)
    np.testing.assert_allclose(y.sum((-2, -1)).numpy(), x.sum((-2, -1)).numpy(), rtol=1e-12)


def test_blur_per_image_sigma_and_identity():
    x = _images()
    sig = torch.tensor([0.0, 0.4, 1.1], dtype=x.dtype)
    y = gaussian_blur(x, sig)
    assert torch.equal(y[0], x[0])  # sigma 0: untouched
    for i in (1, 2):
        assert torch.allclose(y[i], gaussian_blur(x[i:i + 1], float(sig[i]))[0], atol=1e-9)
    assert torch.equal(gaussian_blur(x, 0.0), x)
    # one sigma for every image as a tensor, and an empty batch
    assert torch.allclose(gaussian_blur(x, torch.tensor(0.4, dtype=x.dtype)), gaussian_blur(x, 0.4), atol=1e-12)
    empty = torch.zeros(0, 6, 5, dtype=x.dtype)
    assert gaussian_blur(empty, torch.tensor(1.0)).shape == empty.shape


def test_sobel_of_a_step_edge():
    x = torch.zeros(1, 8, 10, dtype=torch.float64)
    x[..., 5:] = 1.0  # vertical step between columns 4 and 5
    e = sobel_magnitude(x)[0]
    # the [1 2 1] x [-1 0 1] kernel gives 4 on both columns next to a unit step, 0 elsewhere
    assert torch.allclose(e[:, 4], torch.full((8,), 4.0, dtype=x.dtype))
    assert torch.allclose(e[:, 5], torch.full((8,), 4.0, dtype=x.dtype))
    assert torch.all(e[:, [0, 1, 2, 3, 6, 7, 8, 9]] == 0)
    # and equals scipy on a random image
    r = _images(1)[0]
    ref = np.hypot(ndimage.sobel(r.numpy(), 0), ndimage.sobel(r.numpy(), 1))
    np.testing.assert_allclose(sobel_magnitude(r[None])[0].numpy(), ref, atol=1e-10)


def test_upsample_matches_scipy_zoom_order1():
    x = _images(2)
    y = upsample(x, 2)
    assert y.shape == (2, 128, 54)
    for i in range(2):
        np.testing.assert_allclose(y[i].numpy(), ndimage.zoom(x[i].numpy(), 2, order=1), atol=1e-9)
    assert upsample(x, 1) is x


def test_contact_map():
    x = torch.tensor([[[0.0, 2.0], [0.5, 0.0]]])
    assert torch.equal(contact_map(x), torch.tensor([[[0.0, 1.0], [1.0, 0.0]]]))


def test_input_channels_shapes_and_normalisation():
    x = _images(2).float()
    chans = input_channels(x)
    assert chans.shape == (2, 3, 128, 54)
    np.testing.assert_allclose(chans.sum((-2, -1)).numpy(), 128 * 54, rtol=1e-5)
    assert input_channels(x, InputConfig(edges_contact=False)).shape == (2, 1, 128, 54)
    dense = input_channels(_images(1, 192, 84).float(), InputConfig(upsample=1))
    assert dense.shape == (1, 3, 192, 84)
    # the contact channel is the (upsampled) mask of the raw image, not of the blurred one
    mask = contact_map(x)
    c = input_channels(x, contact=mask)[:, 2]
    assert torch.allclose(c, input_channels(x)[:, 2])


def test_contact_floor_drops_faint_readings_from_every_channel():
    x = _images(2).float()
    x = torch.where(x > 6.0, x, torch.zeros_like(x))  # a body: every reading above the floor
    faint = x + (x == 0) * torch.rand(x.shape, generator=torch.Generator().manual_seed(0)) * 5.0
    floor = InputConfig(contact_floor_mmhg=5.0)
    # with the floor, a faint background (<= 5 mmHg, as a real mat reads off the body) changes nothing
    assert torch.equal(input_channels(faint, floor), input_channels(x, floor))
    # without it (the paper's p > 0) the background becomes contact
    paper = InputConfig(upsample=1)
    share = {name: (input_channels(im, paper)[:, 2] > 0).float().mean() for name, im in (("faint", faint), ("body", x))}
    assert share["faint"] > share["body"] + 0.3
    # a reading just above the floor stays contact, one at it does not
    edge = torch.zeros(1, 64, 27)
    edge[0, 10, 10], edge[0, 20, 20] = 5.0, 5.5
    c = input_channels(edge, InputConfig(upsample=1, contact_floor_mmhg=5.0))[0, 2]
    assert c[10, 10] == 0 and c[20, 20] > 0
    assert torch.equal(apply_floor(edge, 0.0), edge)
    with pytest.raises(BadInput, match="contact_floor_mmhg"):
        InputConfig(contact_floor_mmhg=-1.0)
    with pytest.raises(BadInput, match="contact_floor_mmhg"):
        InputConfig(contact_floor_mmhg=float("nan"))
