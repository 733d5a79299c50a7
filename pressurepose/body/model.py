"""``BodyModel``: the user-facing body model (open default or a user's SMPL file).

>>> body = BodyModel("female")                       # shipped open model (MakeHuman-derived)
>>> body = BodyModel("/path/to/SMPL_FEMALE.pkl")      # a licensed SMPL file
>>> verts, joints = body.forward(betas, pose, transl) # numpy, (B, V, 3) and (B, 24, 3)
>>> layer = body.torch_layer(dtype=torch.float64)     # differentiable, same numbers
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from pressurepose.body import lbs_numpy
from pressurepose.body.mesh import mesh_volume
from pressurepose.body.smpl_io import SmplArrays, load_body_arrays
from pressurepose.errors import BadInput

GENDERS = ("female", "male", "neutral")
_ALIASES = {"f": "female", "m": "male", "n": "neutral", "female": "female", "male": "male",
            "neutral": "neutral"}


def canonical_gender(gender: str) -> str:
    """'f' / 'female' -> 'female' etc.; BadInput for anything else."""
    g = _ALIASES.get(str(gender).strip().lower())
    if g is None:
        raise BadInput(f"gender {gender!r} is not known; expected one of f, m, n (female, male, neutral)")
    return g


def asset_path(name: str) -> Path:
    """Path of a shipped asset file in ``pressurepose/body/assets``."""
    return Path(str(resources.files("pressurepose.body") / "assets" / name))


@lru_cache(maxsize=8)
def _load_cached(path: str, mtime: float) -> SmplArrays:
    return load_body_arrays(path)


def resolve_model_path(spec: str | Path) -> Path:
    """Turn 'female' / 'm' / a file path into the path of an SMPL-format file."""
    s = str(spec)
    if s.strip().lower() in _ALIASES:
        g = canonical_gender(s)
        p = asset_path(f"{g}.npz")
        if not p.is_file():
            raise BadInput(f"the shipped {g} body model is missing ({p}); rebuild it with "
                           f"`python tools/bake_body_model.py` (needs the [bake] extra)")
        return p
    p = Path(s).expanduser()
    if not p.is_file():
        raise BadInput(f"body model {s!r} is neither a gender (f, m, n) nor an existing .npz/.pkl file")
    return p


class BodyModel:
    """An SMPL-format body model: 24 joints, metres, z up.

    Parameters
    ----------
    spec: 'female' | 'male' | 'neutral' (or f/m/n) for the shipped open models, the path of
        an SMPL-format ``.npz`` or official SMPL ``.pkl``, or :class:`SmplArrays` already in memory
        (e.g. ``pressurepose.body.toy.toy_body_arrays()``).
    """

    def __init__(self, spec: str | Path | SmplArrays = "neutral"):
        if isinstance(spec, SmplArrays):
            self.path = Path(str(spec.meta.get("source", "arrays")))
            self.arrays = spec
        else:
            path = resolve_model_path(spec)
            self.path = path
            self.arrays = _load_cached(str(path), path.stat().st_mtime)
        g = self.arrays.meta.get("gender")
        self.gender = canonical_gender(g) if g in _ALIASES else (
            canonical_gender(spec) if str(spec).lower() in _ALIASES else "neutral")

    def __repr__(self) -> str:
        return (f"BodyModel({self.gender}, {self.num_vertices} vertices, {self.num_joints} joints, "
                f"{self.num_betas} betas, source={self.arrays.meta.get('source', self.path.name)!r})")

    # ---------------------------------------------------------------- sizes
    @property
    def num_vertices(self) -> int:
        return self.arrays.num_vertices

    @property
    def num_joints(self) -> int:
        return self.arrays.num_joints

    @property
    def num_betas(self) -> int:
        return self.arrays.num_betas

    @property
    def faces(self) -> np.ndarray:
        """(F, 3) int64 triangle indices."""
        return self.arrays.faces

    @property
    def parents(self) -> np.ndarray:
        return self.arrays.parents

    @property
    def identity(self) -> str:
        """A short string that identifies this model (for checkpoints and manifests)."""
        import hashlib

        h = hashlib.sha256(self.arrays.v_template.astype(np.float32).tobytes())
        h.update(self.arrays.shapedirs.astype(np.float32).tobytes())
        return f"{self.gender}:{self.num_vertices}v:{h.hexdigest()[:16]}"

    # ---------------------------------------------------------------- checks
    def check_params(self, betas, pose, transl=None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Validate and batch parameters; BadInput naming the bad one."""
        betas = np.asarray(betas, dtype=np.float64)
        pose = np.asarray(pose, dtype=np.float64)
        if betas.ndim == 1:
            betas = betas[None]
        if pose.ndim == 1:
            pose = pose[None]
        if betas.ndim != 2 or betas.shape[1] > self.num_betas:
            raise BadInput(f"betas has shape {betas.shape}; expected (B, S) with S <= {self.num_betas}")
        n_pose = 3 * self.num_joints
        if pose.ndim != 2 or pose.shape[1] != n_pose:
            raise BadInput(f"pose has shape {pose.shape}; expected (B, {n_pose}) axis-angle "
                           f"(global orientation first)")
        if betas.shape[0] != pose.shape[0]:
            raise BadInput(f"betas batch {betas.shape[0]} != pose batch {pose.shape[0]}")
        if transl is not None:
            transl = np.asarray(transl, dtype=np.float64)
            if transl.ndim == 1:
                transl = transl[None]
            if transl.shape != (pose.shape[0], 3):
                raise BadInput(f"transl has shape {transl.shape}; expected ({pose.shape[0]}, 3)")
        for name, arr in (("betas", betas), ("pose", pose), ("transl", transl)):
            if arr is not None and not np.all(np.isfinite(arr)):
                raise BadInput(f"{name} contains NaN or infinite values")
        return betas, pose, transl

    # ---------------------------------------------------------------- forward
    def forward(self, betas, pose, transl=None) -> tuple[np.ndarray, np.ndarray]:
        """Numpy forward pass. betas (B, S), pose (B, 72), transl (B, 3) or None.

        Returns vertices (B, V, 3) and joints (B, 24, 3), metres. 1-D inputs are a batch of one.
        """
        betas, pose, transl = self.check_params(betas, pose, transl)
        return lbs_numpy.forward(self.arrays, betas, pose, transl)

    def rest(self, betas) -> tuple[np.ndarray, np.ndarray]:
        """Shaped T-pose vertices (B, V, 3) and joints (B, 24, 3)."""
        betas, _, _ = self.check_params(betas, np.zeros((np.atleast_2d(betas).shape[0], 3 * self.num_joints)))
        return lbs_numpy.rest_joints(self.arrays, betas)

    def torch_layer(self, device=None, dtype=None):
        """The differentiable torch layer for this model (see :class:`BodyLayer`)."""
        import torch

        from pressurepose.body.lbs_torch import BodyLayer

        layer = BodyLayer(self.arrays, dtype=dtype or torch.float32)
        return layer.to(device) if device is not None else layer

    # ---------------------------------------------------------------- physical
    def volume(self, betas, pose=None) -> np.ndarray:
        """Enclosed volume (B,) in m^3 of the posed (default rest) mesh, by the divergence theorem."""
        betas = np.atleast_2d(np.asarray(betas, dtype=np.float64))
        if pose is None:
            pose = np.zeros((betas.shape[0], 3 * self.num_joints))
        verts, _ = self.forward(betas, pose)
        return mesh_volume(verts, self.faces)

    def mass(self, betas, density: float = 1000.0) -> np.ndarray:
        """Body mass (B,) in kg as rest volume x density (default 1000 kg/m^3)."""
        return density * self.volume(betas)

    def height(self, betas) -> np.ndarray:
        """Standing height (B,) in metres: z extent of the rest mesh."""
        v, _ = self.rest(betas)
        return v[..., 2].max(-1) - v[..., 2].min(-1)

