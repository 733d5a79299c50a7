"""The torch device a run or a model uses, from its name."""

from __future__ import annotations

import torch

from pressurepose.errors import BadInput


def resolve_device(name: str) -> torch.device:
    """A torch device from 'auto' (CUDA when there is one, else the CPU), 'cpu', 'cuda', 'cuda:1'...;
    BadInput for unknown names or CUDA without CUDA."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(name)
    except RuntimeError:
        raise BadInput(f"device {name!r} is not a torch device (e.g. cpu, cuda, cuda:1)") from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise BadInput(f"device {name!r} asked for, but CUDA is not available")
    return dev
