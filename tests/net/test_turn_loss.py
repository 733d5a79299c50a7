"""The turn term of the loss (not the paper's; off by default): its value for known rotations, its
gradient, that weight 0 is the paper's loss exactly, and that training with it runs and resumes."""

import math

import numpy as np
import pytest
import torch

from pressurepose.errors import BadInput
from pressurepose.net.losses import TURN_PAIRS, loss_l1, turn_error
from pressurepose.net.train import train
from pressurepose.net.train_config import TrainConfig
from tests.net.synth import toy_body, toy_dataset
from tests.net.test_train import GRID

torch.set_num_threads(1)


def _joints(n: int = 3, seed: int = 0) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.randn(n, 24, 3, generator=g, dtype=torch.float64)


def _rotate_about_y(j: torch.Tensor, angle: float) -> torch.Tensor:
    """Turn every joint about the bed's long axis (y) through the origin."""
    c, s = math.cos(angle), math.sin(angle)
    r = torch.tensor([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]], dtype=j.dtype)
    return j @ r.T


def test_the_turn_error_is_the_chord_of_the_angle_between_the_axes():
    j = _joints()
    assert torch.allclose(turn_error(j, j), torch.zeros(3, dtype=j.dtype), atol=1e-5)
    for deg in (10.0, 45.0, 90.0, 180.0):
        a = math.radians(deg)
        # every axis turned by the same angle about y, when the axes lie across the bed (no y part)
        flat = j.clone()
        for left, right in TURN_PAIRS:
            flat[:, left, 1] = flat[:, right, 1]
        got = turn_error(_rotate_about_y(flat, a), flat)
        assert torch.allclose(got, torch.full((3,), 2 * math.sin(a / 2), dtype=got.dtype), atol=1e-5)
    # moving the whole body, or scaling it, leaves the axes' directions alone
    assert torch.allclose(turn_error(2.0 * j + 0.3, j), torch.zeros(3, dtype=j.dtype), atol=1e-5)


def test_the_turn_error_gradient_matches_finite_differences():
    j_true = _joints(2, seed=1)
    j = (j_true + 0.2 * _joints(2, seed=2)).requires_grad_(True)
    turn_error(j, j_true).sum().backward()
    eps = 1e-6
    for idx in [(0, 1, 0), (1, 16, 2), (0, 2, 1), (1, 5, 0)]:
        jp, jm = j.detach().clone(), j.detach().clone()
        jp[idx] += eps
        jm[idx] -= eps
        fd = (turn_error(jp, j_true).sum() - turn_error(jm, j_true).sum()) / (2 * eps)
        assert float(j.grad[idx]) == pytest.approx(float(fd), abs=1e-6)
    assert float(j.grad[:, 5].abs().max()) == 0.0  # joints off the axes get no gradient


class _Out:
    def __init__(self, joints, betas):
        self.joints = joints
        self.params = type("P", (), {"betas": betas})()


def test_weight_zero_is_the_papers_loss_and_a_weight_adds_the_term():
    j_true, betas = _joints(4, seed=3), torch.zeros(4, 10)
    out = _Out(j_true + 0.1 * _joints(4, seed=4), torch.ones(4, 10))
    paper, parts = loss_l1(out, j_true, betas)
    zero, parts0 = loss_l1(out, j_true, betas, turn_weight=0.0)
    assert torch.equal(paper, zero) and "turn" not in parts0
    two, parts2 = loss_l1(out, j_true, betas, turn_weight=2.0)
    assert float(two) == pytest.approx(float(paper) + 2.0 * float(turn_error(out.joints, j_true).mean()))
    assert float(parts2["turn"]) > 0


def test_training_with_the_turn_term_runs_and_checks_its_weight(tmp_path):
    data = toy_dataset(4, seed=5, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=2, epochs_mod2=1, batch_size=2, lr=1e-3, cnn="half", turn_loss=2.0)
    result = train(data, tmp_path, cfg, bodies=(body, body), grid=GRID)
    assert len(result.history) == 3 and all(np.isfinite(r["train_loss"]) for r in result.history)
    plain = train(data, tmp_path / "plain", TrainConfig(epochs_mod1=2, epochs_mod2=1, batch_size=2, lr=1e-3,
                                                        cnn="half"), bodies=(body, body), grid=GRID)
    assert result.history[0]["train_loss"] > plain.history[0]["train_loss"]  # the same step plus the term
    with pytest.raises(BadInput, match="turn_loss"):
        TrainConfig(turn_loss=-1.0)
