"""Reading and writing body models in SMPL format, safely.

A body model is a handful of arrays (SMPL names and layout):

=============== ============ ==============================================
key             shape        meaning
=============== ============ ==============================================
``v_template``  V x 3        rest-pose vertices of the mean shape, metres
``shapedirs``   V x 3 x S    shape blend shapes (one per beta)
``posedirs``    V x 3 x P    pose blend shapes, P = 9 (J - 1)
``J_regressor`` J x V        joints as weighted sums of vertices
``weights``     V x J        linear-blend-skinning weights
``kintree_table`` 2 x J      row 0: parent of each joint (root: -1 or 2^32-1)
``f``           F x 3        triangle faces (vertex indices)
=============== ============ ==============================================

Arrays are in SMPL's own y-up model frame; an ``.npz`` holding an ``up_axis='z'`` string entry is
re-expressed in that frame on load. ``.npz`` files are read with ``allow_pickle=False``. Official SMPL ``.pkl`` files hold chumpy
objects and a scipy sparse matrix; they are read by :class:`RestrictedUnpickler`, which maps those
classes to inert stand-ins and refuses every other class, so a crafted pickle cannot run code.
"""

from __future__ import annotations

import io
import pickle
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pressurepose.errors import BadInput
from pressurepose.files import load_npz, save_npz_atomic

REQUIRED_KEYS = ("v_template", "shapedirs", "posedirs", "J_regressor", "weights", "kintree_table", "f")


@dataclass(frozen=True, eq=False)
class SmplArrays:
    """The arrays of an SMPL-format body model (float64 geometry, int64 topology).

    Attributes are as in the module docstring; ``parents`` is ``kintree_table[0]`` with -1 for the
    root; ``meta`` holds optional extra strings (``gender``, ``source``, ``joint_names``...).
    """

    v_template: np.ndarray
    shapedirs: np.ndarray
    posedirs: np.ndarray
    J_regressor: np.ndarray
    weights: np.ndarray
    parents: np.ndarray
    faces: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def num_vertices(self) -> int:
        return self.v_template.shape[0]

    @property
    def num_joints(self) -> int:
        return self.J_regressor.shape[0]

    @property
    def num_betas(self) -> int:
        return self.shapedirs.shape[2]


# --------------------------------------------------------------------------- restricted unpickling


class _ChumpyStandIn:
    """Takes the place of any chumpy object: keeps its state, never runs chumpy code."""

    def __setstate__(self, state):
        self.__dict__["_state"] = state

    def to_array(self) -> np.ndarray:
        state = self.__dict__.get("_state")
        if isinstance(state, dict):
            for key in ("x", "a", "r"):
                if key in state and isinstance(state[key], (np.ndarray, list, tuple, float, int)):
                    return np.asarray(state[key])
        raise BadInput("SMPL pickle: a chumpy object has no array value ('x') to read")


class _SparseStandIn:
    """Takes the place of a scipy.sparse csc/csr matrix; converts to a dense array."""

    def __setstate__(self, state):
        self.__dict__["_state"] = state

    def to_array(self) -> np.ndarray:
        st = self.__dict__.get("_state", {})
        try:
            shape = tuple(int(s) for s in st.get("_shape", st.get("shape")))
            data, indices, indptr = (np.asarray(st[k]) for k in ("data", "indices", "indptr"))
        except (KeyError, TypeError) as exc:
            raise BadInput(f"SMPL pickle: a sparse matrix lacks {exc}") from None
        fmt = st.get("_kind", "csc")
        dense = np.zeros(shape, dtype=np.float64)
        major = shape[1] if fmt == "csc" else shape[0]
        if len(indptr) != major + 1:
            raise BadInput("SMPL pickle: sparse matrix index pointer does not match its shape")
        for j in range(major):
            sl = slice(indptr[j], indptr[j + 1])
            if fmt == "csc":
                dense[indices[sl], j] = data[sl]
            else:
                dense[j, indices[sl]] = data[sl]
        return dense


class _CsrStandIn(_SparseStandIn):
    def __setstate__(self, state):
        super().__setstate__(dict(state, _kind="csr"))


def _latin1_encode(text, encoding="latin1"):
    """The only codec use a pickle of arrays needs: str -> bytes; no other codec is reachable."""
    if not isinstance(text, str) or encoding not in ("latin1", "latin-1"):
        raise pickle.UnpicklingError(f"refusing codec {encoding!r}")
    return text.encode("latin1")


def _reconstruct(cls, base, state):
    """Stand-in for copyreg._reconstructor that only ever builds our own inert classes."""
    if cls not in (_ChumpyStandIn, _SparseStandIn, _CsrStandIn):
        raise pickle.UnpicklingError(f"refusing to reconstruct {cls!r}")
    return cls.__new__(cls)


_NUMPY_ALLOWED = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
}


_SAFE_BUILTINS = {"object": object, "set": set, "frozenset": frozenset}  # chumpy state holds sets


class RestrictedUnpickler(pickle.Unpickler):
    """An unpickler for SMPL-style files that allows numpy arrays and nothing executable.

    chumpy classes become :class:`_ChumpyStandIn`, scipy sparse matrices :class:`_SparseStandIn`;
    any other global raises :class:`pickle.UnpicklingError`.
    """

    def find_class(self, module: str, name: str):
        if (module, name) in _NUMPY_ALLOWED:
            return getattr(np, name) if module == "numpy" else _numpy_global(name)
        if module.split(".")[0] == "chumpy":
            return _ChumpyStandIn
        if module.startswith("scipy.sparse"):
            if name == "csc_matrix":
                return _SparseStandIn
            if name == "csr_matrix":
                return _CsrStandIn
        if (module, name) in {("copy_reg", "_reconstructor"), ("copyreg", "_reconstructor")}:
            return _reconstruct
        if module in ("__builtin__", "builtins") and name in _SAFE_BUILTINS:
            return _SAFE_BUILTINS[name]
        if (module, name) == ("_codecs", "encode"):  # bytes inside protocol-2 pickles written by Python 3
            return _latin1_encode
        raise pickle.UnpicklingError(f"refusing to load global {module}.{name} from a pickle")


def _numpy_global(name: str):
    if name == "_reconstruct":
        try:
            from numpy._core.multiarray import _reconstruct as r
        except ImportError:  # numpy < 2
            from numpy.core.multiarray import _reconstruct as r
        return r
    if name == "scalar":
        try:
            from numpy._core.multiarray import scalar as s
        except ImportError:
            from numpy.core.multiarray import scalar as s
        return s
    raise pickle.UnpicklingError(name)


def safe_pickle_load(data: bytes | io.BufferedIOBase, *, what: str = "pickle"):
    """Unpickle bytes or a binary file with :class:`RestrictedUnpickler` (Python 2 pickles too)."""
    fh = io.BytesIO(data) if isinstance(data, (bytes, bytearray)) else data
    try:
        return RestrictedUnpickler(fh, encoding="latin1").load()
    except pickle.UnpicklingError as exc:
        raise BadInput(f"{what}: unsafe or unreadable pickle ({exc})") from None
    except (EOFError, ValueError, TypeError, AttributeError, IndexError, KeyError) as exc:
        raise BadInput(f"{what}: corrupt or truncated pickle ({type(exc).__name__}: {exc})") from None


def _to_array(value) -> np.ndarray:
    if isinstance(value, (_ChumpyStandIn, _SparseStandIn)):
        return value.to_array()
    return np.asarray(value)


# --------------------------------------------------------------------------------- load and save


def arrays_from_dict(raw: dict, *, source: str = "body model") -> SmplArrays:
    """Validate a dict of SMPL-format arrays and return :class:`SmplArrays`.

    Raises BadInput naming the missing key or the array with the wrong shape.
    """
    missing = [k for k in REQUIRED_KEYS if k not in raw]
    if missing:
        raise BadInput(f"{source} is not a body model: missing {', '.join(missing)} "
                       f"(expected SMPL-format keys {', '.join(REQUIRED_KEYS)})")
    a = {k: _to_array(raw[k]) for k in REQUIRED_KEYS}
    v = a["v_template"].astype(np.float64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise BadInput(f"{source}: v_template has shape {v.shape}; expected V x 3")
    n_v = v.shape[0]
    jr = a["J_regressor"].astype(np.float64)
    if jr.ndim != 2 or jr.shape[1] != n_v:
        raise BadInput(f"{source}: J_regressor has shape {jr.shape}; expected J x {n_v}")
    n_j = jr.shape[0]
    sd = a["shapedirs"].astype(np.float64)
    if sd.ndim != 3 or sd.shape[:2] != (n_v, 3):
        raise BadInput(f"{source}: shapedirs has shape {sd.shape}; expected {n_v} x 3 x S")
    pd = a["posedirs"].astype(np.float64)
    if pd.shape != (n_v, 3, 9 * (n_j - 1)):
        raise BadInput(f"{source}: posedirs has shape {pd.shape}; expected {n_v} x 3 x {9 * (n_j - 1)}")
    w = a["weights"].astype(np.float64)
    if w.shape != (n_v, n_j):
        raise BadInput(f"{source}: weights has shape {w.shape}; expected {n_v} x {n_j}")
    kt = a["kintree_table"].astype(np.int64)
    if kt.ndim != 2 or kt.shape[0] != 2 or kt.shape[1] != n_j:
        raise BadInput(f"{source}: kintree_table has shape {kt.shape}; expected 2 x {n_j}")
    parents = kt[0].copy()
    parents[parents >= n_j] = -1  # SMPL stores the root's parent as 2^32 - 1
    parents[0] = -1
    if np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, n_j)):
        raise BadInput(f"{source}: kintree_table parents must precede their children")
    f = a["f"].astype(np.int64)
    if f.ndim != 2 or f.shape[1] != 3 or f.min(initial=0) < 0 or f.max(initial=0) >= n_v:
        raise BadInput(f"{source}: f has shape {f.shape} or indices outside 0..{n_v - 1}; expected F x 3")
    for name, arr in (("v_template", v), ("shapedirs", sd), ("posedirs", pd), ("J_regressor", jr), ("weights", w)):
        if not np.all(np.isfinite(arr)):
            raise BadInput(f"{source}: {name} contains NaN or infinite values")
    meta = {}
    for k, val in raw.items():
        is_text = isinstance(val, (str, np.str_)) or (
            isinstance(val, np.ndarray) and val.dtype.kind == "U" and val.ndim == 0)
        if k not in REQUIRED_KEYS and is_text:
            meta[k] = str(val)
    meta.setdefault("source", source)
    up = meta.pop("up_axis", "y").lower()
    if up not in ("y", "z"):
        raise BadInput(f"{source}: up_axis is {up!r}; expected 'y' (SMPL's own frame) or 'z'")
    if up == "z":
        v, sd, pd = _z_up_to_model_frame(v, sd, pd)
    return SmplArrays(v, sd, pd, jr, w, parents, f, meta)


def _z_up_to_model_frame(v, sd, pd):
    """Re-express arrays stored z-up in SMPL's y-up model frame (the frame skinning works in).

    Positions and shape directions rotate by Q^T. A pose blend shape maps vec(R - I) of a joint's
    rotation to an offset; with R_z = Q R Q^T, the block becomes Q^T P_z (Q kron Q) (row-major vec).
    """
    Q = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    v = v @ Q
    sd = np.einsum("dc,vds->vcs", Q, sd)
    n_v, _, n_p = pd.shape
    blocks = pd.reshape(n_v, 3, n_p // 9, 9)
    blocks = np.einsum("dc,vdjk,kl->vcjl", Q, blocks, np.kron(Q, Q))
    return v, sd, blocks.reshape(n_v, 3, n_p)


def load_body_arrays(path: str | Path) -> SmplArrays:
    """Load an SMPL-format body model from ``.npz`` or an official SMPL ``.pkl``.

    Raises BadInput if the file is missing, unreadable, unsafe or not a body model.
    """
    path = Path(path)
    if not path.is_file():
        raise BadInput(f"body model file {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        raw = load_npz(path, "body model")
    elif suffix in (".pkl", ".pickle"):
        with path.open("rb") as fh:
            raw = safe_pickle_load(fh, what=f"body model {str(path)!r}")
        if not isinstance(raw, dict):
            raise BadInput(f"body model {str(path)!r}: pickle holds {type(raw).__name__}, expected a dict")
    else:
        raise BadInput(f"body model {str(path)!r}: unknown file type {suffix!r}; expected .npz or .pkl")
    return arrays_from_dict(raw, source=f"body model {str(path)!r}")


def save_body_arrays(path: str | Path, arrays: SmplArrays) -> None:
    """Write :class:`SmplArrays` as a compressed SMPL-format ``.npz`` (float32 geometry)."""
    parents = arrays.parents.astype(np.int64)
    kintree = np.stack([parents, np.arange(len(parents))]).astype(np.int64)
    save_npz_atomic(
        path,
        v_template=arrays.v_template.astype(np.float32),
        shapedirs=arrays.shapedirs.astype(np.float32),
        posedirs=arrays.posedirs.astype(np.float32),
        J_regressor=arrays.J_regressor.astype(np.float32),
        weights=arrays.weights.astype(np.float32),
        kintree_table=kintree,
        f=arrays.faces.astype(np.int32),
        **{k: np.array(str(v)) for k, v in arrays.meta.items() if k != "source"},
    )
