"""The Python the README and docs/ show works as written: every `pressurepose.…` name they give
resolves, the package docstrings name the modules there are, and the code blocks run (on a few
images, a tiny dataset, the inputs their text describes)."""

import importlib
import re
from pathlib import Path

import numpy as np
import pytest
import torch

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def python_blocks(doc: str) -> list[str]:
    """The ```python blocks of README.md or docs/NAME.md, in order."""
    return re.findall(r"```python\n(.*?)```", (ROOT / doc).read_text(), flags=re.S)


def documented_names() -> list[tuple[str, str]]:
    """(doc, name) of every dotted `pressurepose.x.y` the docs give and every `from pressurepose.x import y`."""
    out = set()
    for doc in DOCS:
        text = doc.read_text()
        out |= {(doc.name, m.rstrip(".")) for m in re.findall(r"pressurepose(?:\.[A-Za-z_]\w*)+", text)}
        for module, names in re.findall(r"from (pressurepose[\w.]*) import ([\w, ]+)", text):
            out |= {(doc.name, f"{module}.{n.strip()}") for n in names.split(",")}
    return sorted(out)


def resolve(name: str):
    """The module, or the attribute of the longest importable module prefix, a dotted name names."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(name)


NAMES = documented_names()


def test_the_docs_name_python():
    assert len(NAMES) >= 40


@pytest.mark.parametrize("doc,name", NAMES, ids=[f"{d}:{n}" for d, n in NAMES])
def test_a_documented_name_exists(doc, name):
    try:
        resolve(name)
    except (ImportError, AttributeError) as exc:
        pytest.fail(f"{doc} names {name}, which does not exist ({exc})")


def test_package_docstrings_name_their_modules():
    import pressurepose

    for sub in ("body", "pose", "sim", "data", "net", "eval", "calibrate", "viz", "cli", "mat", "files", "errors"):
        assert f"``{sub}``" in pressurepose.__doc__, sub
    for package in ("net", "eval", "calibrate"):  # the packages whose docstrings list their modules
        doc = importlib.import_module(f"pressurepose.{package}").__doc__
        modules = {p.stem for p in (ROOT / "pressurepose" / package).glob("*.py")} - {"__init__"}
        named = set(re.findall(r"(?:``|:mod:`\.)(\w+)(?:``|`)", doc))
        assert modules <= named, (package, sorted(modules - named))
        stale = {n for n in named if n.islower() and n not in modules  # neither a module nor in one
                 and not any(hasattr(importlib.import_module(f"pressurepose.{package}.{m}"), n) for m in modules)}
        assert not stale, (package, sorted(stale))


@pytest.fixture
def raw_frames():
    """(3, 64, 32) raw readings of a body on PMD experiment I's mat."""
    from tests.data.realfolders import body_image

    return np.stack([body_image(64, 32, seed=k) for k in range(3)])


def test_readme_python_runs(raw_frames):
    from tests.net.golden_image import fixed_images

    (block,) = python_blocks("README.md")
    space = {"betas": np.zeros((2, 10)), "pose": np.zeros((2, 72)), "transl": np.zeros((2, 3)),
             "b": torch.zeros(2, 10), "p": torch.zeros(2, 69), "g": torch.zeros(2, 3), "t": torch.zeros(2, 3),
             "pressure_mmhg": fixed_images(), "frames": raw_frames}
    exec(block, space)
    assert space["verts"].shape == (2, 6889, 3) and space["joints"].shape == (2, 24, 3)
    assert space["out"].joints.shape == (2, 24, 3) and len(space["est"]) == 3


def test_real_mats_python_runs(raw_frames, tmp_path, monkeypatch):
    from tests.data.realfolders import write_pmd_i

    write_pmd_i(tmp_path / "experiment-i")
    monkeypatch.chdir(tmp_path)
    first, folder = python_blocks("docs/real-mats.md")
    space = {"frames": raw_frames}
    exec(first, space)
    assert space["est"].sites.share.shape == (3, 16)
    exec(folder, space)
    assert len(space["real"]) == 6 and set(space["real"].posture) == {"supine", "right", "inclined"}


def test_monitoring_python_runs(raw_frames):
    (block,) = python_blocks("docs/monitoring.md")
    space = {"raw": np.concatenate([np.zeros((1, 64, 32)), raw_frames, raw_frames])}  # nobody on the mat, then a body
    exec(block, space)
    night = space["night"]
    assert len(night) == 7 and not night.estimated[0] and night.estimated[1]  # nobody, then a body the network read
    assert set(night.posture) == {"supine"}  # the one empty second joins the posture after it


def test_physics_python_runs():
    (block,) = python_blocks("docs/physics.md")
    space = {}
    exec(block, space)
    assert space["out"].image.pressure.shape == (64, 27)


def test_training_python_runs(tmp_path, monkeypatch):
    """The training walk-through, on bodies of the cheap test producer instead of the physics."""
    import functools

    import pressurepose.data.schema as schema

    monkeypatch.setattr(schema, "GenerationConfig", functools.partial(schema.GenerationConfig, producer="synthetic"))
    monkeypatch.chdir(tmp_path)
    (block,) = python_blocks("docs/training.md")
    space = {}
    exec(block, space)
    assert len(space["result"].history) == 3 and len(space["est"]) == 2
    assert (tmp_path / "runs" / "py" / "model.json").is_file()
