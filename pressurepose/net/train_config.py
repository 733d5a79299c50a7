"""The options of a PressureNet training run, checked. Imports no torch: the ``train`` verb builds its
options from these defaults, and a saved model's or a resumable run's record is read back without it.

* :class:`TrainConfig`: every training option (defaults: the ``train`` verb's, which are the paper's,
  appendix B.3 and section 5.2, but for the contact floor and the validation share);
  :data:`PAPER_TRAINING`: the paper's values of those two, so ``TrainConfig(**PAPER_TRAINING)`` is
  the paper's recipe.
* :class:`NoiseConfig`: the training noise model's parameters (:func:`pressurepose.net.noise.add_noise`).
* :data:`CNN_VARIANTS`: the CNN's named widths (:class:`pressurepose.net.cnn.PressureCNN`);
  :data:`LR_SCHEDULES`: the learning-rate schedules.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from pressurepose.errors import BadInput, require_finite, require_non_negative, require_positive, require_whole

LR_SCHEDULES = ("constant", "cosine")
PAPER_CHANNELS = (192, 192, 384, 384)
# named widths of the four conv layers: the paper's, and half as wide (the shipped model's)
CNN_VARIANTS: dict[str, tuple[int, int, int, int]] = {
    "paper": PAPER_CHANNELS,
    "half": (96, 96, 192, 192),
}
# The paper's values of the options whose defaults are not the paper's (a 5 mmHg contact floor reads
# a real mat's faint background as no contact: real posture accuracy 0.57 against 0.43 at 0,
# docs/sim_to_real.md; a 5 % validation share reports a held-out MPJPE each epoch).
# TrainConfig(**PAPER_TRAINING) trains as the paper did; an option a stored run does not name was
# trained at its value here or, for every other option, at TrainConfig's default.
PAPER_TRAINING: dict[str, float] = {"contact_floor_mmhg": 0.0, "val_fraction": 0.0}


@dataclass(frozen=True)
class NoiseConfig:
    """Parameters of :func:`pressurepose.net.noise.add_noise` (units: mmHg for pressures, taxels for
    blur; the paper's training noise, section 5.2 and its public code): mult_std, sd of one gain drawn
    per image about 1; add_std, sd of the noise added to each loaded taxel; clip_max, the sensor's
    saturation; blur_mean, blur_std, the Gaussian blur's sigma drawn per image."""

    mult_std: float = 0.2
    add_std: float = 14.0
    clip_max: float = 100.0
    blur_mean: float = 0.5
    blur_std: float = 0.2

    def __post_init__(self):
        for f in dataclasses.fields(self):
            require_non_negative(f"noise_config.{f.name}", getattr(self, f.name))
        require_positive("noise_config.clip_max", self.clip_max)


@dataclass(frozen=True)
class TrainConfig:
    """Training options; the defaults are the ``train`` verb's: the paper's (appendix B.3, section
    5.2) but for a 5 mmHg contact floor and a 5 % validation share (:data:`PAPER_TRAINING` holds the
    paper's values of the two: ``TrainConfig(**PAPER_TRAINING)`` is the paper's recipe).

    epochs_mod1, epochs_mod2: epochs of each stage; batch_size: images per step; lr, weight_decay:
    Adam's; seed: of the validation split, shuffling, noise, dropout and initialisation. noise_config:
    the training noise (:class:`NoiseConfig`). upsample, blur_sigma: the input's upsampling factor and
    Gaussian blur in taxels (``InputConfig``; the paper's 2 and 0.5). gender_input: the CNN also
    reads the gender flag (not in the paper).
    loss_sigmas: "paper" keeps the paper's sigma_s, sigma_beta; "data" computes them from the
    training set (sigma_Q, sigma_C always come from the data). val_fraction: share of samples held
    out for the per-epoch validation (seeded split; default 0.05, the paper's 0 validates on none).
    gain: output gain (:mod:`.outputs`).
    lr_mod2: Mod2's learning rate (default: lr, as the paper). lr_schedule: "constant" (the paper)
    or "cosine" (each stage's rate falls from its lr to 0 along half a cosine over its epochs, set
    at the start of every epoch). dropout: the CNN's dropout (paper 0.1). use_pmr, edges_contact,
    noise: the paper's ablations.
    save_every: epochs between resumable states (the last epoch of each stage is always saved).
    device: "auto" (CUDA when available), "cpu", "cuda", ...; amp: mixed precision on CUDA.
    cnn: the CNN's widths, a name in :data:`CNN_VARIANTS` ("paper", the
    default, or "half", half as wide: about 3.5x faster to train on a CPU; the shipped model's). cpu_amp: run the
    CNNs in bfloat16 autocast on the CPU (fast where the CPU has bf16 instructions; the body
    layer, PMR and losses stay float32), like ``amp`` on CUDA. contact_floor_mmhg: the input's
    sensor floor in mmHg (``InputConfig.contact_floor_mmhg``; default 5, above 99 % of the faint
    readings a real mat shows away from the body; 0, the paper's, counts any non-zero reading as
    contact); the model keeps it, so inference applies the same floor. turn_loss:
    weight of the turn term (:func:`pressurepose.net.losses.turn_error`) in both modules' losses;
    0, the paper's, leaves it out.
    """

    epochs_mod1: int = 100
    epochs_mod2: int = 100
    batch_size: int = 128
    lr: float = 2e-5
    lr_mod2: float | None = None
    lr_schedule: str = "constant"
    weight_decay: float = 5e-4
    noise: bool = True
    noise_config: NoiseConfig = field(default_factory=NoiseConfig)
    use_pmr: bool = True
    edges_contact: bool = True
    upsample: int = 2
    blur_sigma: float = 0.5
    gender_input: bool = False
    dropout: float = 0.1
    gain: float = 0.1
    loss_sigmas: str = "paper"
    val_fraction: float = 0.05
    seed: int = 0
    device: str = "auto"
    amp: bool = True
    save_every: int = 1
    cnn: str = "paper"
    cpu_amp: bool = False
    contact_floor_mmhg: float = 5.0
    turn_loss: float = 0.0

    def __post_init__(self):
        for name in ("epochs_mod1", "epochs_mod2"):
            require_whole(name, getattr(self, name), 0)
        for name in ("batch_size", "upsample", "save_every"):
            require_whole(name, getattr(self, name), 1)
        for name in ("lr", "lr_mod2"):
            if getattr(self, name) is not None:
                require_positive(f"{name} (learning rate)", getattr(self, name))
        require_non_negative("weight_decay", self.weight_decay)
        if self.lr_schedule not in LR_SCHEDULES:
            raise BadInput(f"lr_schedule = {self.lr_schedule!r}; expected one of {', '.join(LR_SCHEDULES)}")
        if self.loss_sigmas not in ("paper", "data"):
            raise BadInput(f"loss_sigmas = {self.loss_sigmas!r}; expected 'paper' or 'data'")
        require_finite("val_fraction", self.val_fraction)
        if not 0 <= self.val_fraction < 1:
            raise BadInput(f"val_fraction = {self.val_fraction}; expected 0 <= f < 1")
        require_whole("seed", self.seed, 0, 2 ** 63 - 1)  # torch's generators take 64-bit seeds
        require_non_negative("contact_floor_mmhg (a pressure, mmHg)", self.contact_floor_mmhg)
        require_non_negative("turn_loss (a weight)", self.turn_loss)
        if self.cnn not in CNN_VARIANTS:
            raise BadInput(f"cnn = {self.cnn!r}; expected one of {', '.join(CNN_VARIANTS)}")
        for name in ("noise", "use_pmr", "edges_contact", "gender_input", "amp", "cpu_amp"):
            if not isinstance(getattr(self, name), bool):  # "no" would be true
                raise BadInput(f"{name} = {getattr(self, name)!r}; expected True or False")
        if not isinstance(self.noise_config, NoiseConfig):
            raise BadInput(f"noise_config is {type(self.noise_config).__name__}; expected a NoiseConfig")
        require_non_negative("blur_sigma (taxels)", self.blur_sigma)
        require_finite("dropout", self.dropout)
        if not 0.0 <= self.dropout < 1.0:
            raise BadInput(f"dropout is {self.dropout!r}; expected a probability from 0 to below 1 (the paper's 0.1)")
        require_positive("gain (output gain)", self.gain)
        if not isinstance(self.device, str):
            raise BadInput(f"device = {self.device!r}; expected a device name: auto, cpu, cuda, cuda:1 ...")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)
