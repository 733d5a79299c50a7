"""Atomic writers keep the old file on failure; output paths are checked before work."""

import json
from pathlib import Path

import numpy as np
import pytest

from pressurepose.errors import BadInput
from pressurepose.files import (
    atomic_write,
    check_output_path,
    save_figure_atomic,
    write_json_atomic,
)


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


def test_write_errors_become_bad_input_naming_the_file(tmp_path, monkeypatch):
    import errno
    import os

    from pressurepose.files import write_text_atomic

    target = tmp_path / "a.txt"
    target.write_text("old")

    def refused(src, dst):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(os, "replace", refused)
    with pytest.raises(BadInput, match="cannot write .*a.txt: Permission denied"):
        write_text_atomic(target, "new")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_two_phase_write_and_npz_to_the_exact_name(tmp_path):
    import numpy as np

    from pressurepose.files import commit, save_npz_atomic, stage

    tmp = stage(tmp_path / "b.bin", lambda p: p.write_bytes(b"data"))
    assert not (tmp_path / "b.bin").exists() and tmp.read_bytes() == b"data"
    commit(tmp, tmp_path / "b.bin")
    assert (tmp_path / "b.bin").read_bytes() == b"data" and not tmp.exists()
    save_npz_atomic(tmp_path / "arrays.dat", x=np.arange(3))  # numpy would have written arrays.dat.npz
    with np.load(tmp_path / "arrays.dat") as z:
        assert z["x"].tolist() == [0, 1, 2]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arrays.dat", "b.bin"]


def test_atomic_write_gives_a_plain_file_mode_even_when_the_writer_makes_a_private_file(tmp_path):
    import os

    def private(p):  # as safetensors' save_file does
        fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        os.write(fd, b"x")
        os.close(fd)

    mask = os.umask(0o022)
    try:
        atomic_write(tmp_path / "w.bin", private)
    finally:
        os.umask(mask)
    assert (tmp_path / "w.bin").stat().st_mode & 0o777 == 0o644


def test_load_npz_names_the_file_for_every_way_it_can_be_wrong(tmp_path):
    import numpy as np

    from pressurepose.files import load_npz

    good = tmp_path / "good.npz"
    np.savez(good, a=np.arange(3), b=np.ones(2))
    assert set(load_npz(good, "thing")) == {"a", "b"}
    assert list(load_npz(good, "thing", ("b",))) == ["b"]
    with pytest.raises(BadInput, match=r"thing '.*good.npz' lacks c"):
        load_npz(good, "thing", ("a", "c"))
    data = good.read_bytes()
    cases = {"half.npz": data[: len(data) // 2], "garbage.npz": b"PK\x03\x04garbage", "text.npz": b"1,2,3\n",
             "empty.npz": b""}
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(BadInput, match=rf"thing '.*{name}' is (corrupt|not a readable .npz)"):
            load_npz(tmp_path / name, "thing")
    with pytest.raises(BadInput, match="no .npy / .npz header"):
        load_npz(tmp_path / "text.npz", "thing")
    np.save(tmp_path / "one.npy", np.zeros(3))
    with pytest.raises(BadInput, match="holds one array"):
        load_npz(tmp_path / "one.npy", "thing")
    with pytest.raises(BadInput, match="missing.npz"):
        load_npz(tmp_path / "missing.npz", "thing")


@pytest.mark.parametrize("loader", ["pose.samples:load_samples", "body.capsules:load_regressors",
                                    "calibrate.measurements:load_measurements", "body.smpl_io:load_body_arrays"])
def test_every_npz_reader_refuses_a_corrupt_archive_by_name(tmp_path, loader):
    """A damaged .npz is a BadInput naming the file, not zipfile's own error."""
    import importlib

    module, name = loader.split(":")
    read = getattr(importlib.import_module(f"pressurepose.{module}"), name)
    bad = tmp_path / "damaged.npz"
    bad.write_bytes(b"PK\x03\x04garbage")
    with pytest.raises(BadInput, match="damaged.npz' is corrupt"):
        read(bad)


def test_read_npy_refuses_an_npz_and_a_header_larger_than_the_file(tmp_path):
    from pressurepose.files import read_npy

    npz = tmp_path / "x.npy"
    with open(npz, "wb") as fh:
        np.savez(fh, pressure=np.zeros((2, 64, 27)))
    with pytest.raises(BadInput, match="npz archive under another name"):
        read_npy(npz, "pressure")
    huge = tmp_path / "huge.npy"
    with open(huge, "wb") as fh:
        np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False,
                                                  "shape": (10**9, 64, 27)})
        fh.write(b"\0" * 800)
    with pytest.raises(BadInput, match=r"claims an array of shape \(1000000000, 64, 27\).*truncated"):
        read_npy(huge, "pressure")
    good = tmp_path / "good.npy"
    np.save(good, np.ones((3, 4)))
    assert read_npy(good, "pressure").shape == (3, 4)


def test_an_output_folder_that_cannot_be_made_is_refused_up_front(tmp_path):
    from pressurepose.files import check_output_path

    blocked = tmp_path / "ro"
    blocked.mkdir()
    (blocked / "file").write_text("x")
    with pytest.raises(BadInput, match="--out"):  # a file where a folder must go: mkdir fails
        check_output_path(blocked / "file" / "sub", "--out", directory=True)
    if Path("/proc").is_dir():
        with pytest.raises(BadInput, match="cannot create or write"):
            check_output_path("/proc/pressurepose-out", "--out", directory=True)
    fresh = tmp_path / "a" / "b"
    assert check_output_path(fresh, "--out", directory=True) == fresh and not (tmp_path / "a").exists()


def test_json_written_is_strict_with_non_finite_values_as_null(tmp_path):
    """No writer can put NaN / Infinity literals (which strict JSON readers refuse) in a file:
    write_json_atomic turns them into null, in nested dicts, lists, tuples and numpy values."""
    record = {"a": float("nan"), "b": [1.0, float("inf"), (np.float32("-inf"), 2)], "c": np.array([np.nan, 3.0]),
              "d": {"e": np.float64(np.nan), 4: np.int64(5)}, "f": "NaN"}
    write_json_atomic(tmp_path / "x.json", record)
    text = (tmp_path / "x.json").read_text()

    def refuse(token):
        raise ValueError(f"non-strict literal {token}")

    assert json.loads(text, parse_constant=refuse) == {"a": None, "b": [1.0, None, [None, 2]], "c": [None, 3.0],
                                                       "d": {"e": None, "4": 5}, "f": "NaN"}


def test_stale_numbered_outputs_of_a_longer_run_are_removed(tmp_path):
    from pressurepose.files import remove_stale_numbered

    for name in ("mesh_000.ply", "mesh_001.obj", "mesh_1000.ply", "mesh_notes.ply", "estimate_000.png", "mine.ply"):
        (tmp_path / name).write_text("x")
    remove_stale_numbered(tmp_path, "mesh_", (".ply", ".obj"), [tmp_path / "mesh_000.ply"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["estimate_000.png", "mesh_000.ply", "mesh_notes.ply",
                                                          "mine.ply"]


def test_an_output_path_that_is_not_a_path_is_refused_by_name():
    from pressurepose.files import check_output_path

    for path in (None, 3):
        with pytest.raises(BadInput, match=r"^--out is .*; expected a path"):
            check_output_path(path, "--out", directory=True)
        with pytest.raises(BadInput, match=r"^--plot is .*; expected a path"):
            check_output_path(path, "--plot", suffixes=(".png",))
