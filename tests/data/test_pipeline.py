"""Determinism, independence of shards, worker counts, retries, and a real kill -9 in the middle of a run."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pressurepose.data.generate import generate
from pressurepose.data.pipeline import (
    GenerationError,
    WorkUnit,
    make_sample,
    plan_units,
)
from pressurepose.data.producers import attempt_rng
from pressurepose.data.store import MANIFEST, Manifest, read_shard_arrays, shard_name
from pressurepose.data.synthetic import synthetic_producer
from pressurepose.sim.simulate import Rejected
from tests.data.helpers import small_config

REPO = Path(__file__).resolve().parents[2]


def _arrays(out, shards=None):
    m = Manifest.load(out)
    ks = sorted(m.shards) if shards is None else shards
    return {k: read_shard_arrays(out / shard_name(k)) for k in ks}


def _assert_same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].keys() == b[k].keys()
        for name in a[k]:
            assert a[k][name].dtype == b[k][name].dtype
            assert a[k][name].tobytes() == b[k][name].tobytes(), (k, name)


def test_same_config_and_seed_give_identical_shards(tmp_path):
    c = small_config(count=14, shard_size=5)
    r1 = generate(c, tmp_path / "a", progress=False)
    r2 = generate(c, tmp_path / "b", progress=False)
    _assert_same(_arrays(tmp_path / "a"), _arrays(tmp_path / "b"))
    assert {k: s.sha256 for k, s in r1.manifest.shards.items()} == {k: s.sha256 for k, s in r2.manifest.shards.items()}
    assert r1.manifest.rejections == r2.manifest.rejections and sum(r1.manifest.rejections.values()) > 0
    other = generate(small_config(count=14, shard_size=5, seed=8), tmp_path / "c", progress=False)
    assert not np.array_equal(_arrays(tmp_path / "c")[0]["betas"], _arrays(tmp_path / "a")[0]["betas"])
    assert other.manifest.samples_done == 14


def test_one_shard_made_alone_equals_the_same_shard_of_a_full_run(tmp_path):
    c = small_config(count=18, shard_size=6)
    generate(c, tmp_path / "full", progress=False)
    generate(c, tmp_path / "alone", progress=False, only_shards=[2])
    assert sorted(Manifest.load(tmp_path / "alone").shards) == [2]
    _assert_same(_arrays(tmp_path / "full", [2]), _arrays(tmp_path / "alone", [2]))
    assert (tmp_path / "full" / shard_name(2)).read_bytes() == (tmp_path / "alone" / shard_name(2)).read_bytes()


def test_a_sample_does_not_depend_on_count_or_shard_size():
    a = make_sample(small_config(count=20, shard_size=6), 13)[0]
    b = make_sample(small_config(count=50, shard_size=17), 13)[0]
    assert np.array_equal(a.pressure, b.pressure) and np.array_equal(a.pose, b.pose)
    # other partitions with the same seed draw other bodies
    c = make_sample(small_config(partition="general_supine"), 13)[0]
    assert not np.array_equal(a.betas, c.betas)


def test_rejections_are_deterministic_and_counted_by_cause():
    c = small_config(options={"reject_rate": 0.5})
    s, attempt, rej = make_sample(c, 3)
    for a in range(attempt):  # every earlier attempt really was rejected, for the recorded causes
        assert isinstance(synthetic_producer(c, attempt_rng(c, 3, a)), Rejected)
    assert sum(rej.values()) == attempt
    assert make_sample(c, 3)[1:] == (attempt, rej)


def test_two_workers_equal_one_worker(tmp_path):
    c = small_config(count=20, shard_size=5)
    generate(c, tmp_path / "one", workers=1, progress=False)
    generate(c, tmp_path / "two", workers=2, progress=False)
    _assert_same(_arrays(tmp_path / "one"), _arrays(tmp_path / "two"))


def test_units_split_one_shard_so_every_worker_has_work():
    c = small_config(count=64, shard_size=256)
    assert plan_units(c) == [WorkUnit(c, 0)]
    units = plan_units(c, workers=2)
    assert len(units) >= 8 and all(u.shard == 0 for u in units)
    assert [i for u in units for i in u.indices] == list(range(64))  # contiguous, in order, no overlap
    sizes = [len(u.indices) for u in units]
    assert max(sizes) - min(sizes) <= 1
    several = plan_units(small_config(count=30, shard_size=8), [1, 3], workers=2)
    assert [i for u in several for i in u.indices] == list(range(8, 16)) + list(range(24, 30))


def test_two_workers_share_a_single_shard_and_write_the_same_bytes(tmp_path):
    marks = tmp_path / "marks"
    marks.mkdir()
    c = small_config(count=24, shard_size=256, producer="tests.data.helpers:pid_recording_producer",
                     options={"marker_dir": str(marks), "sleep_ms": 20})
    generate(c, tmp_path / "one", workers=1, progress=False)
    for p in marks.iterdir():
        p.unlink()
    generate(c, tmp_path / "two", workers=2, progress=False)
    assert len(list(marks.iterdir())) == 2  # both worker processes made samples of the one shard
    assert (tmp_path / "one" / shard_name(0)).read_bytes() == (tmp_path / "two" / shard_name(0)).read_bytes()


def test_failed_unit_is_retried_not_dropped(tmp_path):
    ref = small_config(count=12, shard_size=6)
    generate(ref, tmp_path / "ref", progress=False)
    flaky = small_config(count=12, shard_size=6, producer="tests.data.helpers:flaky_producer",
                         options={"marker_dir": str(tmp_path)})
    report = generate(flaky, tmp_path / "flaky", workers=2, progress=False)
    assert (tmp_path / "failed_once").exists() and report.retries == 1
    assert report.manifest.complete and report.manifest.samples_done == 12
    for k in range(2):  # same samples as the plain synthetic producer
        a = read_shard_arrays(tmp_path / "ref" / shard_name(k))
        b = read_shard_arrays(tmp_path / "flaky" / shard_name(k))
        assert all(np.array_equal(a[f], b[f]) for f in ("pressure", "pose", "joints", "index"))


def test_a_script_without_a_main_guard_is_told_to_add_one(tmp_path):
    """Worker processes import the script that started them again: an unguarded script's workers end
    at once (its code after generate does not run in them) and the run's error says what to do."""
    script = tmp_path / "unguarded.py"
    script.write_text(
        f"import sys\nsys.path.insert(0, {str(Path(__file__).resolve().parents[2])!r})\n"
        "from pressurepose.data.generate import generate\nfrom tests.data.helpers import small_config\n"
        f"generate(small_config(count=4, shard_size=2), {str(tmp_path / 'out')!r}, workers=2, progress=False)\n"
        "print('after generate')\n")
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode != 0 and "after generate" not in run.stdout
    assert 'if __name__ == "__main__":' in run.stderr and "--workers 1" in run.stderr


def test_crashed_worker_process_is_retried(tmp_path):
    c = small_config(count=12, shard_size=6, producer="tests.data.helpers:crashing_producer",
                     options={"marker_dir": str(tmp_path)})
    report = generate(c, tmp_path / "d", workers=2, progress=False)
    assert (tmp_path / "crashed_once").exists() and report.retries >= 1
    assert report.manifest.complete
    # no worker of the broken pool is left waiting for work (it would hang the interpreter at exit)
    import multiprocessing
    import time

    deadline = time.monotonic() + 10
    while multiprocessing.active_children() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not multiprocessing.active_children()


def test_pool_found_broken_when_submitting_is_replaced(tmp_path, monkeypatch):
    """A worker can die between one wait and the next submit: the submit itself then raises. The unit
    it was for never ran; the run starts a new pool and still writes every sample."""
    from concurrent.futures.process import BrokenProcessPool, ProcessPoolExecutor

    from pressurepose.data import executors

    submits = [0]

    class BreaksOnThirdSubmit(ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            submits[0] += 1
            if submits[0] == 3:
                raise BrokenProcessPool("a child process terminated abruptly")
            return super().submit(fn, *args, **kwargs)

    monkeypatch.setattr(executors, "ProcessPoolExecutor", BreaksOnThirdSubmit)
    report = generate(small_config(count=12, shard_size=3), tmp_path / "d", workers=2, progress=False)
    assert submits[0] > 4 and report.manifest.complete
    assert len(read_shard_arrays(tmp_path / "d" / shard_name(0))["pressure"]) == 3


def test_unit_that_keeps_failing_fails_loudly(tmp_path):
    c = small_config(count=12, shard_size=6, producer="tests.data.helpers:broken_producer")
    with pytest.raises(GenerationError, match=r"(?s)shard 0 \(samples 0..5\) failed 3 times; giving up.*always fails"):
        generate(c, tmp_path / "d", retries=2, progress=False)
    assert Manifest.load(tmp_path / "d").shards == {}


def test_exhausted_attempts_are_not_retried(tmp_path):
    c = small_config(options={"reject_rate": 1.0}, max_attempts=5)
    with pytest.raises(GenerationError, match="rejected 5 times in a row"):
        generate(c, tmp_path / "d", progress=False)


def test_kill_9_mid_run_then_rerun_equals_an_uninterrupted_run(tmp_path):
    args = ["generate", "--partition", "general", "--gender", "m", "--count", "48", "--shard-size", "8",
            "--seed", "5", "--producer", "synthetic", "--option", "sleep_ms=15", "--workers", "2", "--no-progress"]
    out = tmp_path / "killed"
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "pressurepose.cli", *args, "--out", str(out)], cwd=REPO,
                            env=env, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while len(list(out.glob("shard-*.h5"))) < 2:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline, "the run made no shards in 60 s"
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)  # the run and its worker processes, mid-run
    proc.wait()
    done = sorted(p.name for p in out.glob("shard-*.h5"))
    assert 2 <= len(done) < 6 and not Manifest.load(out).complete
    config = Manifest.load(out).config
    report = generate(config, out, progress=False)  # the same command again
    assert report.skipped == len(done) and report.made == 6 - len(done)
    ref = generate(config, tmp_path / "ref", progress=False)
    _assert_same(_arrays(out), _arrays(tmp_path / "ref"))
    assert Manifest.load(out).to_dict()["shards"] == ref.manifest.to_dict()["shards"]
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST] + [shard_name(k) for k in range(6)]


def test_ray_local_instance_gives_the_same_dataset(tmp_path):
    pytest.importorskip("ray")
    c = small_config(count=12, shard_size=6)
    generate(c, tmp_path / "local", progress=False)
    generate(c, tmp_path / "ray", ray_address="local", progress=False)
    _assert_same(_arrays(tmp_path / "local"), _arrays(tmp_path / "ray"))


def test_generate_refuses_arguments_of_the_wrong_kind_before_writing(tmp_path):
    """A dict as the config, None or a file as the output, workers='2', only_shards=1 or 'a' were
    AttributeErrors, TypeErrors or FileExistsError; an option the producer does not read was kept
    (the verb refused it, the function did not)."""
    from pressurepose.errors import BadInput

    (tmp_path / "afile").write_text("x")
    c = small_config(count=2)
    for args, kwargs, message in (
            (({"partition": "general"}, tmp_path / "a"), {}, "config is dict; expected a GenerationConfig"),
            ((c, None), {}, "out is None; expected a path"),
            ((c, tmp_path / "afile"), {}, "out .*afile is a file; expected a folder"),
            ((c, tmp_path / "b"), {"workers": "2"}, "workers = '2'; expected at least 1"),
            ((c, tmp_path / "c"), {"retries": 1.5}, "retries = 1.5; expected 0 or more"),
            ((c, tmp_path / "d"), {"only_shards": 1}, "only_shards is 1; expected a list of shard numbers"),
            ((c, tmp_path / "e"), {"only_shards": ["0"]}, "only_shards holds '0'; expected shard numbers"),
            ((small_config(count=2, options={"rejct_rate": 0.5}), tmp_path / "f"), {},
             "--option rejct_rate: producer 'synthetic' has no such option")):
        with pytest.raises(BadInput, match=message):
            generate(*args, progress=False, **kwargs)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]
    assert generate(c, tmp_path / "g", only_shards=(np.int64(0),), progress=False).made == 1


def test_auto_workers_are_the_cores_this_process_may_use_and_one_per_eight_samples(monkeypatch):
    from pressurepose.data import executors
    from pressurepose.errors import BadInput

    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: set(range(8)), raising=False)
    assert executors.available_cores() == 8
    assert [executors.resolve_workers("auto", n) for n in (100, 64, 63, 9, 8, 4, 1, 0)] == [8, 8, 8, 2, 1, 1, 1, 1]
    assert [executors.resolve_workers(3, n) for n in (100, 2)] == [3, 2]
    monkeypatch.delattr(executors.os, "sched_getaffinity", raising=False)  # macOS, Windows
    monkeypatch.setattr(executors.os, "cpu_count", lambda: 6)
    assert executors.resolve_workers("auto", 100) == 6
    for bad in (0, "2", "many", 1.5, True):
        with pytest.raises(BadInput, match="expected at least 1, or 'auto'"):
            executors.resolve_workers(bad, 10)


def test_auto_workers_make_the_same_dataset_as_one_worker(tmp_path, monkeypatch):
    """Three cores: a 30-sample run uses 3 workers, a 10-sample one 2, a 2-sample one this process;
    every dataset holds the bytes one worker makes."""
    from pressurepose.data import executors

    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: {0, 1, 2}, raising=False)
    for count, used in ((30, 3), (10, 2), (2, 1)):
        c = small_config(count=count, shard_size=4)
        one = generate(c, tmp_path / f"one{count}", workers=1, progress=False)
        auto = generate(c, tmp_path / f"auto{count}", workers="auto", progress=False)
        assert (one.workers, auto.workers) == (1, used)
        _assert_same(_arrays(tmp_path / f"one{count}"), _arrays(tmp_path / f"auto{count}"))
        assert one.manifest.to_dict()["shards"] == auto.manifest.to_dict()["shards"]
