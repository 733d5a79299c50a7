"""PressureNet's losses (paper section 4, equations 2 and 3).

L1 = (1 / (N sigma_s)) sum_j ||s_j - s^_j||_2 + (1 / (S sigma_beta)) ||beta - beta^||_1
L2 = L1 + (1 / (T sigma_Q^2)) ||Q - Q^||_2^2 + (1 / (T sigma_C)) ||C_O - C^_O||_1

with N = 24 joints, S = 10 betas, T taxels; each averaged over the batch. The sigmas are standard
deviations over the training set (:func:`dataset_scales`); the paper's values for the joints and
betas are the defaults. The squared Q term is divided by sigma_Q^2, not sigma_Q as printed in
equation 3: that is what the authors' code does (MSE x (1 / 44.46)^2 with Q in mm) and it makes the
term independent of Q's unit. C^_O is PMR's soft contact so the contact term has a gradient.

Not the paper's, off by default (``turn_weight`` 0): a turn term ``w (1 / 2) sum_k ||u_k - u^_k||_2``
over the body's two left-right axes k (right to left hip, right to left shoulder; u the unit
vector, so each term is 2 sin(angle / 2) of the angle between the true and the estimated axis). It
weighs the body's turn about its long axis apart from the joints' distances, which the joint term
counts in proportion to how far the joints move (:func:`turn_error`).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from pressurepose.net.model import ModuleOutput

PAPER_SIGMA_JOINTS_M = 0.17528
PAPER_SIGMA_BETAS = 1.72816


@dataclass(frozen=True)
class LossScales:
    """Standard deviations normalising each loss term: joints (m), betas, Q (its units), contact."""

    joints_m: float = PAPER_SIGMA_JOINTS_M
    betas: float = PAPER_SIGMA_BETAS
    q: float = 1.0
    contact: float = 1.0


def dataset_scales(joints: torch.Tensor, betas: torch.Tensor, q: torch.Tensor | None = None,
                   contact: torch.Tensor | None = None, paper_joints_betas: bool = False) -> LossScales:
    """Loss scales from training targets: joints (N, 24, 3) m, betas (N, 10), maps (N, R, C).

    sigma_s is the pooled standard deviation of the joint coordinates about each joint's mean
    position; sigma_beta that of all betas; sigma_Q and sigma_C those of all taxels of the maps.
    ``paper_joints_betas`` keeps the paper's sigma_s and sigma_beta.
    """
    def std(x):
        return float(x.double().std()) if x is not None and x.numel() > 1 else 1.0

    sj = float(torch.sqrt(((joints.double() - joints.double().mean(0)) ** 2).mean()))
    return LossScales(
        joints_m=PAPER_SIGMA_JOINTS_M if paper_joints_betas else max(sj, 1e-6),
        betas=PAPER_SIGMA_BETAS if paper_joints_betas else max(std(betas), 1e-6),
        q=max(std(q), 1e-6), contact=max(std(contact), 1e-6))


def joint_error(pred: torch.Tensor, true: torch.Tensor) -> torch.Tensor:
    """Per-sample mean Euclidean joint error (B,), metres; pred and true (B, J, 3)."""
    d2 = ((pred.float() - true.float()) ** 2).sum(-1)
    return torch.sqrt(d2 + 1e-12).mean(-1)


# SMPL joints (left, right) whose line is the body's left-right axis: hips, shoulders
TURN_PAIRS = ((1, 2), (16, 17))


def turn_error(pred: torch.Tensor, true: torch.Tensor) -> torch.Tensor:
    """Per-sample turn error (B,) of joints (B, 24, 3): the mean over :data:`TURN_PAIRS` of
    ``||u - u^||``, u the unit vector from the right joint to the left one (2 sin(angle / 2) of the
    angle between the true and the estimated axis: 0 to 2)."""
    def axes(j):
        v = torch.stack([j[:, a] - j[:, b] for a, b in TURN_PAIRS], 1)
        v = v.to(torch.promote_types(v.dtype, torch.float32))  # bf16 under autocast: float32
        return v / torch.sqrt((v * v).sum(-1, keepdim=True) + 1e-12)

    d = axes(pred) - axes(true)
    return torch.sqrt((d * d).sum(-1) + 1e-12).mean(-1)


def loss_l1(out: ModuleOutput, joints: torch.Tensor, betas: torch.Tensor,
            scales: LossScales = LossScales(), turn_weight: float = 0.0) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """L1 over a batch: joints (B, 24, 3) m and betas (B, 10) targets, plus ``turn_weight`` times the
    turn term (:func:`turn_error`; 0, the paper's, leaves it out). Returns (loss, detached parts)."""
    lj = joint_error(out.joints, joints).mean() / scales.joints_m
    lb = (out.params.betas.float() - betas.float()).abs().mean() / scales.betas
    parts = {"joints": lj.detach(), "betas": lb.detach()}
    loss = lj + lb
    if turn_weight:
        lt = turn_error(out.joints, joints).mean()
        loss = loss + turn_weight * lt
        parts["turn"] = lt.detach()
    return loss, parts


def loss_l2(out: ModuleOutput, joints: torch.Tensor, betas: torch.Tensor, q: torch.Tensor,
            contact: torch.Tensor, scales: LossScales,
            turn_weight: float = 0.0) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """L2 over a batch: L1 (with its turn term) plus the map terms against ground-truth maps q,
    contact (B, R, C)."""
    l1, parts = loss_l1(out, joints, betas, scales, turn_weight)
    lq = ((out.maps.q - q.float()) ** 2).mean() / scales.q ** 2
    lc = (out.maps.contact_soft - contact.float()).abs().mean() / scales.contact
    return l1 + lq + lc, {**parts, "q": lq.detach(), "contact": lc.detach()}
