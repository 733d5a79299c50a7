"""Saving and loading trained PressureNets without ever running code from a file.

A model is a ``NAME.json`` (the :class:`NetConfig`, the body models' identities, loss scales and
training notes) with its weights in safetensors files beside it (the format holds tensors only):
``NAME.safetensors`` by default, or one file per module (``NAME.mod1.safetensors``,
``NAME.mod2.safetensors``, listed in the JSON under ``weight_files``) when saved with
``split_modules=True``, which keeps each file small enough for a git repository. A ``.pt`` file
holding ``{"meta": <json text>, "state_dict": {name: tensor}}`` is also read, with
``torch.load(weights_only=True)``: a pickle that would build anything else is refused with
BadInput. The body models are given by spec ("female", "male", "neutral", "toy" or an SMPL-format
file); a loaded model is checked against the stored identity of its bodies.
"""

from __future__ import annotations

import json
from pathlib import Path

import torch

from pressurepose.body.model import BodyModel
from pressurepose.errors import BadInput, require_path
from pressurepose.files import atomic_write, json_text, write_text_atomic
from pressurepose.net.model import (
    GenderedBody,
    NetConfig,
    PressureNet,
    PressureNetModule,
)

FORMAT = "pressurepose.pressurenet/1"


def body_model(spec: str) -> BodyModel:
    """A BodyModel from a spec: 'female' / 'male' / 'neutral' (shipped), 'toy' (the tiny test
    body) or the path of an SMPL-format .npz / .pkl file."""
    if spec == "toy":
        from pressurepose.body.toy import toy_body_arrays

        return BodyModel(toy_body_arrays())
    return BodyModel(spec)


def body_spec(body: BodyModel) -> str:
    """The spec that rebuilds ``body`` (see :func:`body_model`)."""
    if body.arrays.meta.get("source") == "toy":
        return "toy"
    from pressurepose.body.model import asset_path

    if body.gender in ("female", "male", "neutral") and body.path == asset_path(f"{body.gender}.npz"):
        return body.gender
    return str(body.path)


def gendered_body(female: BodyModel, male: BodyModel) -> GenderedBody:
    """The two-gender body layer of a PressureNet (one layer when both are the same model)."""
    f = female.torch_layer()
    return GenderedBody(f, f if male is female else male.torch_layer())


def bodies_meta(female: BodyModel, male: BodyModel) -> dict:
    return {g: {"spec": body_spec(b), "identity": b.identity} for g, b in (("female", female), ("male", male))}


def save_model(path: str | Path, net: PressureNet, bodies: tuple[BodyModel, BodyModel], meta: dict | None = None,
               split_modules: bool = False, dtype: torch.dtype | None = None) -> Path:
    """Write a model at ``path`` (NAME.safetensors / NAME.json, or a single NAME.pt).

    split_modules: weights in one safetensors file per top-level module (NAME.mod1.safetensors, ...)
    instead of one NAME.safetensors. dtype: store floating-point weights in this dtype (e.g.
    torch.float16 to halve the size; loading casts them to the network's dtype). Returns the path to load from.
    """
    from safetensors.torch import save_file

    path = Path(path)
    record = {"format": FORMAT, "config": net.config.to_dict(), "bodies": bodies_meta(*bodies), **(meta or {})}
    record.pop("weight_files", None)  # meta read from another model names that model's files
    weights = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    if dtype is not None:
        weights = {k: v.to(dtype) if v.is_floating_point() else v for k, v in weights.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".pt":
        atomic_write(path, lambda p: torch.save({"meta": json_text(record, indent=None), "state_dict": weights}, p))
        return path
    groups = {"": weights}
    if split_modules:
        groups = {}
        for k, v in weights.items():
            groups.setdefault(k.split(".", 1)[0], {})[k] = v
    files = {f"{path.stem}.{g}.safetensors" if g else f"{path.stem}.safetensors": w for g, w in groups.items()}
    for name, w in files.items():
        atomic_write(path.with_name(name), lambda p, w=w: save_file(w, str(p)))
    if split_modules:
        record["weight_files"] = sorted(files)
    meta_path = path.with_suffix(".json")
    write_text_atomic(meta_path, json_text(record))
    return meta_path if split_modules else path.with_suffix(".safetensors")


def _read_meta(path: Path, text: str) -> dict:
    try:
        meta = json.loads(text)
    except json.JSONDecodeError as exc:
        raise BadInput(f"model file {str(path)!r}: its metadata is not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise BadInput(f"model file {str(path)!r} is not a {FORMAT} model")
    return meta


def _read_safetensors(path: Path, meta_path: Path) -> tuple[dict, dict[str, torch.Tensor]]:
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    meta = _read_meta(path, meta_path.read_text())
    names = meta.get("weight_files", [meta_path.stem + ".safetensors"])
    if not (isinstance(names, list) and names and all(isinstance(n, str) and Path(n).name == n for n in names)):
        raise BadInput(f"model file {str(meta_path)!r}: 'weight_files' must list file names beside it")
    weights: dict[str, torch.Tensor] = {}
    for name in names:
        file = meta_path.with_name(name)
        if not file.is_file():
            raise BadInput(f"model file {str(path)!r}: its weights {str(file)!r} do not exist")
        try:
            part = load_file(str(file))
        except (SafetensorError, OSError, ValueError) as exc:
            raise BadInput(f"model file {str(file)!r} is not a valid safetensors file ({exc})") from None
        if weights.keys() & part.keys():
            raise BadInput(f"model file {str(file)!r} repeats weights of another of its files")
        weights.update(part)
    return meta, weights


def _load_refusal(exc: Exception) -> str:
    """Why torch.load refused a file, naming the blocked global in full when there is one."""
    import re

    text = str(exc)
    blocked = re.search(r"Unsupported global: GLOBAL (\S+)", text) or re.search(r"GLOBAL (\S+)", text)
    if blocked:
        return f"it needs {blocked.group(1).rstrip('.,')}, which only a full unpickler would build; refused"
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return f"{type(exc).__name__}: {lines[0] if lines else ''}"[:300]


def read_model_files(path: str | Path) -> tuple[dict, dict[str, torch.Tensor]]:
    """(meta record, state dict) of a saved model given by its .json, .safetensors, .pt or run
    folder; BadInput for anything that is not one."""
    path = require_path("model file", path)
    if path.is_dir():
        path = path / "model.json"
    if path.suffix in (".json", ".safetensors"):
        meta_path = path.with_suffix(".json")
        if not meta_path.is_file():
            if not path.is_file():
                raise BadInput(f"model file {str(path)!r} does not exist")
            hint = ""
            for module in (".mod1", ".mod2"):  # one module's weights of a model stored per module
                if path.stem.endswith(module) and path.with_name(path.stem[:-len(module)] + ".json").is_file():
                    hint = f"; it holds one module's weights: pass {path.with_name(path.stem[:-len(module)] + '.json')}"
            raise BadInput(f"model file {str(path)!r} has no {meta_path.name} beside it{hint}")
        meta, weights = _read_safetensors(path, meta_path)
    elif path.suffix == ".pt":
        if not path.is_file():
            raise BadInput(f"model file {str(path)!r} does not exist")
        try:
            blob = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as exc:  # the weights-only unpickler refuses anything but tensors and plain data
            raise BadInput(f"model file {str(path)!r} is not a PressureNet checkpoint that can be read "
                           f"safely ({_load_refusal(exc)})") from None
        if not isinstance(blob, dict) or not isinstance(blob.get("meta"), str) or not isinstance(blob.get("state_dict"), dict):
            raise BadInput(f"model file {str(path)!r} does not hold {{'meta': json, 'state_dict': tensors}}")
        meta, weights = _read_meta(path, blob["meta"]), blob["state_dict"]
    else:
        raise BadInput(f"model file {str(path)!r}: expected a .json / .safetensors model or a .pt file")
    if not all(isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in weights.items()):
        raise BadInput(f"model file {str(path)!r}: its weights are not a name -> tensor mapping")
    return meta, weights


def _check_weight_shapes(path, config: NetConfig, weights: dict[str, torch.Tensor]) -> None:
    """BadInput, before any network is built, when a stored CNN or output weight has another shape
    than ``config`` gives it: the network is sized by its config, which must not make it larger
    than the weights the file holds. (Shapes only: built on the meta device, nothing allocated.)"""
    with torch.device("meta"):
        modules = {"mod1": PressureNetModule(config, config.inputs.num_channels()),
                   "mod2": PressureNetModule(config, config.inputs.num_channels(2 if config.use_pmr else 0))}
    for prefix, module in modules.items():
        for name, tensor in module.state_dict().items():
            stored = weights.get(f"{prefix}.{name}")
            if stored is not None and tuple(stored.shape) != tuple(tensor.shape):
                raise BadInput(f"model file {str(path)!r}: its config makes {prefix}.{name} of shape "
                               f"{tuple(tensor.shape)} but the stored weights are {tuple(stored.shape)}; the config "
                               f"(grid, inputs.upsample, cnn_channels, use_pmr, gender_input) does not fit the weights")


def load_model(path: str | Path, bodies: tuple[BodyModel, BodyModel] | None = None,
               device: str | torch.device | None = None) -> tuple[PressureNet, dict]:
    """Load a saved PressureNet (eval mode) and its metadata.

    bodies: (female, male) BodyModels to use; default: rebuilt from the stored specs. Either way
    their identities must equal the stored ones (BadInput otherwise, naming both).
    """
    if bodies is not None and not (isinstance(bodies, (tuple, list)) and len(bodies) == 2
                                   and all(isinstance(b, BodyModel) for b in bodies)):
        raise BadInput(f"bodies is {bodies!r:.80}; expected (female, male) BodyModels (body_model('female'), ...), "
                       f"or None for those the model names")
    if device is not None:
        from pressurepose.net.device import resolve_device

        device = resolve_device(device)
    meta, weights = read_model_files(path)
    if "config" not in meta:
        raise BadInput(f"model file {str(path)!r} holds no 'config'")
    try:
        config = NetConfig.from_dict(meta["config"])
    except BadInput as exc:
        raise BadInput(f"model file {str(path)!r}: config: {exc}") from None
    _check_weight_shapes(path, config, weights)
    stored = meta.get("bodies", {})
    if bodies is None:
        try:
            f = body_model(stored["female"]["spec"])
            m = f if stored["male"]["spec"] == stored["female"]["spec"] else body_model(stored["male"]["spec"])
        except (KeyError, TypeError) as exc:
            raise BadInput(f"model file {str(path)!r} names no body models ({exc})") from None
        bodies = (f, m)
    for g, b in zip(("female", "male"), bodies):
        want = stored.get(g, {}).get("identity")
        if b.identity != want:
            raise BadInput(f"the {g} body model {b.identity} is not the one this model was trained with "
                           f"({want}); pass the same body model files")
    net = PressureNet(config, gendered_body(*bodies))
    try:
        net.load_state_dict(weights, strict=True)
    except RuntimeError as exc:
        raise BadInput(f"model file {str(path)!r}: weights do not fit its config ({str(exc)[:300]})") from None
    net.eval()
    return (net.to(device) if device is not None else net), meta
