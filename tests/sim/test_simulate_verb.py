import numpy as np

from pressurepose.body import BodyModel
from pressurepose.cli import main


def test_simulate_writes_labels_that_match_the_images(tmp_path, capsys):
    out = tmp_path / "s.npz"
    assert main(["simulate", "--partition", "general_supine", "--gender", "f", "--count", "1", "--seed", "2",
                 "--out", str(out), "--plot", str(tmp_path / "s.png")]) == 0
    z = np.load(out)
    assert z["pressure"].shape == (1, 64, 27) and z["pose"].shape == (1, 72)
    _, joints = BodyModel("f").forward(z["betas"], z["pose"], z["transl"])
    np.testing.assert_allclose(joints, z["joints"], atol=1e-9)
    weight = z["mass"][0] * 9.81
    assert 0.6 * weight < z["force"][0].sum() <= 1.001 * weight  # the sensing area carries most of it
    assert (tmp_path / "s.png").stat().st_size > 20_000


def test_simulate_bad_input(tmp_path, capsys):
    assert main(["simulate", "--partition", "sideways", "--gender", "f", "--out", str(tmp_path / "x.npz")]) == 2
    assert "sideways" in capsys.readouterr().err
    assert main(["simulate", "--partition", "general", "--gender", "f", "--count", "0",
                 "--out", str(tmp_path / "x.npz")]) == 2


def test_simulate_passes_the_height_reference_to_the_sampler(tmp_path, capsys):
    poses = {}
    for ref in ("proximal", "bed"):
        out = tmp_path / f"{ref}.npz"
        assert main(["simulate", "--partition", "general", "--gender", "f", "--count", "1", "--seed", "4",
                     "--height-reference", ref, "--out", str(out)]) == 0
        poses[ref] = np.load(out)["pose"][0]
    assert not np.allclose(poses["proximal"], poses["bed"])
