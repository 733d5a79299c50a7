"""bench_simulate's recipe prediction from the per-partition rows."""

import pytest

from benchmarks.bench_simulate import PARTITIONS, mix_rate, recipe_mix


def test_mix_rate_adds_each_parts_cpu():
    # 10 samples at 2 per CPU-s (5 s) and 30 at 1 per CPU-s (30 s): 40 samples in 35 s
    assert mix_rate({"a": 2.0, "b": 1.0}, {"a": 10, "b": 30}) == pytest.approx(40 / 35)
    assert mix_rate({"a": 2.0}, {"a": 7}) == pytest.approx(2.0)
    with pytest.raises(KeyError, match="no rate"):
        mix_rate({"a": 2.0}, {"a": 1, "c": 1})


def test_recipe_mix_is_the_paper_recipe_and_every_partition_has_a_row():
    mix = recipe_mix()
    assert sum(mix.values()) == 206_000
    rows = {p for p, _ in PARTITIONS}
    assert {p for p, _, _ in mix} <= rows
    assert {g for _, g, _ in mix} == {"f", "m"}
