"""Training the site network (:mod:`pressurepose.net.sitenet`) on simulated data whose samples
record the body site under each taxel (``Sample.sites``).

Each image is first read by a PressureNet (the shipped one by default) and its estimated body's
site map taken (:func:`pressurepose.body.sites.body_loads`): the site network learns to correct it.
Training: AdamW with a cosine learning rate; each batch is mirrored left-right image by image with
probability 1/2 (columns reversed, left and right sites swapped) and, with probability 1/2, passed
through the training noise model (:func:`pressurepose.net.noise.add_noise`). The loss
(:func:`site_loss`) is the cross-entropy of the true site over each image's loaded taxels, each
taxel weighted half by its share of the image's load and half equally, so that every image counts
the same. Training writes ``OUT/state.pt`` after each epoch (read back with ``weights_only=True``)
and resumes from it; the finished network is ``OUT/sitenet.json``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from pressurepose.body.sites import NO_SITE
from pressurepose.errors import BadInput, require_whole
from pressurepose.files import atomic_write
from pressurepose.mat import MatSpec
from pressurepose.net.sitenet import (
    SiteNet,
    SiteNetConfig,
    mirrored_sites,
    read_taxel_sites,
    save_site_net,
    site_inputs,
)


@dataclass(frozen=True)
class SiteTrainConfig:
    """epochs, batch_size, lr (peak, cosine to 0), weight_decay; width: the U-Net's first width; seed."""

    epochs: int = 12
    batch_size: int = 32
    lr: float = 2e-3
    weight_decay: float = 1e-4
    width: int = 32
    seed: int = 0

    def __post_init__(self):
        for name in ("epochs", "batch_size", "width"):
            require_whole(name, getattr(self, name), 1)
        require_whole("seed", self.seed, 0)
        if not (self.lr > 0 and math.isfinite(self.lr)) or not (self.weight_decay >= 0):
            raise BadInput(f"lr {self.lr!r} and weight_decay {self.weight_decay!r}: expected a positive and a "
                           f"non-negative number")


@dataclass(frozen=True)
class SiteData:
    """pressure (N, R, C) float32 mmHg; body_sites (N, R, C) int8, the estimated body's site map;
    truth (N, R, C) int8, the simulator's (``NO_SITE`` where no body force); grid: their mat."""

    pressure: np.ndarray
    body_sites: np.ndarray
    truth: np.ndarray
    grid: MatSpec

    def __post_init__(self):
        shape = self.pressure.shape
        if self.pressure.ndim != 3 or self.body_sites.shape != shape or self.truth.shape != shape \
                or shape[1:] != self.grid.shape:
            raise BadInput(f"site data: pressure {shape}, body_sites {self.body_sites.shape} and truth "
                           f"{self.truth.shape} must all be (N, {self.grid.rows}, {self.grid.cols})")

    def __len__(self) -> int:
        return len(self.pressure)


def body_route_sites(pressure: np.ndarray, gender, model=None, batch_size: int = 256,
                     progress: bool = False) -> np.ndarray:
    """(N, R, C) int8: the site map of the body PressureNet (``model``; None: the shipped one)
    estimates for each image, as :func:`pressurepose.body.sites.body_loads` reads it (progress: a
    bar over the batches on stderr)."""
    from tqdm import tqdm

    from pressurepose.net.infer import estimate

    genders = [gender] * len(pressure) if isinstance(gender, str) else list(gender)
    out = []
    for s in tqdm(range(0, len(pressure), batch_size), desc="estimating bodies", unit="batch",
                  disable=not progress):
        est = estimate(pressure[s:s + batch_size], genders[s:s + batch_size], model=model, site_net=None)
        out.append(est.sites.taxel_site)  # with no site network, the estimated body's own map
    return np.concatenate(out)


def sited_samples(root: str | Path) -> list:
    """Every :class:`~pressurepose.data.schema.Sample` under ``root``; BadInput when there are none
    or some carry no recorded body sites."""
    from pressurepose.data.dataset import DatasetReader

    samples = list(DatasetReader(root))
    if not samples:
        raise BadInput(f"{root} holds no samples")
    missing = sum(s.sites is None for s in samples)
    if missing:
        raise BadInput(f"{missing} of {len(samples)} samples under {root} carry no body sites (made before the "
                       f"simulator recorded them); generate the data again")
    return samples


def load_site_data(root: str | Path, model=None, progress: bool = False) -> SiteData:
    """Every sample under ``root`` (with its recorded sites) and the site maps of the bodies
    ``model`` (None: the shipped PressureNet) estimates for them. BadInput when ``root`` holds no
    samples, samples without recorded sites, or images on another mat than the model's."""
    from pressurepose.net.infer import resolve_model

    samples = sited_samples(root)
    pressure = np.stack([s.pressure for s in samples]).astype(np.float32)
    net = resolve_model(model)
    grid = net.config.grid
    if pressure.shape[1:] != grid.shape:
        raise BadInput(f"the samples under {root} are on a {pressure.shape[1]} x {pressure.shape[2]} mat; "
                       f"the model reads {grid.rows} x {grid.cols}: generate them on the model's mat (--mat)")
    return SiteData(pressure=pressure, body_sites=body_route_sites(pressure, [s.gender for s in samples], net,
                                                                   progress=progress),
                    truth=np.stack([s.sites for s in samples]).astype(np.int8), grid=grid)


VAL_FRACTION = 0.1  # share of the samples ``pressurepose train-sites`` holds out to report on


def held_out_split(data: SiteData, seed: int, fraction: float = VAL_FRACTION) -> tuple[SiteData, SiteData]:
    """(training, held out): a random ``fraction`` of the images (rounded down; seeded) held out."""
    if not 0 <= fraction < 1:
        raise BadInput(f"held-out fraction {fraction!r}; expected 0 <= fraction < 1")
    order = np.random.default_rng([seed, 0x5173]).permutation(len(data))
    held = np.sort(order[:int(fraction * len(data))])
    keep = np.sort(order[len(held):])

    def take(idx):
        return SiteData(pressure=data.pressure[idx], body_sites=data.body_sites[idx], truth=data.truth[idx],
                        grid=data.grid)

    return take(keep), take(held)


def most_loaded_right(data: SiteData, site_net: SiteNet | None) -> float:
    """Share of ``data``'s images whose most loaded body site (by load share, ``other`` included)
    is the simulator's, reading each loaded taxel's site with ``site_net`` (None: the estimated
    body's site map alone)."""
    from pressurepose.body.sites import site_stats

    if not len(data):
        raise BadInput("no images to score")
    p = data.pressure
    body = np.where(p > 0, data.body_sites, NO_SITE).astype(np.int8)
    read = body if site_net is None else read_taxel_sites(site_net, p, body)
    said = site_stats(p, read, data.grid).share.argmax(1)
    truth = site_stats(p, np.where(p > 0, data.truth, NO_SITE).astype(np.int8), data.grid).share.argmax(1)
    return float(np.mean(said == truth))


def site_loss(logits: torch.Tensor, truth: torch.Tensor, pressure: torch.Tensor) -> torch.Tensor:
    """Mean over images of the weighted cross-entropy of the true sites (B, R, C) under logits
    (B, S, R, C) over the loaded taxels (truth >= 0 and pressure > 0): each taxel weighs half its
    share of the image's load plus half of 1 / (loaded taxels). Images with no load count 0."""
    on = (truth >= 0) & (pressure > 0)
    p = torch.where(on, pressure, torch.zeros_like(pressure))
    load = p.sum((1, 2), keepdim=True)
    n = on.sum((1, 2), keepdim=True)
    w = 0.5 * p / load.clamp_min(1e-9) + 0.5 * on / n.clamp_min(1)
    ce = torch.nn.functional.cross_entropy(logits, truth.clamp_min(0).long(), reduction="none")
    return (w * ce).sum((1, 2)).mean()


_MIRROR = mirrored_sites()


def flipped(sites: np.ndarray) -> np.ndarray:
    """Site maps (B, R, C) of the mirrored images: columns reversed, left and right sites swapped."""
    s = np.asarray(sites)[..., ::-1]
    return np.where(s >= 0, _MIRROR[np.clip(s, 0, None)], s).astype(np.int8)


def train_site_net(data: SiteData, config: SiteTrainConfig = SiteTrainConfig(), out: str | Path | None = None,
                   progress: bool = True, meta: dict | None = None) -> SiteNet:
    """A site network trained on ``data``; with ``out``, OUT/state.pt after each epoch (a rerun
    resumes from it) and OUT/sitenet.json at the end (``meta``: more JSON-ready notes for it, such
    as the model and data it was made for)."""
    from tqdm import tqdm

    from pressurepose.net.noise import add_noise

    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    gen = torch.Generator().manual_seed(config.seed)
    net = SiteNet(SiteNetConfig(grid=data.grid, width=config.width))
    opt = torch.optim.AdamW(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    steps = math.ceil(len(data) / config.batch_size)
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda k: 0.5 * (1 + math.cos(math.pi * min(k, steps * config.epochs) / (steps * config.epochs))))
    start = 0
    state_path = None if out is None else Path(out) / "state.pt"
    if state_path is not None and state_path.is_file():
        state = torch.load(state_path, weights_only=True)
        if state["config"] != asdict(config):
            raise BadInput(f"{state_path} was written with other settings {state['config']}; use another folder")
        net.load_state_dict(state["net"])
        opt.load_state_dict(state["opt"])
        sched.load_state_dict(state["sched"])
        rng.bit_generator.state = json.loads(state["rng"])
        gen.set_state(state["gen"])
        start = int(state["epoch"])
    for epoch in range(start, config.epochs):
        net.train()
        order = rng.permutation(len(data))
        total = 0.0
        for s in tqdm(range(0, len(order), config.batch_size), desc=f"sites epoch {epoch + 1}/{config.epochs}",
                      disable=not progress, unit="batch"):
            idx = np.sort(order[s:s + config.batch_size])
            p, body, truth = data.pressure[idx], data.body_sites[idx], data.truth[idx]
            flip = rng.random(len(idx)) < 0.5
            p = np.where(flip[:, None, None], p[..., ::-1], p)
            body = np.where(flip[:, None, None], flipped(body), body)
            truth = np.where(flip[:, None, None], flipped(truth), truth)
            pt = torch.from_numpy(np.ascontiguousarray(p))
            noisy = add_noise(pt, gen)[0] if rng.random() < 0.5 else pt
            x = site_inputs(noisy.numpy(), body, net.config)
            loss = site_loss(net(x), torch.from_numpy(truth.astype(np.int64)), pt)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.detach()) * len(idx)
        if progress:
            tqdm.write(f"sites epoch {epoch + 1}: loss {total / len(data):.4f}")
        if state_path is not None:
            state_path.parent.mkdir(parents=True, exist_ok=True)
            state = {"net": net.state_dict(), "opt": opt.state_dict(), "sched": sched.state_dict(),
                     "rng": json.dumps(rng.bit_generator.state), "gen": gen.get_state(), "epoch": epoch + 1,
                     "config": asdict(config)}
            atomic_write(state_path, lambda tmp: torch.save(state, tmp))
    net.eval()
    if out is not None:
        save_site_net(Path(out) / "sitenet.json", net, {"training": asdict(config), "samples": len(data), **(meta or {})})
    return net


__all__ = ["SiteTrainConfig", "SiteData", "body_route_sites", "sited_samples", "load_site_data", "held_out_split",
           "most_loaded_right", "site_loss", "flipped", "train_site_net", "VAL_FRACTION", "NO_SITE"]
