"""Loading SMPL-format files: npz round trip, official-style pickles without chumpy, unsafe input."""

import pickle
import sys
import types

import numpy as np
import pytest
import scipy.sparse

from pressurepose.body import BodyModel, load_body_arrays, save_body_arrays
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rodrigues
from pressurepose.body.smpl_io import SmplArrays, safe_pickle_load
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput


def raw_dict(a: SmplArrays) -> dict:
    return dict(v_template=a.v_template, shapedirs=a.shapedirs, posedirs=a.posedirs,
                J_regressor=a.J_regressor, weights=a.weights,
                kintree_table=np.stack([np.where(a.parents < 0, 2**32 - 1, a.parents), np.arange(24)]),
                f=a.faces)


def test_npz_round_trip(tmp_path):
    a = toy_body_arrays()
    save_body_arrays(tmp_path / "m.npz", a)
    b = load_body_arrays(tmp_path / "m.npz")
    np.testing.assert_allclose(b.v_template, a.v_template, atol=1e-7)
    np.testing.assert_array_equal(b.parents, a.parents)
    assert b.meta["gender"] == "neutral"
    assert BodyModel(tmp_path / "m.npz").num_vertices == 192


@pytest.fixture
def fake_chumpy(monkeypatch):
    """A module named chumpy.ch with a class Ch, present only while pickles are written."""
    pkg, mod = types.ModuleType("chumpy"), types.ModuleType("chumpy.ch")

    class Ch:
        def __init__(self, x):
            self.x = x
            self._dirty_vars = set()

    Ch.__module__ = "chumpy.ch"
    Ch.__qualname__ = "Ch"
    mod.Ch = Ch
    pkg.ch = mod
    monkeypatch.setitem(sys.modules, "chumpy", pkg)
    monkeypatch.setitem(sys.modules, "chumpy.ch", mod)
    return Ch


@pytest.mark.parametrize("protocol", [0, 2])
def test_official_style_pickle_loads_without_chumpy(tmp_path, fake_chumpy, monkeypatch, protocol):
    a = toy_body_arrays()
    raw = raw_dict(a)
    raw["shapedirs"] = fake_chumpy(a.shapedirs)
    raw["v_template"] = fake_chumpy(a.v_template)
    raw["J_regressor"] = scipy.sparse.csc_matrix(a.J_regressor)
    raw["bs_style"] = "lbs"
    path = tmp_path / "SMPL_TEST.pkl"
    path.write_bytes(pickle.dumps(raw, protocol=protocol))
    monkeypatch.delitem(sys.modules, "chumpy")
    monkeypatch.delitem(sys.modules, "chumpy.ch")
    b = load_body_arrays(path)
    np.testing.assert_array_equal(b.shapedirs, a.shapedirs)
    np.testing.assert_array_equal(b.J_regressor, a.J_regressor)
    assert "chumpy" not in sys.modules


class _Evil:
    def __reduce__(self):
        import os
        return (os.system, ("touch pwned_by_pickle",))


def test_crafted_pickle_cannot_run_code(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    payload = pickle.dumps({"v_template": _Evil()}, protocol=2)
    (tmp_path / "evil.pkl").write_bytes(payload)
    with pytest.raises(BadInput, match="posix.system|os.system|refusing"):
        load_body_arrays(tmp_path / "evil.pkl")
    with pytest.raises(BadInput):
        safe_pickle_load(pickle.dumps(_Evil()))
    assert not (tmp_path / "pwned_by_pickle").exists()


def test_truncated_and_wrong_files(tmp_path):
    a = toy_body_arrays()
    save_body_arrays(tmp_path / "m.npz", a)
    data = (tmp_path / "m.npz").read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(BadInput, match="cut.npz"):
        load_body_arrays(tmp_path / "cut.npz")
    (tmp_path / "cut.pkl").write_bytes(pickle.dumps(raw_dict(a), protocol=2)[:500])
    with pytest.raises(BadInput, match="truncated|corrupt"):
        load_body_arrays(tmp_path / "cut.pkl")
    with pytest.raises(BadInput, match="does not exist"):
        load_body_arrays(tmp_path / "nope.npz")
    (tmp_path / "x.txt").write_text("hello")
    with pytest.raises(BadInput, match="unknown file type"):
        load_body_arrays(tmp_path / "x.txt")
    np.savez(tmp_path / "other.npz", images=np.zeros(3))
    with pytest.raises(BadInput, match="not a body model: missing"):
        load_body_arrays(tmp_path / "other.npz")
    with pytest.raises(BadInput, match="neither a gender"):
        BodyModel("robot")


def test_shape_and_value_errors_name_the_array(tmp_path):
    raw = raw_dict(toy_body_arrays())
    bad = dict(raw, weights=raw["weights"][:, :23])
    np.savez(tmp_path / "w.npz", **bad)
    with pytest.raises(BadInput, match="weights has shape"):
        load_body_arrays(tmp_path / "w.npz")
    nan = dict(raw, v_template=np.full_like(raw["v_template"], np.nan))
    np.savez(tmp_path / "n.npz", **nan)
    with pytest.raises(BadInput, match="v_template contains NaN"):
        load_body_arrays(tmp_path / "n.npz")


def test_z_up_storage_loads_to_the_same_body(tmp_path):
    """A model stored z-up (up_axis='z') must pose exactly like the same model stored y-up.

    The z-up pose blend shapes are found here by least squares from their meaning (the offset for
    a rotation R in the model frame equals Q times the model-frame offset), independently of the
    loader's closed form.
    """
    rng = np.random.default_rng(0)
    a = toy_body_arrays()
    pd = 0.01 * rng.standard_normal(a.posedirs.shape)
    native = SmplArrays(a.v_template, a.shapedirs, pd, a.J_regressor, a.weights, a.parents, a.faces, {})
    Q = Y_UP_TO_Z_UP
    R = rodrigues(rng.normal(size=(40, 3)))
    X_n = (R - np.eye(3)).reshape(40, 9)                       # model-frame features
    X_z = (Q @ R @ Q.T - np.eye(3)).reshape(40, 9)             # the same rotations seen z-up
    blocks = pd.reshape(192, 3, 23, 9)
    Y = np.einsum("vcjk,nk->nvcj", blocks, X_n)                # model-frame offsets
    Y_z = np.einsum("dc,nvcj->nvdj", Q, Y)                     # Q @ offset
    sol, *_ = np.linalg.lstsq(X_z, Y_z.reshape(40, -1), rcond=None)
    pd_z = sol.reshape(9, 192, 3, 23).transpose(1, 2, 3, 0).reshape(192, 3, 207)
    raw = raw_dict(native)
    raw.update(v_template=a.v_template @ Q.T, shapedirs=np.einsum("cd,vds->vcs", Q, a.shapedirs),
               posedirs=pd_z, up_axis=np.array("z"))
    np.savez(tmp_path / "z.npz", **raw)
    loaded = load_body_arrays(tmp_path / "z.npz")
    betas, pose = rng.normal(size=(3, 10)), rng.normal(scale=0.5, size=(3, 72))
    v1, _ = BodyModel(native).forward(betas, pose)
    v2, _ = BodyModel(loaded).forward(betas, pose)
    np.testing.assert_allclose(v2, v1, atol=1e-10)
