"""The package's floors hold at run time too: inference, scoring and the real-data readers load no
simulator, and the layer contracts in pyproject.toml are the ones `make test` checks."""

import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_inference_scoring_and_readers_import_without_mujoco():
    code = ("import sys, pressurepose.net.infer, pressurepose.eval.real, pressurepose.eval.realism, "
            "pressurepose.data.readers.real, pressurepose.data.realprep\n"
            "assert 'mujoco' not in sys.modules, sorted(m for m in sys.modules if 'mujoco' in m)")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)


def test_the_simulator_does_load_mujoco():  # the check above can fail: the settle's import is seen
    code = "import sys, pressurepose.sim.settle\nassert 'mujoco' in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)


def test_generate_parses_its_arguments_without_the_heavy_libraries():
    # the verb's options load pressurepose.sim (for --settle and the bed): no scipy.fft (0.25 s),
    # MuJoCo, torch or trimesh until a body is sampled, settled or pressed
    code = ("import sys\nfrom pressurepose.cli import main\n"
            "try:\n    main(['generate', '--help'])\nexcept SystemExit:\n    pass\n"
            "assert 'pressurepose.sim.press' in sys.modules\n"
            "heavy = [m for m in ('scipy.fft', 'scipy.sparse', 'mujoco', 'torch', 'trimesh') if m in sys.modules]\n"
            "assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO, capture_output=True)


def test_train_parses_its_arguments_without_torch():
    # the verb's defaults and choices come from the training configuration, which builds without torch
    # (about 2 s of start-up); torch loads when training starts
    code = ("import sys\nfrom pressurepose.cli import main\n"
            "try:\n    main(['train', '--help'])\nexcept SystemExit:\n    pass\n"
            "assert 'pressurepose.cli.net' in sys.modules\n"
            "assert 'torch' not in sys.modules, sorted(m for m in sys.modules if m.startswith('pressurepose.'))")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO, capture_output=True)


def test_training_does_load_torch():  # the check above can fail: the training loop's import is seen
    code = "import sys, pressurepose.net.train\nassert 'torch' in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)


def test_a_pasternak_press_does_load_scipy_fft():  # the check above can fail: the lazy import is seen
    code = ("import sys, numpy as np\nfrom pressurepose.sim.foundation import PasternakFoundation\n"
            "assert 'scipy.fft' not in sys.modules\n"
            "PasternakFoundation((2, 3), (0.03, 0.03), 1e5, 10.0).flexibility(np.ones((2, 3)))\n"
            "assert 'scipy.fft' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)


def test_every_subpackage_is_on_a_floor():
    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = next(c for c in config["contracts"] if c["type"] == "layers")["layers"]
    named = {m.strip() for layer in layers for m in layer.split("|")}
    root = REPO / "pressurepose"
    modules = {f"pressurepose.{p.name}" for p in root.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    modules |= {f"pressurepose.{p.stem}" for p in root.glob("*.py") if p.stem != "__init__"}
    assert modules == named


def test_settle_and_dataset_configs_are_checked_without_mujoco():
    code = ("import sys, pressurepose.sim.settle_config, pressurepose.data.schema, pressurepose.sim.simulate\n"
            "pressurepose.sim.settle_config.settle_preset('paper')\n"
            "assert 'mujoco' not in sys.modules, sorted(m for m in sys.modules if 'mujoco' in m)")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPO)
