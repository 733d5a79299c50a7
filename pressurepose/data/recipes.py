"""Recipes: a whole mix of partitions and counts (e.g. the paper's) made by one command.

A recipe is a JSON file ``{"format": "pressurepose-recipe", "entries": [...]}``; each entry has a
``name`` (its sub-directory of the output, e.g. ``"train/general_f_plo"``), ``split``, and the
config keys ``partition``, ``gender``, ``limbs_on_bed``, ``count``, ``seed``. Settings shared by all
entries (mat, shard size, producer, options) come from the command line. ``"paper"`` names the
shipped recipe ``recipes/paper.json`` (the partitions and counts of the paper's appendix A.7 table).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from pressurepose.data.schema import GenerationConfig
from pressurepose.errors import BadInput

_ENTRY_KEYS = {"name", "split", "partition", "gender", "limbs_on_bed", "count", "seed"}


@dataclass(frozen=True)
class RecipeEntry:
    name: str
    split: str
    config: GenerationConfig


def recipe_path(spec: str | Path) -> Path:
    """``"paper"`` -> the shipped recipe; otherwise ``spec`` must be an existing file."""
    shipped = resources.files("pressurepose.data") / "recipes" / f"{spec}.json"
    if shipped.is_file():
        return Path(str(shipped))
    path = Path(spec).expanduser()
    if not path.is_file():
        raise BadInput(f"recipe {str(spec)!r} is neither a shipped recipe (paper) nor an existing file")
    return path


def load_recipe(spec: str | Path, *, scale: float = 1.0, **common: Any) -> list[RecipeEntry]:
    """The recipe's entries as configs. ``scale`` multiplies every count (at least 1 sample each),
    ``common`` sets shared config fields (mat, shard_size, producer, options, max_attempts)."""
    path = recipe_path(spec)
    try:
        raw = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise BadInput(f"recipe {path}: not valid JSON ({exc})") from None
    if not isinstance(raw, dict) or raw.get("format") != "pressurepose-recipe" or \
            not isinstance(raw.get("entries"), list) or not raw["entries"]:
        raise BadInput(f"recipe {path}: expected {{\"format\": \"pressurepose-recipe\", \"entries\": [...]}}")
    if not scale > 0:
        raise BadInput(f"recipe scale {scale}: expected a positive number")
    entries, names, streams = [], set(), {}
    for i, e in enumerate(raw["entries"]):
        if not isinstance(e, dict) or set(e) - _ENTRY_KEYS or not {"name", "partition", "gender", "count"} <= set(e):
            raise BadInput(f"recipe {path}: entry {i} must have name, partition, gender, count and only "
                           f"{', '.join(sorted(_ENTRY_KEYS))}")
        if isinstance(e["count"], bool) or not isinstance(e["count"], int) or e["count"] < 1:
            raise BadInput(f"recipe {path}: entry {i} has count {e['count']!r}; expected a whole number >= 1")
        name = str(e["name"])
        if name in names or Path(name).is_absolute() or ".." in Path(name).parts:
            raise BadInput(f"recipe {path}: entry name {name!r} is repeated or not a relative path")
        names.add(name)
        config = GenerationConfig(partition=e["partition"], gender=e["gender"],
                                  limbs_on_bed=bool(e.get("limbs_on_bed", False)),
                                  count=max(1, round(int(e["count"]) * scale)), seed=int(e.get("seed", 0)),
                                  **common)
        stream = (config.partition, config.gender, config.limbs_on_bed, config.seed)
        if stream in streams:
            raise BadInput(f"recipe {path}: entries {streams[stream]!r} and {name!r} have the same partition, "
                           f"gender, limbs_on_bed and seed, so they would hold the same bodies; give one "
                           f"another seed")
        streams[stream] = name
        entries.append(RecipeEntry(name, str(e.get("split", "")), config))
    return entries
