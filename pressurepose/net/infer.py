"""Running a trained PressureNet: ``estimate(pressure, gender) -> Estimate`` and its files.

>>> from pressurepose.net.infer import estimate
>>> est = estimate(pressure_image, "f", model="runs/x/model.json")   # (64, 27) mmHg on the model's mat
>>> est.joints.shape, est.vertices.shape                                   # (1, 24, 3), (1, V, 3)
>>> est.sites.share.shape                                                    # (1, 16) load per body site
>>> est.save("out/")   # estimate.json, estimate.npz, sites.json, mesh_000.ply
>>> est = estimate("S1/1.txt", "m", mat="fsa_softflex_2048", units="raw", weight_kg=87)  # a real recording

A real recording on any mat (``mat=``) is read by
:func:`pressurepose.data.readers.recording.read_recording` and made model input by
:meth:`pressurepose.data.readers.images.RealImages.model_input`, the road ``evaluate-real`` takes.
"""

from __future__ import annotations

import os
import weakref
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Sequence

import numpy as np
import torch

from pressurepose.body.sites import SITES, SiteLoads, body_loads, site_stats, vertex_sites
from pressurepose.data.readers.images import RealImages
from pressurepose.data.readers.recording import read_array_file, read_recording
from pressurepose.errors import BadInput, finite_float32, require_bool, require_whole
from pressurepose.files import (
    atomic_write,
    check_output_path,
    remove_stale_numbered,
    save_npz_atomic,
    write_json_atomic,
)
from pressurepose.mat import MatSpec
from pressurepose.net.fit import FitConfig, fit_config, fit_to_print
from pressurepose.net.model import GENDER_CODES, PressureNet
from pressurepose.net.plausibility import Plausibility, check_plausible
from pressurepose.net.pmr import PMRConfig, surface_maps
from pressurepose.net.sitenet import AUTO, SiteNet, read_taxel_sites, resolve_site_net

DEFAULT_MODEL = Path(__file__).parent / "assets" / "pressurenet.json"
SENSOR_MAX_MMHG = 100.0  # top of the range of every mat preset (pressurepose.mat.MATS)


@dataclass
class Estimate:
    """PressureNet's estimate for a batch of B images (numpy, bed frame, metres and radians).

    betas (B, 10); pose (B, 72) SMPL axis-angle (root first); transl (B, 3); joints (B, 24, 3);
    vertices (B, V, 3); faces (F, 3); pressure (B, R, C) the input (mmHg); :attr:`q` (B, R, C) the
    reconstructed pressure map of the body (its sink below the mattress top, mm, read from its
    lower surface as the simulator reads a body: :func:`pressurepose.net.pmr.surface_maps`, with
    ``pmr``'s settings) and :attr:`contact` (B, R, C) its contact map (1 where the body is below
    the mattress top), both computed when first read (about 25 ms a body on one CPU core);
    gender: 'f' or 'm' per image; mod1_joints (B, 24, 3): Mod1's joints, for reference; grid: the
    model's mat; mirror: whether each body averages the readings of the image and of its mirror;
    fitted: whether each body was moved to fit its image's print (:mod:`pressurepose.net.fit`);
    frame: (B,) int, each image's frame index in the recording it was read from (None for images
    given on the model's mat); vertex_site (B, V) int8: the body site of each vertex of each body
    (:func:`~pressurepose.body.sites.vertex_sites`; None: no sites). From it, computed when first
    read (10-20 ms an image on one CPU core, half of it the site network): :attr:`sites`, the load
    on each body site (:class:`~pressurepose.body.sites.SiteLoads`: peak, mean, area and share per site of
    :data:`~pressurepose.body.sites.SITES`), and :attr:`vertex_pressure` (B, V) mmHg on the body's
    surface (:func:`~pressurepose.body.sites.vertex_pressure`). site_net: the site network that
    gives each loaded taxel its site from the image and the estimated body's site map
    (:mod:`pressurepose.net.sitenet`; ``estimate()`` sets the one its ``site_net`` names); None: each taxel takes the site of the estimated body lying on it. plausibility: whether
    each input image looks like a person lying on the mat, and why not where it does not
    (:func:`pressurepose.net.plausibility.check_plausible`; None: not checked): an estimate of an
    image that does not means nothing.
    """

    betas: np.ndarray
    pose: np.ndarray
    transl: np.ndarray
    joints: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    pressure: np.ndarray
    gender: list[str]
    mod1_joints: np.ndarray
    grid: MatSpec
    mirror: bool = False
    fitted: bool = False
    frame: np.ndarray | None = None
    pmr: PMRConfig = PMRConfig()
    vertex_site: np.ndarray | None = None
    plausibility: Plausibility | None = None
    site_net: SiteNet | None = None
    _maps: tuple[np.ndarray, np.ndarray] | None = field(default=None, init=False, repr=False, compare=False)
    _sites: tuple[SiteLoads, np.ndarray] | None = field(default=None, init=False, repr=False, compare=False)

    def __len__(self) -> int:
        return int(self.betas.shape[0])

    def image_name(self, i: int) -> str:
        """How reports and pictures name image ``i``: its frame in the recording it was read from
        ('frame 12'), else its index in the input ('image 3')."""
        return f"frame {int(self.frame[i])}" if self.frame is not None else f"image {i}"

    def _surface_maps(self) -> tuple[np.ndarray, np.ndarray]:
        if self._maps is None:
            verts, faces = torch.from_numpy(np.asarray(self.vertices, np.float32)), torch.from_numpy(self.faces)
            maps = [surface_maps(verts[s:s + 32], faces, self.grid, self.pmr) for s in range(0, len(self), 32)]
            self._maps = (torch.cat([m.q for m in maps]).float().numpy(),
                          torch.cat([m.contact for m in maps]).float().numpy())
        return self._maps

    @property
    def q(self) -> np.ndarray:
        """(B, R, C) the body's sink below the mattress top per taxel, mm (0 where it does not sink)."""
        return self._surface_maps()[0]

    @property
    def contact(self) -> np.ndarray:
        """(B, R, C) 1 where the body's lower surface is below the mattress top, else 0."""
        return self._surface_maps()[1]

    def to_records(self) -> list[dict]:
        """One JSON-ready dict per image (with "plausible" and, where False, "doubt": the reason in
        words, when the images were checked)."""
        frame = [{} if self.frame is None else {"frame": int(self.frame[i])} for i in range(len(self))]
        checked = [{} if self.plausibility is None else self.plausibility.record(i) for i in range(len(self))]
        return [{**frame[i], **checked[i], "gender": self.gender[i], "betas": self.betas[i].tolist(), "pose": self.pose[i].tolist(),
                 "transl": self.transl[i].tolist(), "joints": self.joints[i].tolist()} for i in range(len(self))]

    def _site_loads(self) -> tuple[SiteLoads, np.ndarray] | None:
        if self._sites is None and self.vertex_site is not None:
            loads, on_skin = body_loads(self.pressure, self.vertices, self.faces, self.vertex_site, self.grid)
            if self.site_net is not None:
                loads = site_stats(self.pressure, read_taxel_sites(self.site_net, self.pressure, loads.taxel_site),
                                   self.grid)
            self._sites = (loads, on_skin)
        return self._sites

    @property
    def sites_read_by(self) -> str:
        """How each taxel got its site: 'site network' or 'estimated body'."""
        return "estimated body" if self.site_net is None else "site network"

    @property
    def sites(self) -> SiteLoads | None:
        """The load on each body site of each image (None without ``vertex_site``), each taxel's site
        read as :attr:`sites_read_by` says."""
        loads = self._site_loads()
        return None if loads is None else loads[0]

    @property
    def vertex_pressure(self) -> np.ndarray | None:
        """(B, V) mmHg on each body's surface (None without ``vertex_site``)."""
        loads = self._site_loads()
        return None if loads is None else loads[1]

    def sites_record(self) -> dict:
        """The per-site loads as a strict-JSON-ready dict: one entry per image (its frame, the most
        loaded site and every site's peak_mmhg, mean_mmhg, area_cm2 and share)."""
        if self.sites is None:
            raise BadInput("this estimate has no body sites (vertex_site); estimate() gives them")
        images = []
        for i, (rec, top) in enumerate(zip(self.sites.to_records(), self.sites.most_loaded())):
            frame = {} if self.frame is None else {"frame": int(self.frame[i])}
            images.append({"image": i, **frame, "most_loaded": top or None, "sites": rec})
        return {"units": "peak and mean mmHg over the site's loaded taxels, contact area cm^2, share of the "
                         "image's load", "sites": list(SITES), "sites_read_by": self.sites_read_by,
                "site_network": None if self.site_net is None else self.site_net.source, "images": images}

    def save(self, out_dir: str | Path, mesh_format: str = "ply") -> list[Path]:
        """Write estimate.json, estimate.npz, sites.json (with site loads) and one mesh per image
        (``mesh_000.ply`` or ``.obj``), removing the numbered meshes an earlier estimate left in
        ``out_dir``. Returns the paths written (pictures: :func:`pressurepose.viz.estimate.save_estimate_figures`)."""
        import trimesh

        if mesh_format not in ("ply", "obj"):
            raise BadInput(f"mesh format {mesh_format!r}: expected ply or obj")
        out = check_output_path(out_dir, "output folder", directory=True)
        out.mkdir(parents=True, exist_ok=True)
        paths = [out / "estimate.json", out / "estimate.npz"]
        write_json_atomic(paths[0], {"units": "metres, radians (SMPL axis-angle, root first); bed frame",
                                     "mirror_averaged": bool(self.mirror),
                                     "fitted_to_print": bool(self.fitted), "estimates": self.to_records()})
        save_npz_atomic(paths[1], betas=self.betas, pose=self.pose, transl=self.transl, joints=self.joints,
                        vertices=self.vertices, faces=self.faces, q=self.q, contact=self.contact,
                        gender=np.array(self.gender),
                        **({} if self.frame is None else {"frame": np.asarray(self.frame, dtype=np.int64)}),
                        **({} if self.sites is None else {"vertex_pressure": self.vertex_pressure.astype(np.float32),
                                                          "taxel_site": self.sites.taxel_site}))
        if self.sites is not None:
            paths.append(out / "sites.json")
            write_json_atomic(paths[-1], self.sites_record())
        for i in range(len(self)):
            p = out / f"mesh_{i:03d}.{mesh_format}"
            mesh = trimesh.Trimesh(self.vertices[i], self.faces, process=False)
            atomic_write(p, lambda t, mesh=mesh: mesh.export(str(t), file_type=mesh_format))
            paths.append(p)
        remove_stale_numbered(out, "mesh_", (".ply", ".obj"), paths)  # an earlier, longer estimate's
        return paths


# ---------------------------------------------------------------------------------------- input
def refuse_recording_settings(units, weight_kg, gain, head_row) -> None:
    """BadInput when a recording's own settings (units other than mmHg, a weight, a gain, the head
    at the last row) come without its mat: images on the model's mat take none of them."""
    if units not in (None, "mmHg") or weight_kg is not None or gain is not None or head_row != "first":
        raise BadInput("units, weight_kg, gain and head_row describe a recording on its own mat: give its mat "
                       "too (mat=preset name or mat.json)")


def load_pressure(path: str | Path, key: str = "pressure") -> np.ndarray:
    """Pressure images from a file: ``.npy`` ((R, C) or (B, R, C)), ``.csv`` (one image, R rows of
    C comma-separated values), ``.npz`` (array ``key``: a ``simulate`` output or a training pack) or
    HDF5 (``.h5`` / ``.hdf5``, dataset ``key``: a dataset shard). BadInput otherwise."""
    path = Path(path)
    if path.is_dir():
        shards = sorted(path.glob("shard-*.h5"))
        hint = f", e.g. {str(shards[0])!r}" if shards else ""
        raise BadInput(f"pressure file {str(path)!r} is a folder; expected a file (.npy, .csv, .npz or a "
                       f"dataset shard .h5{hint})")
    if not path.is_file():
        raise BadInput(f"pressure file {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    try:
        if suffix in (".npy", ".csv"):
            arr = read_array_file(path, "pressure")
        elif suffix == ".npz":
            from pressurepose.files import load_npz

            arr = load_npz(path, "pressure file", (key,))[key]  # only the images, not a pack's labels
        elif suffix in (".h5", ".hdf5"):
            import h5py

            from pressurepose.files import stored_dataset

            with h5py.File(path, "r") as f:
                arr = stored_dataset(f, key, f"HDF5 file {str(path)!r}")[()]
        else:
            raise BadInput(f"pressure file {str(path)!r}: expected .npy, .csv, .npz, .h5 or .hdf5")
    except BadInput:
        raise
    except (ValueError, OSError) as exc:
        raise BadInput(f"pressure file {str(path)!r} could not be read ({exc})") from None
    return finite_float32(arr, f"pressure file {str(path)!r}")


def load_genders(path: str | Path, key: str = "gender") -> list[str] | str:
    """Genders stored with the images of a file: an HDF5 file's dataset ``key`` of 'f' / 'm' (a
    dataset shard), or an ``.npz``'s array ``key``: one 'f' / 'm' for all its images (a ``simulate``
    output) or per-image codes 0 / 1 (a training pack). BadInput when there are none, or when they
    are not genders (naming the file)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        from pressurepose.files import load_npz

        try:
            values = load_npz(path, "pressure file", (key,))[key]
        except BadInput as exc:
            raise BadInput(f"{exc}; pass --gender") from None
        names = _stored_genders(values, f"pressure file {str(path)!r}")
        return names[0] if values.ndim == 0 and values.dtype.kind not in "iu" else names
    if suffix not in (".h5", ".hdf5"):
        raise BadInput(f"--gender is needed for {str(path)!r} (only HDF5 and .npz files can carry genders)")
    import h5py

    from pressurepose.files import stored_dataset

    with h5py.File(path, "r") as f:
        if key not in f:
            raise BadInput(f"HDF5 file {str(path)!r} has no {key!r} dataset; pass --gender")
        values = stored_dataset(f, key, f"HDF5 file {str(path)!r}")[()]
    return _stored_genders(np.asarray(values), f"HDF5 file {str(path)!r}")


def _stored_genders(values: np.ndarray, where: str) -> list[str]:
    """The genders of a file's array (one, or one per image): 'f' / 'm' names (str or bytes) or codes
    0 / 1; BadInput naming ``where`` for anything else."""
    from pressurepose.data.schema import GENDERS

    if values.ndim > 1:
        raise BadInput(f"{where}: its genders have shape {values.shape}; expected one, or one per image; pass --gender")
    if values.dtype.kind in "iu":
        if values.size and not (0 <= values.min() and values.max() < len(GENDERS)):
            raise BadInput(f"{where}: gender codes {sorted(set(values.tolist()))} are not indices into {GENDERS}; "
                           f"pass --gender")
        return [GENDERS[int(v)] for v in np.atleast_1d(values)]
    names = [v.decode(errors="replace") if isinstance(v, bytes) else str(v) for v in np.atleast_1d(values)]
    for g in names:
        if g.strip().lower() not in GENDER_CODES and g.strip() not in ("0", "1"):
            raise BadInput(f"{where}: gender {g!r} is not known; expected f or m; pass --gender")
    return names


def check_pressure(pressure, shape: tuple[int, int], what: str = "pressure") -> np.ndarray:
    """(B, R, C) float32 from one image (R, C) or a batch; BadInput for a wrong shape, NaN,
    infinite or negative values."""
    arr = np.asarray(pressure.detach().cpu() if isinstance(pressure, torch.Tensor) else pressure)
    if arr.dtype.kind not in "fiub":
        raise BadInput(f"{what} has dtype {arr.dtype}; expected numbers")
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != tuple(shape) or arr.shape[0] == 0:
        hint = ("; a recording from another mat goes in with that mat (`infer --mat PRESET|mat.json --units ...`, "
                "or estimate(..., mat=..., units=...)), which resamples it onto this one keeping the total force"
                if arr.ndim in (2, 3) and arr.shape[0] else "")
        raise BadInput(f"{what} has shape {np.shape(pressure)}; this model's mat is {shape[0]} x {shape[1]} "
                       f"(expected ({shape[0]}, {shape[1]}) or (B, {shape[0]}, {shape[1]})){hint}")
    arr = finite_float32(arr, what)
    if np.any(arr < 0):
        raise BadInput(f"{what} has negative values (min {arr.min():.3g}); pressures must be >= 0")
    return arr


def pressure_warnings(arr: np.ndarray, max_mmhg: float = SENSOR_MAX_MMHG, what: str = "pressure") -> list[str]:
    """Sentences about checked images (B, R, C) that no estimate can be trusted for: empty mats (all
    readings 0) and readings above the sensor's range ``max_mmhg``. BadInput when every image is
    empty or a reading is beyond 10 times the range (wrong units: 1 mmHg = 133.3 Pa)."""
    empty = np.flatnonzero(arr.reshape(len(arr), -1).max(axis=1) <= 0)
    peak = float(arr.max())
    if len(empty) == len(arr):
        raise BadInput(f"{what}: the mat is empty (every reading is 0); nobody lies on it")
    if peak > 10 * max_mmhg:
        raise BadInput(f"{what}: readings up to {peak:.3g} mmHg are far outside the sensor's range 0..{max_mmhg:g} "
                       f"mmHg; are they in mmHg (1 mmHg = 133.3 Pa)?")
    notes = []
    if len(empty):
        notes.append(f"{what}: image(s) {', '.join(map(str, empty[:10].tolist()))} are empty (every reading 0); "
                     f"their estimates mean nothing")
    if peak > max_mmhg:
        over = np.flatnonzero(arr.reshape(len(arr), -1).max(axis=1) > max_mmhg)
        notes.append(f"{what}: image(s) {', '.join(map(str, over[:10].tolist()))} read above the sensor's range "
                     f"(peak {peak:.3g} > {max_mmhg:g} mmHg); the model never saw such readings")
    return notes


def floor_warnings(arr: np.ndarray, floor_mmhg: float, what: str = "pressure") -> list[str]:
    """A sentence about checked images (B, R, C) that are not all zero but read nothing above
    ``floor_mmhg``, a model's contact floor (:class:`~pressurepose.net.transforms.InputConfig`): the
    model drops readings at or below it, so it sees an empty mat. [] when there are none."""
    peak = arr.reshape(len(arr), -1).max(axis=1)
    faint = np.flatnonzero((peak > 0) & (peak <= floor_mmhg))
    if not len(faint):
        return []
    return [f"{what}: image(s) {', '.join(map(str, faint[:10].tolist()))}{' ...' if len(faint) > 10 else ''} read at "
            f"most {float(peak[faint].max()):.3g} mmHg, not above the model's contact floor ({floor_mmhg:g} mmHg), at "
            f"or below which it drops readings: it sees an empty mat, and their estimates mean nothing"]


def _genders(gender, n: int) -> list[str]:
    if isinstance(gender, (str, int, np.integer)) and not isinstance(gender, bool):
        items = [gender] * n
    elif isinstance(gender, (list, tuple, np.ndarray)) and np.ndim(gender) == 1:
        items = list(gender)
    else:
        raise BadInput(f"gender is {gender!r:.80}; expected f or m for all images, or a list of one per image")
    if len(items) != n:
        raise BadInput(f"{len(items)} genders for {n} pressure images")
    out = []
    for g in items:
        key = str(g).strip().lower()
        if key not in GENDER_CODES and key not in ("0", "1"):
            raise BadInput(f"gender {g!r} is not known; expected f or m")
        out.append("f" if key in ("0", "f", "female") else "m")
    return out


@lru_cache(maxsize=4)
def _cached_model(path: str, mtime: float, bodies: tuple[str, str] | None) -> PressureNet:
    from pressurepose.net.checkpoint import body_model, load_model

    return load_model(path, bodies=None if bodies is None else tuple(body_model(b) for b in bodies))[0]


def resolve_model(model=None, bodies: tuple[str, str] | None = None) -> PressureNet:
    """A PressureNet from None (the shipped model), a path, or a PressureNet (returned as is).

    bodies: (female, male) body model specs ('female', 'male', 'toy' or SMPL-format files) to use
    instead of those stored with the model (e.g. the same SMPL files at another place); they must
    be the models it was trained with (checked by identity).
    """
    if isinstance(model, PressureNet):
        return model
    if model is not None and not isinstance(model, (str, os.PathLike)):
        loaded = (isinstance(model, tuple) and len(model) == 2 and isinstance(model[0], PressureNet)
                  and isinstance(model[1], dict))
        hint = "; load_model returns (network, record): pass load_model(path)[0], or the path itself" if loaded else ""
        raise BadInput(f"model is {type(model).__name__}; expected a model file (.json, .safetensors or .pt), a "
                       f"run folder, a loaded PressureNet, or None for the shipped model{hint}")
    if bodies is not None and (isinstance(bodies, (str, bytes)) or not isinstance(bodies, (tuple, list))
                               or len(bodies) != 2 or not all(isinstance(b, (str, os.PathLike)) for b in bodies)):
        raise BadInput(f"bodies is {bodies!r:.80}; expected (female, male) body model specs: 'female' / 'male', 'toy' "
                       f"or SMPL-format files")
    path = DEFAULT_MODEL if model is None else Path(model)
    if model is None and not path.is_file():
        raise BadInput("no trained PressureNet ships with this installation yet; pass a model file "
                       "(--model / model=...) made by `pressurepose train`")
    if path.is_dir():
        path = path / "model.json"
    if not path.is_file():
        raise BadInput(f"model file {str(path)!r} does not exist")
    return _cached_model(str(path.resolve()), path.stat().st_mtime, None if bodies is None else tuple(map(str, bodies)))


@torch.inference_mode()
def run_network(net: PressureNet, pressure: np.ndarray, genders: Sequence[str], batch_size: int = 64,
                progress: bool = False, mirror: bool = False, fit: FitConfig | None = None):
    """Both modules' outputs for checked pressure (B, R, C): a list of (out1, out2) per batch
    (progress: a progress bar over the batches; mirror: average each estimate with the network's
    reading of the mirrored image, :mod:`pressurepose.net.mirror`, about twice the work; fit: then
    move Mod2's body to fit the image's print, :mod:`pressurepose.net.fit`)."""
    from tqdm import tqdm

    require_whole("batch size", batch_size, 1)
    device = next(net.parameters()).device
    if net.training:
        net.eval()
    g = torch.tensor([GENDER_CODES[x] for x in genders], dtype=torch.long)
    results = []
    for s in tqdm(range(0, len(pressure), batch_size), desc="infer", unit="batch", disable=not progress):
        p = torch.from_numpy(pressure[s:s + batch_size]).to(device)
        gb = g[s:s + batch_size].to(device)
        results.append(read_batch(net, p, gb, mirror, fit))
    return results


def read_batch(net: PressureNet, pressure: torch.Tensor, gender: torch.Tensor, mirror: bool = False,
               fit: FitConfig | None = None):
    """(out1, out2) for one batch of clean images (B, R, C) and gender codes (B,): the network's
    reading (``mirror``: averaged with its reading of the mirrored images), then (``fit``) Mod2's
    body moved to fit each image's print."""
    from pressurepose.net.mirror import mirror_averaged

    out1, out2 = mirror_averaged(net, pressure, gender) if mirror else net(pressure, gender)
    if fit is not None:
        params = fit_to_print(net.body, out2.params, gender, pressure, net.config.grid,
                              net.config.inputs.contact_floor_mmhg, fit)
        out2 = net.pose_body(params, gender, maps=out2.maps is not None)
    return out1, out2


def estimate(pressure, gender, model=None, batch_size: int = 64, bodies: tuple[str, str] | None = None,
             progress: bool = False, mirror: bool = False, fit: bool | FitConfig = False, *, mat=None,
             units: str | None = None, weight_kg=None, gain: float | None = None, head_row: str = "first",
             what: str | None = None, site_net=AUTO) -> Estimate:
    """Estimate body pose and shape from pressure images.

    pressure: one image (R, C) or a batch (B, R, C), mmHg, on the model's mat (numpy or torch, or a
    file of them, as ``infer`` without ``--mat`` reads it: :func:`load_pressure`); or,
    with ``mat``, a real recording on any mat: an array or a file (.npy, .csv, a PMD-style .txt of
    one frame a line), read by :func:`pressurepose.data.readers.recording.read_recording` with
    ``units`` ('raw' or 'mmHg'), ``weight_kg`` or ``gain`` (raw readings to mmHg) and ``head_row``
    ('first' or 'last': which end of the rows is the head), or a RealImages from any reader.
    Either way a real recording is cleaned, put in mmHg and resampled onto the model's mat by
    :meth:`~pressurepose.data.readers.images.RealImages.model_input`, as ``evaluate-real`` does,
    and ``Estimate.frame`` says which frames were estimated.
    gender: 'f' / 'm' (or female / male) for all images, or one per image.
    model: None (the shipped model), a model path, or a loaded :class:`PressureNet`.
    bodies: (female, male) body model specs overriding the stored ones (see :func:`resolve_model`).
    mirror: also read each image's left-right mirror and average the two bodies
    (:mod:`pressurepose.net.mirror`; about twice the work).
    fit: True (the default :class:`~pressurepose.net.fit.FitConfig`) or a FitConfig: move each
    estimated body to fit its image's print after the network (:mod:`pressurepose.net.fit`; about
    0.3 s of one CPU core an image).
    what: the input's name in messages (default: the file, or 'pressure').
    site_net: what reads each loaded taxel's body site (``Estimate.sites``): 'auto' (default: the
    site network shipped for the model's mat, when there is one), a site network file trained for
    this model (``pressurepose train-sites``), a loaded SiteNet, or None (the estimated body alone);
    :func:`pressurepose.net.sitenet.resolve_site_net`.
    progress: a progress bar over the batches on stderr; off by default, unlike the functions that
    run over a dataset, a recording or a training run, since ``estimate`` is called per image or
    per frame in loops.

    Each image (as the model reads it: mmHg on its mat) is checked for looking like a person lying
    on the mat (:func:`pressurepose.net.plausibility.check_plausible`): ``Estimate.plausibility``
    says which do not and why (``infer`` prints it); their estimates mean nothing.
    Warns (:func:`warnings.warn`, the sentences of :func:`pressure_warnings` and
    :func:`floor_warnings`) about empty images, readings above the sensor's range and images that read
    nothing above the model's contact floor; BadInput when every image is empty or readings lie
    beyond 10 times the range (not mmHg).
    """
    import warnings

    fitting = fit_config(fit)
    require_bool("mirror", mirror)
    net = resolve_model(model, bodies)
    site_net = resolve_site_net(site_net, net.config.grid)  # refused before any work
    frame = None
    if isinstance(pressure, RealImages) or mat is not None:
        real = pressure if isinstance(pressure, RealImages) else read_recording(
            pressure, mat, units, weight_kg=weight_kg, gain=gain, head_row=head_row)
        if isinstance(pressure, RealImages) and (mat is not None or units is not None or weight_kg is not None
                                                 or gain is not None or head_row != "first"):
            raise BadInput("a RealImages carries its own mat, units, weight and gain; pass them to its reader")
        what = what or (str(pressure) if isinstance(pressure, (str, Path)) else "the recording")
        arr = real.model_input(net.config.grid)
        frame = real.frame
        notes = (pressure_warnings(real.images, real.mat.max_mmhg, what) if real.units == "mmHg"
                 else pressure_warnings(arr, net.config.grid.max_mmhg, what))
    else:
        refuse_recording_settings(units, weight_kg, gain, head_row)
        if isinstance(pressure, (str, Path)):
            what = what or str(pressure)
            pressure = load_pressure(pressure)
        what = what or "pressure"
        arr = check_pressure(pressure, net.config.grid.shape, what=what)
        notes = None
    genders = _genders(gender, len(arr))
    if notes is None:
        notes = pressure_warnings(arr, net.config.grid.max_mmhg, what)
    for note in notes + floor_warnings(arr, net.config.inputs.contact_floor_mmhg, what):
        warnings.warn(note, stacklevel=2)
    parts = run_network(net, arr, genders, batch_size, progress, mirror, fitting)

    def cat(fn):
        items = [fn(o1, o2) for o1, o2 in parts]
        return (items[0] if len(items) == 1 else torch.cat(items)).float().cpu().numpy()

    return Estimate(betas=cat(lambda a, b: b.params.betas), pose=cat(lambda a, b: b.params.pose),
                    transl=cat(lambda a, b: b.params.transl), joints=cat(lambda a, b: b.joints),
                    vertices=cat(lambda a, b: b.vertices), faces=net.body.faces.cpu().numpy(),
                    pressure=arr, gender=genders, mod1_joints=cat(lambda a, b: a.joints), grid=net.config.grid,
                    mirror=bool(mirror), fitted=fitting is not None, frame=frame, pmr=net.config.pmr,
                    vertex_site=vertex_sites_of(net, genders), plausibility=check_plausible(arr, net.config.grid),
                    site_net=resolve_site_net(site_net, net.config.grid))


_VERTEX_SITES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def vertex_sites_of(net: PressureNet, genders: Sequence[str]) -> np.ndarray:
    """(B, V) int8 body site (:func:`pressurepose.body.sites.vertex_sites`) of every vertex of the
    network's body of each image's gender ('f' / 'm'); each body's sites are worked out once."""
    per = {}
    for g, layer in zip("fm", (net.body.layers[0], net.body.layers[-1])):
        if layer not in _VERTEX_SITES:
            _VERTEX_SITES[layer] = vertex_sites(layer)
        per[g] = _VERTEX_SITES[layer]
    return np.stack([per[g] for g in genders]) if len(genders) else np.zeros((0, len(per["f"])), np.int8)
