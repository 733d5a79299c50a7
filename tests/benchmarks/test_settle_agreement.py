"""benchmarks/bench_settle.py --agreement on a handful of bodies: the fine step against itself
agrees exactly, a start offset is undone before joints are compared, and the table has a row per
candidate."""

import pytest

import benchmarks.bench_settle as bench
from pressurepose.body.model import asset_path


@pytest.mark.skipif(not asset_path("female.npz").is_file(), reason="the shipped body models are not baked")
def test_agreement_table_on_two_bodies(monkeypatch):
    monkeypatch.setattr(bench, "AGREEMENT_PARTITIONS", (("supine_straight_limbs", False),))
    monkeypatch.setattr(bench, "AGREEMENT_CANDIDATES", {
        "the fine step again": (bench.FINE_STEP, bench.NO_OFFSET),
        "moved 10 cm along the bed": (bench.FINE_STEP, (0.0, 0.1, 0.0)),
        "pushed off the bed's side": (bench.FINE_STEP, (2.0, 0.0, 0.0)),
    })
    lines = bench.agreement(1, seed=7)
    assert len(lines) == 2 + 3
    same = lines[2].split(" | ")
    assert same[1:3] == ["2/2", "2"]                      # same outcome, both settled
    assert same[3] == "0.0 / 0.0 / 0.0" and same[4] == "100 %"  # joint error, within 20 mm
    assert same[5] == "1.0000 / 1.000"
    moved = lines[3].split(" | ")
    # a body started 10 cm further down the bed rests 10 cm further down: compared where it
    # started, its joints agree to centimetres, not to the 10 cm it was moved
    assert moved[1] == "2/2" and float(moved[3].split(" / ")[2]) < 50.0
    off = lines[4].split(" | ")
    assert off[1:6] == ["0/2", "0", "-", "-", "-"]  # nothing to compare, and the table says so
