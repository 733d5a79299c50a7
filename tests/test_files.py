"""Atomic writers keep the old file on failure; output paths are checked before work."""

import json

import pytest

from pressurepose.errors import BadInput
from pressurepose.files import atomic_write, check_output_path, save_figure_atomic, write_json_atomic


def test_failed_write_keeps_previous_file_and_leaves_no_temp(tmp_path):
    target = tmp_path / "a.json"
    write_json_atomic(target, {"ok": 1})

    def boom(p):
        p.write_text("partial")
        raise RuntimeError("disk died")

    with pytest.raises(RuntimeError):
        atomic_write(target, boom)
    assert json.loads(target.read_text()) == {"ok": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_check_output_path_names_the_problem(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "f").write_text("x")
    with pytest.raises(BadInput, match="is a folder"):
        check_output_path(tmp_path / "d")
    with pytest.raises(BadInput, match="does not exist"):
        check_output_path(tmp_path / "missing" / "x.npz")
    with pytest.raises(BadInput, match="ending in .npz"):
        check_output_path(tmp_path / "x.txt", suffixes=(".npz",))
    with pytest.raises(BadInput, match="is a file"):
        check_output_path(tmp_path / "f", directory=True)
    assert check_output_path(tmp_path / "new" / "deeper", directory=True) == tmp_path / "new" / "deeper"


def test_figure_suffix_checked(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure()
    with pytest.raises(BadInput, match="unknown image suffix"):
        save_figure_atomic(fig, tmp_path / "x.bmpx")
    save_figure_atomic(fig, tmp_path / "x.png")
    assert (tmp_path / "x.png").read_bytes()[:4] == b"\x89PNG"
    plt.close(fig)
