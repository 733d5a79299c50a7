"""The subject split of benchmarks/bench_people_fit.py: every subject on exactly one side, and the
shared files on both."""

import pytest

from benchmarks.bench_people_fit import split_subjects, subject_range


def test_subjects_split_into_fit_and_check(tmp_path):
    data = tmp_path / "pmd"
    for k in range(1, 5):
        (data / f"S{k}").mkdir(parents=True)
    (data / "subject-info-i.csv").write_text("Subject-Number,Age,Height/cm,Weight/kg\n")
    fit, check = split_subjects(data, subject_range("1-2"), tmp_path / "out")
    assert sorted(p.name for p in fit.iterdir()) == ["S1", "S2", "subject-info-i.csv"]
    assert sorted(p.name for p in check.iterdir()) == ["S3", "S4", "subject-info-i.csv"]
    assert (check / "S3").resolve() == (data / "S3").resolve()
    assert split_subjects(data, {1, 2}, tmp_path / "out") == (fit, check)  # a rerun keeps the links
    with pytest.raises(SystemExit):
        split_subjects(data, {1, 2, 3, 4}, tmp_path / "again")
    assert subject_range("3") == {3} and subject_range("8-13") == set(range(8, 14))
