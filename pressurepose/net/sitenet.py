"""Which body site carries each loaded taxel, read by a small network (the site network).

The estimated body alone names the body site under each taxel (:func:`pressurepose.body.sites.body_loads`);
where the body is a few centimetres off, the boundary between two sites (shoulder blades and
sacrum, hip and knee) falls on the wrong taxels. The site network reads the pressure image together
with that body's site map and gives each loaded taxel its site again, as the simulator recorded
them (``Sample.sites``) in the data it was trained on (:mod:`pressurepose.net.sitenet_train`).

Input channels per taxel (:func:`site_inputs`): the pressure (mmHg / ``max_mmhg``, clipped to 0..2),
whether it is loaded, the row and column as fractions of the mat, and the body route's site as a
one-hot over :data:`~pressurepose.body.sites.SITES` plus one channel for no site. The network is a
three-level U-Net (widths w, 2w, 4w; 3x3 convolutions, batch norm, ReLU) whose output is one logit
per site and taxel (B, S, R, C). It works on the mat it was trained on (``SiteNetConfig.grid``).

A site network is saved as ``NAME.json`` (format, config, training notes) with its weights in
``NAME.safetensors`` (tensors only); loading runs no code from the files.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from pressurepose.body.sites import NO_SITE, SITES
from pressurepose.errors import BadInput, require_path
from pressurepose.files import atomic_write, json_text, write_text_atomic
from pressurepose.mat import MatSpec

FORMAT = "pressurepose.sitenet/1"
SHIPPED = Path(__file__).parent / "assets" / "sitenet.json"
N_INPUTS = 4 + len(SITES) + 1


def mirrored_sites() -> np.ndarray:
    """(S,) int: the index into :data:`SITES` of each site's mirror image (left and right swapped)."""
    names = [n.replace("left_", "@").replace("right_", "left_").replace("@", "right_") for n in SITES]
    return np.array([SITES.index(n) for n in names])


@dataclass(frozen=True)
class SiteNetConfig:
    """grid: the mat the network reads; width: channels of the U-Net's first level (then 2x, 4x);
    max_mmhg: the pressure that reads as 1 at the input."""

    grid: MatSpec
    width: int = 32
    max_mmhg: float = 100.0

    def __post_init__(self):
        if not isinstance(self.grid, MatSpec):
            raise BadInput(f"grid is {type(self.grid).__name__}; expected a pressurepose.mat.MatSpec")
        if not isinstance(self.width, int) or isinstance(self.width, bool) or self.width < 4:
            raise BadInput(f"width {self.width!r}: expected a whole number of at least 4")
        if not np.isfinite(self.max_mmhg) or self.max_mmhg <= 0:
            raise BadInput(f"max_mmhg {self.max_mmhg!r}: expected a positive number of mmHg")

    def to_dict(self) -> dict:
        return {"grid": self.grid.to_dict(), "width": self.width, "max_mmhg": self.max_mmhg}

    @staticmethod
    def from_dict(d: dict) -> "SiteNetConfig":
        try:
            return SiteNetConfig(grid=MatSpec.from_dict(d["grid"]), width=int(d["width"]),
                                 max_mmhg=float(d["max_mmhg"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise BadInput(f"site network config {d!r}: {exc}; expected grid, width and max_mmhg") from None


def _block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True),
                         nn.Conv2d(cout, cout, 3, padding=1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class SiteNet(nn.Module):
    """U-Net from :func:`site_inputs` (B, N_INPUTS, R, C) to site logits (B, S, R, C). ``source``
    names where it came from, as results record it: 'shipped', the file it was loaded from, or
    'given in Python'."""

    def __init__(self, config: SiteNetConfig):
        super().__init__()
        self.config = config
        self.source = "given in Python"
        w = config.width
        self.enc = nn.ModuleList([_block(N_INPUTS, w), _block(w, 2 * w), _block(2 * w, 4 * w)])
        self.up = nn.ModuleList([nn.Conv2d(4 * w, 2 * w, 1), nn.Conv2d(2 * w, w, 1)])
        self.dec = nn.ModuleList([_block(4 * w, 2 * w), _block(2 * w, w)])
        self.head = nn.Conv2d(w, len(SITES), 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        skips = []
        for i, block in enumerate(self.enc):
            if i:
                x = F.max_pool2d(x, 2, ceil_mode=True)
            x = block(x)
            skips.append(x)
        for up, dec, skip in zip(self.up, self.dec, reversed(skips[:-1])):
            x = up(F.interpolate(x, size=skip.shape[-2:], mode="nearest"))
            x = dec(torch.cat([x, skip], 1))
        return self.head(x)


def site_inputs(pressure: np.ndarray, body_sites: np.ndarray, config: SiteNetConfig) -> torch.Tensor:
    """(B, N_INPUTS, R, C) float32 network input from pressure (B, R, C) mmHg and the body route's
    taxel sites (B, R, C) int (indices into :data:`SITES`, ``NO_SITE`` for none)."""
    p = np.asarray(pressure, np.float32)
    s = np.asarray(body_sites)
    if p.ndim != 3 or s.shape != p.shape or p.shape[1:] != config.grid.shape:
        raise BadInput(f"pressure {p.shape} and body sites {s.shape}: expected both (B, {config.grid.rows}, "
                       f"{config.grid.cols}), the site network's mat")
    if s.dtype.kind not in "iu" or (s.size and (s.min() < NO_SITE or s.max() >= len(SITES))):
        raise BadInput(f"body sites must be integers from {NO_SITE} (no site) to {len(SITES) - 1} (indices into "
                       f"SITES); got {s.dtype} from {s.min() if s.size else '-'} to {s.max() if s.size else '-'}")
    B, R, C = p.shape
    x = np.zeros((B, N_INPUTS, R, C), np.float32)
    x[:, 0] = np.clip(p / config.max_mmhg, 0.0, 2.0)
    x[:, 1] = p > 0
    x[:, 2] = (np.arange(R, dtype=np.float32) / max(R - 1, 1))[:, None]
    x[:, 3] = (np.arange(C, dtype=np.float32) / max(C - 1, 1))[None, :]
    k = np.where(s < 0, len(SITES), s).astype(np.int64)
    np.put_along_axis(x[:, 4:], k[:, None], 1.0, axis=1)
    return torch.from_numpy(x)


@torch.inference_mode()
def read_taxel_sites(net: SiteNet, pressure, body_sites, batch_size: int = 256) -> np.ndarray:
    """(B, R, C) int8 site of every loaded taxel (``NO_SITE`` where the reading is 0 or less), the
    site network's most likely site, from pressure (B, R, C) mmHg and the body route's taxel sites."""
    p = np.asarray(pressure, np.float32)
    if net.training:
        net.eval()
    out = np.empty(p.shape, np.int8)
    for s in range(0, len(p), batch_size):
        logits = net(site_inputs(p[s:s + batch_size], np.asarray(body_sites)[s:s + batch_size], net.config))
        out[s:s + batch_size] = logits.argmax(1).numpy().astype(np.int8)
    return np.where(p > 0, out, NO_SITE).astype(np.int8)


def save_site_net(path: str | Path, net: SiteNet, meta: dict | None = None) -> Path:
    """Write ``NAME.json`` and ``NAME.safetensors`` for ``path`` = NAME.json; returns the JSON's path."""
    from safetensors.torch import save_file

    path = Path(path).with_suffix(".json")
    weights = path.with_suffix(".safetensors")
    path.parent.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    atomic_write(weights, lambda tmp: save_file(state, str(tmp)))
    write_text_atomic(path, json_text({"format": FORMAT, "config": net.config.to_dict(), "sites": list(SITES),
                                       "weights": weights.name, **(meta or {})}))
    return path


def load_site_net(path: str | Path) -> SiteNet:
    """A site network from ``NAME.json`` and its safetensors weights; BadInput naming the file
    when it is not one."""
    from safetensors.torch import load_file

    path = require_path("site network", path)
    if not path.is_file():
        raise BadInput(f"site network {str(path)!r} does not exist")
    try:
        record = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadInput(f"site network {str(path)!r} is not JSON ({exc})") from None
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise BadInput(f"{str(path)!r} is not a site network (expected format {FORMAT!r})")
    if record.get("sites", list(SITES)) != list(SITES):
        raise BadInput(f"site network {str(path)!r} names the sites {record['sites']}; this pressurepose has "
                       f"{list(SITES)}: train it again (pressurepose train-sites)")
    net = SiteNet(SiteNetConfig.from_dict(record.get("config", {})))
    weights = path.parent / str(record.get("weights", ""))
    if not weights.is_file():
        raise BadInput(f"site network {str(path)!r}: its weights {str(weights)!r} are missing")
    try:
        state = load_file(str(weights))
        net.load_state_dict(state)
    except Exception as exc:  # safetensors raises its own errors for a damaged file
        raise BadInput(f"site network weights {str(weights)!r} do not load: {exc}") from None
    net.meta = record
    net.source = "shipped" if path.resolve() == SHIPPED.resolve() else str(path)
    return net.eval()


@lru_cache(maxsize=1)
def shipped_site_net() -> SiteNet | None:
    """The site network that ships with pressurepose (None when none ships)."""
    return load_site_net(SHIPPED) if SHIPPED.is_file() else None


@lru_cache(maxsize=4)
def _cached_site_net(path: str, mtime: float) -> SiteNet:
    return load_site_net(path)  # mtime: a file written anew is loaded anew


AUTO = "auto"


def resolve_site_net(site_net, grid: MatSpec) -> SiteNet | None:
    """The site network that reads the loaded taxels of a model on ``grid``'s mat.

    site_net: 'auto' (the shipped one when it reads ``grid``'s mat, else None), None (none: each
    taxel's site comes from the estimated body alone), a site network file (``NAME.json``, from
    ``pressurepose train-sites``) or a :class:`SiteNet`. BadInput when a given network reads
    another mat than ``grid``'s."""
    if isinstance(site_net, str) and site_net == AUTO:
        net = shipped_site_net()
        return net if net is not None and net.config.grid.same_grid(grid) else None
    if site_net is None:
        return None
    if isinstance(site_net, (str, Path)):
        path = require_path("site network", site_net)
        if not path.is_file():
            raise BadInput(f"site network {str(path)!r} does not exist")
        net, what = _cached_site_net(str(path.resolve()), path.stat().st_mtime), f"site network {str(site_net)!r}"
    elif isinstance(site_net, SiteNet):
        net, what = site_net, "the site network"
    else:
        raise BadInput(f"site_net is {type(site_net).__name__}; expected 'auto', None, a site network file "
                       f"(sitenet.json) or a SiteNet")
    g = net.config.grid
    if not g.same_grid(grid):
        raise BadInput(f"{what} reads a {g.rows} x {g.cols} mat; the model reads {grid.rows} x {grid.cols}: "
                       f"train one for the model (pressurepose train-sites)")
    return net
