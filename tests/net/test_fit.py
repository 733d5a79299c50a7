"""Fitting the estimated body to the image's print (pressurepose.net.fit): the loss terms have their
known values, a body moved off its print comes back, each image's fit ignores the rest of its batch,
and estimate / evaluate / the CLI verbs take it."""

import json

import numpy as np
import pytest
import torch

from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import gendered_body, save_model
from pressurepose.net.fit import FitConfig, fit_to_print, print_loss, taxel_centres
from pressurepose.net.infer import estimate
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import BodyParams, OutputConfig
from tests.net.synth import toy_body, toy_dataset

torch.set_num_threads(1)
GRID = custom_mat(rows=40, cols=20, pitch_row_m=0.05, pitch_col_m=0.05)


def test_the_print_term_is_the_squared_distance_to_the_nearest_vertex_at_or_below_the_top():
    loaded = torch.zeros(1, 40, 20, dtype=torch.bool)
    loaded[0, 10, 5] = True  # centre (0.275, 0.525)
    verts = torch.tensor([[[0.275, 0.525 + 0.03, -0.01],   # 3 cm along the bed, sunk: d^2 = 9e-4
                           [0.275, 0.525, 0.02],            # right over it but 2 cm above the top: 4e-4
                           [0.9, 1.9, -0.05]]], dtype=torch.float64)
    p, lift = print_loss(verts, loaded, GRID, FitConfig())
    assert float(p) == pytest.approx(4e-4)  # the nearest counts its height above the top
    # over taxels that read nothing the far vertex sinks 5 cm and the first 1 cm (it lies over row 11);
    # the second is above the top
    assert float(lift) == pytest.approx((0.05 ** 2 + 0.01 ** 2) / 3)
    far = torch.tensor([[[1.5, 0.1, 0.0]]], dtype=torch.float64)  # beyond the reach: clipped
    p, _ = print_loss(far, loaded, GRID, FitConfig(max_reach_m=0.1))
    assert float(p) == pytest.approx(0.1 ** 2)


def test_taxel_centres_follow_the_grid():
    c = taxel_centres(GRID)
    assert c.shape == (800, 2)
    np.testing.assert_allclose(c[0].numpy(), [0.025, 0.025])
    np.testing.assert_allclose(c[20 * 3 + 2].numpy(), [0.125, 0.175])  # row 3, column 2


@pytest.mark.parametrize("bad", [dict(steps=0), dict(lr=-1.0), dict(lr=float("nan")), dict(print_weight=-1.0),
                                 dict(search_vertices=2.5), dict(steps=True)])
def test_bad_settings_are_refused(bad):
    with pytest.raises(BadInput, match="fit"):
        FitConfig(**bad)


@pytest.fixture(scope="module")
def body():
    toy = toy_body()
    return gendered_body(toy, toy)


def _params(data, dx: float = 0.0) -> BodyParams:
    n = len(data["betas"])
    transl = data["transl"].clone()
    transl[:, 0] += dx
    return BodyParams(unconstrained=torch.zeros(n, 88), betas=data["betas"], transl=transl,
                      root_euler=torch.zeros(n, 3), global_orient=data["pose"][:, :3], body_pose=data["pose"][:, 3:])


def _sunk_print(body, data) -> torch.Tensor:
    """(B, R, C) 10 mmHg under every vertex of the true bodies that lies below the mattress top, 0
    elsewhere: a print with sharp edges."""
    verts, _ = body(_params(data), data["gender"])
    out = torch.zeros(len(verts), GRID.rows, GRID.cols)
    for b, v in enumerate(verts):
        col, row = (v[:, 0] / GRID.pitch_col_m).long(), (v[:, 1] / GRID.pitch_row_m).long()
        keep = (v[:, 2] < 0) & (col >= 0) & (col < GRID.cols) & (row >= 0) & (row < GRID.rows)
        out[b, row[keep], col[keep]] = 10.0
    return out


def test_a_body_moved_off_its_print_comes_back(body):
    data = toy_dataset(3, seed=4, grid=GRID)
    pressure = _sunk_print(body, data)
    moved = _params(data, dx=0.06)  # 6 cm across the bed, more than a taxel
    # joints held by a stiff prior, translation free: the body slides back onto its print
    rigid = FitConfig(steps=60, lr=0.01, pose_prior=100.0, transl_prior=0.0)
    fitted = fit_to_print(body, moved, data["gender"], pressure, GRID, 0.0, rigid)
    before = (moved.transl[:, 0] - data["transl"][:, 0]).abs()
    after = (fitted.transl[:, 0] - data["transl"][:, 0]).abs()
    assert torch.all(after < 0.3 * before), (before, after)
    # a body already on its print stays close to where it lies across the bed and along it (the print
    # pins no depth: with no translation prior the body may sink or rise a little)
    still = fit_to_print(body, _params(data), data["gender"], pressure, GRID, 0.0, rigid)
    assert float((still.transl - data["transl"])[:, :2].abs().max()) < 0.015
    # with the default settings the joints move too; the print and lift terms fall
    free = fit_to_print(body, moved, data["gender"], pressure, GRID, 0.0)
    loaded = pressure > 0

    def terms(p):
        verts, _ = body(p, data["gender"])
        a, b = print_loss(verts, loaded, GRID, FitConfig())
        return 100 * a + 100 * b

    assert torch.all(terms(free) < 0.5 * terms(moved)), (terms(moved), terms(free))
    torch.testing.assert_close(fitted.betas, data["betas"])  # the shape is the network's


def test_each_image_is_fitted_as_if_alone(body):
    data = toy_dataset(3, seed=5, grid=GRID)
    params = _params(data, dx=0.04)
    config = FitConfig(steps=10)
    together = fit_to_print(body, params, data["gender"], data["pressure"], GRID, 0.0, config)
    one = BodyParams(**{k: v[1:2] for k, v in vars(params).items()})
    alone = fit_to_print(body, one, data["gender"][1:2], data["pressure"][1:2], GRID, 0.0, config)
    torch.testing.assert_close(together.body_pose[1:2], alone.body_pose, atol=1e-5, rtol=0)
    torch.testing.assert_close(together.transl[1:2], alone.transl, atol=1e-6, rtol=0)


def test_a_wrong_pressure_shape_is_refused(body):
    data = toy_dataset(2, grid=GRID)
    with pytest.raises(BadInput, match="expected \\(2, 40, 20\\)"):
        fit_to_print(body, _params(data), data["gender"], data["pressure"][:, :10], GRID, 0.0)


def test_estimate_evaluate_and_the_verbs_take_fit(body, tmp_path):
    torch.manual_seed(0)
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1)))
    net = PressureNet(cfg, body).eval()
    path = save_model(tmp_path / "m.safetensors", net, (toy_body(), toy_body()))
    data = toy_dataset(2, grid=GRID)
    x = data["pressure"].numpy()
    plain = estimate(x, "f", model=path)
    fitted = estimate(x, "f", model=path, fit=FitConfig(steps=5))
    assert fitted.fitted and not plain.fitted
    assert not np.allclose(fitted.joints, plain.joints)
    np.testing.assert_allclose(fitted.betas, plain.betas)
    with pytest.raises(BadInput, match="fit is 'yes'"):
        estimate(x, "f", model=path, fit="yes")
    np.save(tmp_path / "p.npy", x)
    assert main(["infer", str(tmp_path / "p.npy"), "--gender", "f", "--model", str(path), "--out",
                 str(tmp_path / "e"), "--fit", "--max-figures", "0"]) == 0
    assert json.loads((tmp_path / "e" / "estimate.json").read_text())["fitted_to_print"] is True
    got = np.load(tmp_path / "e" / "estimate.npz")["joints"]
    np.testing.assert_allclose(got, estimate(x, "f", model=path, fit=True).joints, atol=1e-5)
