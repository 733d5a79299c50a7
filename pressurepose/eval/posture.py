"""Posture class and stature of an estimated body, for comparing estimates with real labels.

Posture: from the body's root orientation (its roll about its own long axis,
:mod:`pressurepose.pose.posture`): 'supine', 'left', 'right' or 'prone', where 'left' / 'right' is the
side the person lies on (left side down: roll +90 deg). A label 'lateral' (either side) matches
'left' or 'right'.

Stature: the standing height of the body's mesh at its betas with zero pose (the z-up model
standing, arms out), metres, as :meth:`pressurepose.body.BodyModel.height`; mass: that mesh's
volume x 1000 kg/m^3 (:meth:`pressurepose.body.BodyModel.mass`).
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.mesh import mesh_volume
from pressurepose.errors import BadInput
from pressurepose.pose.posture import posture_classes

CLASSES = ("supine", "left", "right", "prone")
DENSITY = 1000.0  # kg/m^3, as BodyModel.mass
_NAMES = {"supine": "supine", "left_lateral": "left", "right_lateral": "right", "prone": "prone"}


def posture_of(pose) -> np.ndarray:
    """(B,) class names ('supine', 'left', 'right', 'prone') of SMPL poses (B, 72)."""
    return np.array([_NAMES[str(c)] for c in posture_classes(np.atleast_2d(pose))])


def posture_correct(label, predicted) -> np.ndarray:
    """(N,) bool: the predicted class matches the label ('lateral' matches 'left' or 'right')."""
    lab, pred = np.asarray(label, dtype=str), np.asarray(predicted, dtype=str)
    return (lab == pred) | ((lab == "lateral") & np.isin(pred, ("left", "right")))


def confusion(labels, predicted) -> dict[str, dict[str, int]]:
    """{label: {predicted class: count}} over all labels present and the four classes."""
    lab, pred = np.asarray(labels, dtype=str), np.asarray(predicted, dtype=str)
    return {str(t): {c: int(np.sum((lab == t) & (pred == c))) for c in CLASSES} for t in sorted(set(lab.tolist()))}


def zero_pose_vertices(layer, betas) -> np.ndarray:
    """(B, V, 3) vertices of a body layer (``pressurepose.body.lbs_torch.BodyLayer``) at betas (B, S)
    with zero pose and translation: the standing z-up body."""
    import torch

    buf = next(layer.buffers())
    b = torch.as_tensor(np.atleast_2d(np.asarray(betas, dtype=np.float64)), dtype=buf.dtype, device=buf.device)
    with torch.no_grad():
        out = layer(betas=b)
    return out.vertices.detach().cpu().numpy().astype(np.float64)


def stature(verts) -> np.ndarray:
    """(B,) standing height (m): the z extent of zero-pose vertices (B, V, 3)."""
    v = np.asarray(verts, dtype=np.float64)
    if v.ndim != 3 or v.shape[-1] != 3:
        raise BadInput(f"vertices have shape {v.shape}; expected (B, V, 3)")
    return v[..., 2].max(-1) - v[..., 2].min(-1)


def mass(verts, faces) -> np.ndarray:
    """(B,) mass (kg) of closed zero-pose meshes (B, V, 3), faces (F, 3): volume x 1000 kg/m^3."""
    return DENSITY * mesh_volume(np.asarray(verts, dtype=np.float64), np.asarray(faces))


def body_stature_mass(net, betas, genders) -> tuple[np.ndarray, np.ndarray]:
    """Stature (m) and mass (kg), (B,) each, of a PressureNet's bodies at betas (B, 10) and genders
    (B,) 'f' / 'm' (its own female and male layers)."""
    from pressurepose.net.model import GENDER_CODES

    layers = net.body.layers
    betas = np.atleast_2d(np.asarray(betas, dtype=np.float64))
    codes = np.array([GENDER_CODES[str(g)] for g in genders])
    h, m = np.zeros(len(betas)), np.zeros(len(betas))
    faces = net.body.faces.cpu().numpy()
    for g in np.unique(codes):
        sel = codes == g
        v = zero_pose_vertices(layers[min(int(g), len(layers) - 1)], betas[sel])
        h[sel], m[sel] = stature(v), mass(v, faces)
    return h, m


def contact_iou(a, b) -> np.ndarray:
    """(N,) intersection over union of boolean maps (N, R, C); 1 where both are empty."""
    a, b = np.asarray(a, bool), np.asarray(b, bool)
    inter = (a & b).sum((-2, -1))
    union = (a | b).sum((-2, -1))
    return np.where(union > 0, inter / np.maximum(union, 1), 1.0)
