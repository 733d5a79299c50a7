"""benchmarks/bench_shipped_physics.py: the shipped model's test recipe, and the settle swapped in
for one set only."""

import pytest

import benchmarks.bench_shipped_physics as bench
from pressurepose.sim import settle as settle_module
from pressurepose.sim.settle import SettleConfig


def test_the_test_recipe_is_the_shipped_models():
    recipe = bench.shipped_test_recipe()
    assert {e["split"] for e in recipe["entries"]} == {"test"}
    assert sum(e["count"] for e in recipe["entries"]) == 360
    assert {e["seed"] for e in recipe["entries"]} == {1411}


def test_a_swapped_settle_is_put_back_even_when_generate_fails(tmp_path, monkeypatch):
    import pressurepose.cli

    seen = {}

    def fake_main(argv):
        seen["paper"] = settle_module.settle_preset("paper")
        seen["relaxed"] = settle_module.settle_preset("relaxed")
        seen["argv"] = argv
        return 2

    monkeypatch.setattr(pressurepose.cli, "main", fake_main)
    original = settle_module.settle_preset
    with pytest.raises(SystemExit, match="shipped"):
        bench.make_set("shipped", tmp_path / "recipe.json", tmp_path / "out")
    assert seen["paper"] == bench.SETTLES["shipped"] and seen["paper"].coarse_factor == 1.0
    assert seen["relaxed"] == SettleConfig()
    assert "--workers" in seen["argv"] and seen["argv"][seen["argv"].index("--workers") + 1] == "1"
    assert settle_module.settle_preset is original
