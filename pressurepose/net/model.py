"""PressureNet (paper section 4): two modules in series, each CNN -> output limits -> body layer -> PMR.

Mod1 sees the pressure channels (P, E, C_I); Mod2 sees the same plus the two maps PMR reconstructed
from Mod1's body (Q_1, C_O,1) and predicts residuals on Mod1's unconstrained parameters. Gender
(0 female, 1 male) selects which body model each batch element is posed with.

Ablations (paper Table 2): ``use_pmr=False`` drops the PMR channels from Mod2 (and the map terms
from its loss); ``InputConfig.edges_contact=False`` drops E and C_I; the noise is a training option
(:mod:`pressurepose.net.train`).
"""

from __future__ import annotations

import contextlib
from dataclasses import asdict, dataclass, field

import torch
from torch import nn

from pressurepose.errors import (
    BadInput,
    require_finite,
    require_positive,
    require_whole,
)
from pressurepose.mat import MatSpec
from pressurepose.net.cnn import (
    NUM_OUTPUTS,
    PressureCNN,
    conv_output_size,
    flattened_size,
)
from pressurepose.net.outputs import BodyParams, OutputConfig, OutputLayer
from pressurepose.net.pmr import PMRConfig, PMRMaps, pmr
from pressurepose.net.train_config import PAPER_CHANNELS
from pressurepose.net.transforms import InputConfig, input_channels, map_channels

GENDER_CODES = {"f": 0, "female": 0, "m": 1, "male": 1}
MAX_CHANNELS = 4096          # widest CNN layer a config may ask for (the paper's widest: 384)
MAX_FC_WEIGHTS = 250_000_000  # one module's linear layer (the paper's 64 x 27 mat at x2: 5.9e6; SLP at x2: 1.1e8)


def full_precision(device: torch.device):
    """A context that turns autocast off: the input transforms, body layer and PMR run in float32
    even inside a mixed-precision training step (only the CNNs run in half precision)."""
    if device.type in ("cuda", "cpu"):
        return torch.autocast(device.type, enabled=False)
    return contextlib.nullcontext()


@dataclass(frozen=True)
class NetConfig:
    """Everything that fixes a PressureNet's architecture and meaning; stored with checkpoints.

    grid: the mat (rows, cols, pitches). inputs, outputs, pmr: see their modules.
    use_pmr: Mod2 gets Mod1's PMR maps (False: the paper's "PMR ablated" network).
    gender_input: append the gender flag to the CNN features (not in the paper; default off).
    dropout: CNN dropout probability (paper 0.1).
    cnn_channels: the widths of the CNN's four conv layers (the paper's (192, 192, 384, 384); see
    :data:`pressurepose.net.train_config.CNN_VARIANTS` for the named widths).
    """

    grid: MatSpec
    outputs: OutputConfig
    inputs: InputConfig = field(default_factory=InputConfig)
    pmr: PMRConfig = field(default_factory=PMRConfig)
    use_pmr: bool = True
    gender_input: bool = False
    dropout: float = 0.1
    cnn_channels: tuple[int, int, int, int] = PAPER_CHANNELS

    def __post_init__(self):
        """BadInput naming the field for values no network can be built from, or a network whose
        linear layers would exceed :data:`MAX_FC_WEIGHTS` (an input far larger than any mat's)."""
        for name, kind in (("grid", MatSpec), ("outputs", OutputConfig), ("inputs", InputConfig), ("pmr", PMRConfig)):
            if not isinstance(getattr(self, name), kind):
                raise BadInput(f"{name} is {type(getattr(self, name)).__name__}; expected a {kind.__name__}")
        for name in ("use_pmr", "gender_input"):
            if not isinstance(getattr(self, name), bool):
                raise BadInput(f"{name} is {getattr(self, name)!r}; expected true or false")
        require_finite("dropout", self.dropout)
        if not 0.0 <= self.dropout < 1.0:
            raise BadInput(f"dropout is {self.dropout!r}; expected a probability from 0 to below 1 (the paper's 0.1)")
        channels = self.cnn_channels
        if isinstance(channels, (str, bytes)) or not hasattr(channels, "__len__") or len(channels) != 4:
            raise BadInput(f"cnn_channels is {channels!r}; expected the widths of the CNN's four conv layers")
        for i, c in enumerate(channels):
            require_whole(f"cnn_channels[{i}]", c, 1, MAX_CHANNELS)
        object.__setattr__(self, "cnn_channels", tuple(int(c) for c in channels))
        p = self.pmr
        require_whole("pmr.fill_passes", p.fill_passes, 0, 64)
        for name in ("empty_depth_m", "contact_softness_m", "q_scale"):
            require_positive(f"pmr.{name}", getattr(p, name))
        h, w = self.inputs.input_size(self.grid.rows, self.grid.cols)
        oh, ow = conv_output_size(h, w)
        if oh < 1 or ow < 1:
            raise BadInput(f"grid {self.grid.rows} x {self.grid.cols} at inputs.upsample {self.inputs.upsample} is a "
                           f"{h} x {w} input; the CNN needs at least 31 x 31")
        fc = (flattened_size(h, w, self.cnn_channels[-1]) + 1) * NUM_OUTPUTS
        if fc > MAX_FC_WEIGHTS:
            raise BadInput(f"grid {self.grid.rows} x {self.grid.cols} at inputs.upsample {self.inputs.upsample} with "
                           f"cnn_channels {self.cnn_channels} makes a linear layer of {fc:.3g} weights; expected at "
                           f"most {MAX_FC_WEIGHTS:.3g} (a smaller upsample or fewer channels)")

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "NetConfig":
        """Inverse of :meth:`to_dict`; BadInput naming the field (``grid``, ``outputs.gain``,
        ``dropout`` ...) for a missing, unknown or unusable one."""
        if not isinstance(d, dict):
            raise BadInput(f"config is {type(d).__name__}; expected a JSON object")
        d = dict(d)
        if "cnn_channels" not in d:
            raise BadInput("lacks 'cnn_channels'")
        parts = {}
        for name, build in (("grid", MatSpec.from_dict), ("outputs", OutputConfig), ("inputs", InputConfig),
                            ("pmr", PMRConfig)):
            if name not in d:
                raise BadInput(f"lacks {name!r}")
            part = d.pop(name)
            if not isinstance(part, dict):
                raise BadInput(f"{name} is {part!r:.80}; expected a JSON object")
            try:
                parts[name] = build(part) if name == "grid" else build(**part)
            except TypeError as exc:  # an unknown or a missing field
                raise BadInput(f"{name}: {exc}") from None
            except BadInput as exc:
                raise BadInput(f"{name}: {exc}" if name == "grid" else str(exc)) from None
        try:
            return NetConfig(**parts, **d)
        except TypeError as exc:
            raise BadInput(str(exc).replace("NetConfig.__init__()", "config")) from None


@dataclass
class ModuleOutput:
    """One module's estimate: params, vertices (B, V, 3) and joints (B, 24, 3) in the bed frame
    (metres), and its PMR maps (vertices and maps None where they were not asked for)."""

    params: BodyParams
    vertices: torch.Tensor | None
    joints: torch.Tensor
    maps: PMRMaps | None


class GenderedBody(nn.Module):
    """Poses each batch element with the body layer of its gender (0 female, 1 male).

    Both layers must share a mesh topology (same vertex count). Pass the same layer twice for a
    single (e.g. neutral or toy) body.
    """

    def __init__(self, female: nn.Module, male: nn.Module):
        super().__init__()
        if female.v_template.shape != male.v_template.shape:
            raise ValueError(f"female and male bodies differ in vertex count ({female.v_template.shape[0]} "
                             f"vs {male.v_template.shape[0]}); PressureNet needs one topology")
        self.layers = nn.ModuleList([female] if female is male else [female, male])

    @property
    def faces(self) -> torch.Tensor:
        return self.layers[0].faces

    def forward(self, params: BodyParams, gender: torch.Tensor, vertices: bool = True,
                ) -> tuple[torch.Tensor | None, torch.Tensor]:
        """Vertices (B, V, 3) (None with ``vertices=False``) and joints (B, 24, 3) in float32
        (outside any autocast)."""
        with full_precision(params.betas.device):
            args = dict(betas=params.betas.float(), body_pose=params.body_pose.float(),
                        global_orient=params.global_orient.float(), transl=params.transl.float())
            args["check"] = False  # the network's own outputs: NaN there is a training problem, not bad input
            if len(self.layers) == 1:
                out = self.layers[0](**args, vertices=vertices)
                return out.vertices, out.joints
            if gender.device.type != "cpu":
                return self._posed_by_selection(args, gender, vertices)
            if bool(((gender < 0) | (gender > 1)).any()):
                raise ValueError("gender must hold 0 (female) or 1 (male) for every batch element")
            verts = joints = None
            for g, layer in enumerate(self.layers):
                idx = (gender == g).nonzero().squeeze(1)
                if idx.numel() == 0:
                    continue
                out = layer(**{k: v.index_select(0, idx) if torch.is_tensor(v) else v for k, v in args.items()},
                            vertices=vertices)
                if joints is None:
                    b = gender.shape[0]
                    joints = out.joints.new_zeros((b,) + out.joints.shape[1:])
                    if vertices:
                        verts = out.vertices.new_zeros((b,) + out.vertices.shape[1:])
                joints = joints.index_copy(0, idx, out.joints)
                if vertices:
                    verts = verts.index_copy(0, idx, out.vertices)
            return verts, joints

    def _posed_by_selection(self, args: dict, gender: torch.Tensor, vertices: bool,
                            ) -> tuple[torch.Tensor | None, torch.Tensor]:
        """Both bodies for the whole batch, each element's picked by its gender (1 male, anything else
        female; not checked): the path on a GPU, where splitting the batch by gender would read the
        genders back to the host, a wait for the GPU, every call. Twice the body arithmetic, which a
        GPU does not notice (a CPU would, so the CPU splits the batch instead)."""
        female, male = (layer(**args, vertices=vertices) for layer in self.layers)
        is_male = (gender == 1)[:, None, None]
        joints = torch.where(is_male, male.joints, female.joints)
        verts = torch.where(is_male, male.vertices, female.vertices) if vertices else None
        return verts, joints


class PressureNetModule(nn.Module):
    """CNN + output layer of one module (the body layer and PMR are shared by the two modules)."""

    def __init__(self, config: NetConfig, in_channels: int, zero_init: bool = False):
        super().__init__()
        h, w = config.inputs.input_size(config.grid.rows, config.grid.cols)
        self.cnn = PressureCNN(in_channels, h, w, dropout=config.dropout, gender_input=config.gender_input,
                               channels=config.cnn_channels)
        self.outputs = OutputLayer(config.outputs)
        if zero_init:  # a residual module starts as the identity on its base estimate
            nn.init.zeros_(self.cnn.fc.weight)
            nn.init.zeros_(self.cnn.fc.bias)

    def forward(self, x: torch.Tensor, gender: torch.Tensor, base: BodyParams | None = None) -> BodyParams:
        return self.outputs(self.cnn(x, gender), base)


class PressureNet(nn.Module):
    """Mod1 + Mod2 with the gendered body layer and PMR.

    >>> net = PressureNet(config, GenderedBody(female_layer, male_layer))
    >>> out1, out2 = net(pressure, gender)   # pressure (B, R, C) mmHg, gender (B,) long
    """

    def __init__(self, config: NetConfig, body: GenderedBody):
        super().__init__()
        self.config = config
        self.body = body
        self.mod1 = PressureNetModule(config, config.inputs.num_channels())
        self.mod2 = PressureNetModule(config, config.inputs.num_channels(2 if config.use_pmr else 0),
                                      zero_init=True)

    def pose_body(self, params: BodyParams, gender: torch.Tensor, maps: bool, vertices: bool = True) -> ModuleOutput:
        """The body (and with ``maps`` its PMR maps) for ``params``; ``vertices=False`` (and no
        maps) poses the skeleton only, all that the joint and beta losses need."""
        verts, joints = self.body(params, gender, vertices=vertices or maps)
        with full_precision(joints.device):
            m = pmr(verts, self.config.grid, self.config.pmr) if maps else None
        return ModuleOutput(params, verts, joints, m)

    def run_mod1(self, x1: torch.Tensor, gender: torch.Tensor, maps: bool = True, vertices: bool = True,
                 ) -> ModuleOutput:
        """Mod1 on its input channels x1 (B, K1, H, W)."""
        return self.pose_body(self.mod1(x1, gender), gender, maps, vertices)

    def mod2_input(self, x1: torch.Tensor, out1: ModuleOutput) -> torch.Tensor:
        """Mod2's input: x1 plus (with PMR) the channels of Mod1's maps Q_1 and C_O,1 (no gradient)."""
        if not self.config.use_pmr:
            return x1
        m = out1.maps if out1.maps is not None else pmr(out1.vertices, self.config.grid, self.config.pmr)
        extra = torch.stack([m.q, m.contact], 1).detach()
        with full_precision(x1.device):
            return torch.cat([x1, map_channels(extra.float(), self.config.inputs).to(x1.dtype)], 1)

    def run_mod2(self, x1: torch.Tensor, gender: torch.Tensor, out1: ModuleOutput, maps: bool = True,
                 vertices: bool = True) -> ModuleOutput:
        """Mod2 refining ``out1`` (its parameters are the base of Mod2's residuals, no gradient)."""
        base = BodyParams(**{k: v.detach() for k, v in vars(out1.params).items()})
        return self.pose_body(self.mod2(self.mod2_input(x1, out1), gender, base), gender, maps, vertices)

    def inputs(self, pressure: torch.Tensor, contact: torch.Tensor | None = None,
               blur_sigma: torch.Tensor | None = None) -> torch.Tensor:
        """Mod1's input channels from pressure images (B, R, C) (see ``transforms.input_channels``)."""
        with full_precision(pressure.device):
            return input_channels(pressure.float(), self.config.inputs, contact=contact, blur_sigma=blur_sigma)

    def forward(self, pressure: torch.Tensor, gender: torch.Tensor) -> tuple[ModuleOutput, ModuleOutput]:
        """Both modules' estimates for clean pressure images (B, R, C) and genders (B,)."""
        x1 = self.inputs(pressure)
        out1 = self.run_mod1(x1, gender, maps=self.config.use_pmr)
        return out1, self.run_mod2(x1, gender, out1)
