"""A night on the mat: timing, frame selection, posture runs, turns, time above the threshold, alerts."""

import json
import re

import numpy as np
import pytest

from pressurepose.body.sites import SITES, site_index
from pressurepose.errors import BadInput
from pressurepose.eval.monitor import (
    FrameSelection,
    MonitorConfig,
    above_stretches,
    frame_times,
    load_change,
    loaded_frames,
    posture_runs,
    select_frames,
    timeline,
)
from pressurepose.mat import custom_mat

MAT = custom_mat(8, 6, 0.03)


# --------------------------------------------------------------------------- time
def test_frame_times_from_a_rate_or_timestamps_and_bad_timing_refused():
    np.testing.assert_allclose(frame_times(4, fps=2.0), [0, 0.5, 1.0, 1.5])
    np.testing.assert_allclose(frame_times(3, timestamps=[100.0, 101.0, 103.0]), [0, 1, 3])
    with pytest.raises(BadInput, match="frame rate"):
        frame_times(3)
    with pytest.raises(BadInput, match="not both"):
        frame_times(3, fps=1.0, timestamps=[0, 1, 2])
    with pytest.raises(BadInput, match="must increase"):
        frame_times(3, timestamps=[0, 2, 1])
    with pytest.raises(BadInput, match="one per frame"):
        frame_times(3, timestamps=[0, 1])
    with pytest.raises(BadInput, match="gap of 120 s between frames 1 and 2"):
        frame_times(3, timestamps=[0, 1, 121], max_gap_s=60)
    with pytest.raises(BadInput, match="frame rate"):
        frame_times(3, fps=0.0)


# --------------------------------------------------------------------------- which frames are read
def test_only_frames_that_changed_since_the_last_estimate_are_estimated():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(5, 40, (2, 8, 6))
    frames = np.stack([a, a * 1.02, a * 1.04, a * 1.06, b, b, np.zeros((8, 6)), b])
    sel = select_frames(frames, MonitorConfig(change=0.1, min_contact_taxels=10))
    # drift accumulates against the last estimated frame, not the previous frame: 6 % twice is under 10 %
    assert sel.estimated.tolist() == [True, False, False, False, True, False, False, True]
    assert sel.ref.tolist() == [0, 0, 0, 0, 4, 4, -1, 7]  # after an empty frame the body is read again
    assert sel.occupied.tolist() == [True] * 6 + [False, True]
    assert load_change(a, a) == 0.0 and load_change(a, 2 * a) == pytest.approx(0.5)


# --------------------------------------------------------------------------- postures and turns
def test_short_movements_join_the_posture_before_them():
    p = np.array(["supine"] * 100 + ["left"] * 10 + ["supine"] * 50 + ["right"] * 200 + ["empty"] * 5 + ["right"] * 70)
    runs = posture_runs(p, np.ones(len(p)), min_posture_s=60)
    assert runs == [("supine", 0, 160), ("right", 160, 435)]
    runs = posture_runs(np.array(["left"] * 20 + ["supine"] * 100), np.ones(120), min_posture_s=60)
    assert runs == [("supine", 0, 120)]  # a short first run joins the one after it
    # a recording shorter than a posture: one run, named for the posture held longest, not the first frame's
    runs = posture_runs(np.array(["empty"] + ["right"] * 13), np.ones(14), min_posture_s=60)
    assert runs == [("right", 0, 14)]
    runs = posture_runs(np.array(["supine"] * 100 + ["left"] * 30 + ["right"] * 40), np.ones(170), min_posture_s=60)
    assert runs == [("supine", 0, 170)]  # two short movements in a row still join the posture before them


def _night(schedule, fps=1.0, rng=None):
    """Frames, rolls and site maps of a known schedule [(posture roll deg or None for empty, seconds)]:
    each posture a fixed image with 3 % noise per frame; the body estimated on every frame."""
    rng = rng or np.random.default_rng(1)
    frames, roll = [], []
    for deg, seconds in schedule:
        n = int(seconds * fps)
        if deg is None:
            frames.append(np.zeros((n, 8, 6)))
            roll += [np.nan] * n
            continue
        base = np.zeros((8, 6))
        base[1:7, 1:5] = 10.0
        base[5, 2] = 50.0  # the sacrum above the threshold while supine
        frames.append(base * rng.uniform(0.97, 1.03, (n, 8, 6)))
        roll += [np.radians(deg)] * n
    frames = np.concatenate(frames).astype(np.float32)
    t = frame_times(len(frames), fps=fps)
    return t, frames, np.array(roll)


def _read(t, frames, roll, config, doubtful=None):
    """The timeline of a :func:`_night`; ``doubtful`` (T,) bool: frames whose image the
    plausibility check doubts (None: not checked)."""
    occupied = np.isfinite(roll)
    sel = FrameSelection(occupied=occupied, estimated=occupied.copy(),
                         ref=np.where(occupied, np.arange(len(t)), -1))
    maps = np.full((int(occupied.sum()), 8, 6), site_index("other"), np.int8)
    supine = np.abs(roll[occupied]) < np.radians(45)
    maps[supine, 4:7, 1:4] = site_index("sacrum")  # lying on the back, the sacrum is under rows 4-6
    checked = None
    if doubtful is not None:
        from pressurepose.net.plausibility import Doubt, Plausibility, image_stats

        checked = Plausibility(doubt=tuple(Doubt.TOO_SHORT if d else None for d in doubtful),
                               reason=tuple("a person sitting" if d else "" for d in doubtful),
                               stats=image_stats(frames, MAT))
    return timeline(t, frames, sel, roll[occupied], maps, MAT, config, checked)


def test_every_turn_of_a_known_schedule_is_found_and_no_other():
    schedule = [(0, 3000), (85, 1800), (3, 600), (-95, 2400), (None, 120), (-80, 600), (175, 1200)]
    t, frames, roll = _night(schedule)
    roll[3000:3020] = np.radians(-50)  # 20 s rolled the other way first: a movement, not a posture
    tl = _read(t, frames, roll, MonitorConfig())
    assert [(x.time_s, x.before, x.after) for x in tl.turns] == [
        (3020.0, "supine", "left"), (4800.0, "left", "supine"), (5400.0, "supine", "right"),
        (8520.0, "right", "prone")]  # back on the same side after leaving the bed: no turn
    assert tl.turns[0].roll_change_deg == pytest.approx(85.0)
    assert tl.turns[3].roll_change_deg == pytest.approx(175 - (-80) - 360)
    assert tl.posture_s == pytest.approx({"supine": 3620.0, "left": 1780.0, "right": 3000.0, "prone": 1200.0,
                                          "empty": 120.0, "unclear": 0.0})
    assert tl.posture[3005] == "supine" and tl.posture[3100] == "left" and np.isnan(tl.roll_deg[7850])


def test_frames_unlike_a_person_lying_are_an_unclear_spell_that_turns_pass_over():
    """Five minutes whose images the plausibility check doubts (a person sitting on the bed, say),
    read by the network as lying on the left: 'unclear', not a posture; no turn through them back to
    the same posture, one turn where the person lies otherwise after them."""
    t, frames, roll = _night([(0, 600), (85, 300), (0, 600), (85, 300), (-90, 600)])
    doubtful = np.zeros(len(t), bool)
    doubtful[600:900] = doubtful[1500:1800] = True
    tl = _read(t, frames, roll, MonitorConfig(), doubtful)
    assert [(x.time_s, x.before, x.after) for x in tl.turns] == [(1800.0, "supine", "right")]
    assert set(tl.posture[600:900]) == {"unclear"} and tl.posture[1000] == "supine"
    assert tl.posture_s["unclear"] == pytest.approx(600.0) and tl.posture_s["left"] == 0.0
    assert tl.doubtful.sum() == 600
    unchecked = _read(t, frames, roll, MonitorConfig())  # without the check the network's 'left' stands
    assert [x.after for x in unchecked.turns] == ["left", "supine", "left", "right"]


def test_a_recording_with_nobody_on_the_mat_is_one_empty_spell():
    t, frames, roll = _night([(None, 30)])  # no frame carries a body: the network reads none
    tl = _read(t, frames, roll, MonitorConfig())
    assert set(tl.posture) == {"empty"} and np.isnan(tl.roll_deg).all() and not tl.estimated.any()
    assert tl.posture_s["empty"] == pytest.approx(30.0) and tl.turns == [] and tl.alerts == []
    json.dumps(tl.to_dict(), allow_nan=False)


def test_time_above_the_threshold_and_an_alert_after_the_repositioning_interval():
    schedule = [(0, 3000), (85, 1800), (3, 8000)]
    t, frames, roll = _night(schedule)
    tl = _read(t, frames, roll, MonitorConfig(threshold_mmhg=32.0, reposition_s=7200.0))
    k = site_index("sacrum")
    assert tl.peak_mmhg[10, k] > 45 and tl.peak_mmhg[4000, k] == 0.0  # unloaded on the side
    assert tl.above_s["sacrum"] == pytest.approx(11000.0)
    assert tl.longest_above_s["sacrum"] == pytest.approx(8000.0)
    assert len(tl.alerts) == 1  # 3000 s supine is under 2 h; 8000 s is over
    a = tl.alerts[0]
    assert (a.site, a.start_s, a.due_s, a.duration_s) == ("sacrum", 4800.0, 12000.0, 8000.0)
    assert tl.above_s["other"] == pytest.approx(1800.0)  # the same taxel lies under another site on the side
    assert tl.share[10].sum() == pytest.approx(1.0)
    json.dumps(tl.to_dict(), allow_nan=False)  # strict JSON
    lines = tl.to_csv().splitlines()
    assert len(lines) == len(t) + 1 and lines[0].startswith("time_s,posture,roll_deg,estimated,head_peak_mmhg")
    assert len(lines[0].split(",")) == 5 + 2 * len(SITES) and lines[0].endswith(",doubtful")


def test_the_json_record_holds_posture_segments_and_minutes_not_frames():
    """timeline.json's record: one segment per posture held and one row per minute (posture held
    longest, highest peak, time-weighted share): a few hundred rows for a night; the per-frame rows
    are the CSV's."""
    t, frames, roll = _night([(0, 3020), (85, 1780), (3, 600)])
    tl = _read(t, frames, roll, MonitorConfig())
    k = site_index("sacrum")
    rec = json.loads(json.dumps(tl.to_dict(), allow_nan=False))
    assert "frames_table" not in rec and rec["sites"] == list(SITES) and rec["interval_s"] == 60.0
    assert [(g["posture"], g["start_s"], g["end_s"], g["frames"]) for g in rec["segments"]] == [
        ("supine", 0.0, 3020.0, 3020), ("left", 3020.0, 4800.0, 1780), ("supine", 4800.0, 5400.0, 600)]
    assert rec["segments"][1]["roll_deg"] == 85.0 and rec["segments"][1]["peak_mmhg"]["sacrum"] == 0.0
    assert rec["segments"][0]["peak_mmhg"]["sacrum"] == pytest.approx(tl.peak_mmhg[:3020, k].max(), abs=1e-3)
    minutes = rec["per_interval"]
    assert len(minutes) == 90 and [m["start_s"] for m in minutes[:2]] == [0.0, 60.0]
    assert sum(m["frames"] for m in minutes) == len(t) and sum(m["duration_s"] for m in minutes) == 5400.0
    turn = minutes[50]  # 3000-3060 s: 20 s supine, 40 s on the left side
    assert (turn["start_s"], turn["posture"], turn["frames_estimated"]) == (3000.0, "left", 60)
    assert turn["peak_mmhg"]["sacrum"] == pytest.approx(tl.peak_mmhg[3000:3020, k].max(), abs=1e-3)
    assert turn["share"]["sacrum"] == pytest.approx(tl.share[3000:3060, k].mean(), abs=1e-5)
    assert len(tl.per_interval(600.0)) == 9
    with pytest.raises(BadInput, match="interval_s"):
        tl.per_interval(0)
    with pytest.raises(BadInput, match="interval_s"):
        tl.to_dict("a minute")


def test_a_short_dip_under_the_threshold_does_not_relieve_the_skin_and_noise_is_no_load():
    t = np.arange(300.0)
    above = np.ones(300, bool)
    above[40:50] = False  # 10 s under
    above[100:220] = False  # 2 minutes under
    above[150:220:7] = True  # a reading near the threshold crossing it now and then
    (a0, a1), (b0, b1) = above_stretches(above, t, np.ones(300), relief_s=60)
    assert (a0, a1, b1) == (0, 100, 300) and 212 <= b0 <= 220  # the crossings just before 220 blur its start
    assert above_stretches(above, t, np.ones(300), relief_s=5) == [(0, 40), (50, 100), (220, 300)]
    assert not loaded_frames(above, np.ones(300), 60)[150:190].any()


def test_bad_settings_and_shapes_are_refused():
    with pytest.raises(BadInput, match="threshold_mmhg"):
        MonitorConfig(threshold_mmhg=0)
    with pytest.raises(BadInput, match="min_contact_taxels"):
        MonitorConfig(min_contact_taxels=0)
    t, frames, roll = _night([(0, 10)])
    sel = select_frames(frames)
    with pytest.raises(BadInput, match="one body per estimated frame"):
        timeline(t, frames, sel, np.zeros(3), np.zeros((3, 8, 6), np.int8), MAT)
    with pytest.raises(BadInput, match="frames"):
        select_frames(frames[0])


# --------------------------------------------------------------------------- a night read by the shipped model
NIGHT_FRAMES = __import__("pathlib").Path(__file__).parent / "data" / "night_frames.npz"


def night_recording(schedule, seed=0):
    """Real-looking frames (T, 64, 27) mmHg at 1 Hz of a known schedule [(posture or None, seconds)]:
    the simulated image of each posture (tools/record_night_frames.py) with breathing (a 4 s cycle of
    +-2 % over the trunk), 4 % noise per taxel and a 12 s roll between postures (the two images
    blended), and the turn times."""
    rng = np.random.default_rng(seed)
    data = np.load(NIGHT_FRAMES)
    image = dict(zip(data["posture"].tolist(), data["pressure"].astype(np.float64)))
    frames, turns, last, t = [], [], None, 0
    breath = np.zeros((64, 27))
    breath[10:35] = 1.0
    for posture, seconds in schedule:
        img = np.zeros((64, 27)) if posture is None else image[posture]
        if posture is not None and last is not None and posture != last:
            turns.append(t)
            for k in range(12):  # rolling over: the old print fades as the new one grows
                w = (k + 1) / 13
                frames.append((1 - w) * image[last] + w * img)
                t += 1
            seconds -= 12
        for _ in range(seconds):
            phase = np.sin(2 * np.pi * t / 4.0)
            frames.append(img * (1 + 0.02 * phase * breath) * rng.uniform(0.96, 1.04, img.shape))
            t += 1
        last = posture if posture is not None else last
    return np.clip(np.stack(frames), 0, 100).astype(np.float32), turns


SCHEDULE = [("supine", 600), ("left", 900), ("supine", 300), ("right", 1200), (None, 60), ("right", 300),
            ("prone", 600)]


@pytest.mark.skipif(not NIGHT_FRAMES.is_file(), reason="tools/record_night_frames.py has not been run")
def test_the_shipped_model_finds_every_turn_of_a_night_and_no_other():
    from pressurepose.eval.monitor import monitor

    frames, turns = night_recording(SCHEDULE)
    tl = monitor(frames, frame_times(len(frames), fps=1.0), "f")
    found = [(x.time_s, x.before, x.after) for x in tl.turns]
    assert [x[1:] for x in found] == [("supine", "left"), ("left", "supine"), ("supine", "right"),
                                      ("right", "prone")]  # back on the same side after the empty minute: no turn
    for (time_s, _, _), truth in zip(found, [turns[0], turns[1], turns[2], turns[3]]):
        assert truth <= time_s <= truth + 12  # found during the roll
    assert tl.estimated.sum() < 0.05 * len(frames)  # the network reads the frames that changed, not the night
    assert tl.posture_s["empty"] == pytest.approx(60, abs=2)
    assert abs(tl.posture_s["right"] - 1500) < 15 and abs(tl.posture_s["prone"] - 600) < 15
    left, right = site_index("left_trochanter"), site_index("right_trochanter")
    on_left = (tl.times_s > 700) & (tl.times_s < 1400)
    assert tl.share[on_left, left].mean() > tl.share[on_left, right].mean()  # lying on the left: its hip carries
    supine = tl.times_s < 590
    assert tl.share[supine, site_index("sacrum")].mean() > 0.15


@pytest.mark.skipif(not NIGHT_FRAMES.is_file(), reason="tools/record_night_frames.py has not been run")
def test_monitor_gives_each_estimated_frame_the_sites_estimate_gives_it():
    """The timeline's site loads of the frames the network read are those of estimate() (its site
    route, the site network where one ships for the mat), over the taxels monitor counts as loaded."""
    from pressurepose.body.sites import NO_SITE, site_stats
    from pressurepose.eval.monitor import monitor
    from pressurepose.net.infer import estimate

    frames, _ = night_recording([("supine", 40), ("left", 40)])
    tl = monitor(frames, frame_times(len(frames), fps=1.0), "f", progress=False)
    k = np.flatnonzero(tl.estimated)
    est = estimate(frames[k], "f")
    want = site_stats(frames[k], np.where(frames[k] > MonitorConfig().contact_mmhg, est.sites.taxel_site, NO_SITE),
                      est.grid)
    np.testing.assert_allclose(tl.share[k], want.share, atol=1e-9)
    np.testing.assert_allclose(tl.peak_mmhg[k], want.peak_mmhg, atol=1e-4)
    assert tl.sites_read_by == est.sites_read_by == tl.summary()["sites_read_by"]


@pytest.mark.skipif(not NIGHT_FRAMES.is_file(), reason="tools/record_night_frames.py has not been run")
def test_monitor_reads_a_recording_on_its_own_mat_as_the_verb_does(tmp_path):
    """monitor(..., mat=, units=) takes a recording as recorded (here with its head at the last row,
    and as a file) down the same road as recording_input, and finds the turn."""
    from pressurepose.eval.monitor import monitor, recording_input
    from pressurepose.mat import get_mat

    frames, _ = night_recording([("supine", 120), ("left", 120)])
    recorded = frames[:, ::-1].copy()  # head at the last row
    times = frame_times(len(frames), fps=1.0)
    config = MonitorConfig(min_posture_s=30)
    via, _ = recording_input(recorded, "boditrak_bt3510", "mmHg", get_mat("boditrak_bt3510"), head_row="last")
    want = monitor(via, times, "f", config=config)
    got = monitor(recorded, times, "f", config=config, mat="boditrak_bt3510", units="mmHg", head_row="last")
    assert [(t.before, t.after) for t in got.turns] == [("supine", "left")]
    assert list(got.posture) == list(want.posture) and np.allclose(got.share, want.share)
    np.save(tmp_path / "night.npy", recorded)
    from_file = monitor(tmp_path / "night.npy", times, "f", config=config, mat="boditrak_bt3510", units="mmHg",
                        head_row="last")
    assert list(from_file.posture) == list(want.posture)
    np.save(tmp_path / "model_mat.npy", via)  # already on the model's mat, in mmHg
    assert list(monitor(tmp_path / "model_mat.npy", times, "f", config=config).posture) == list(want.posture)
    with pytest.raises(BadInput, match="units"):
        monitor(recorded, times, "f", mat="boditrak_bt3510")
    with pytest.raises(BadInput, match="give its mat"):
        monitor(frames, times, "f", weight_kg=70)


@pytest.mark.skipif(not NIGHT_FRAMES.is_file(), reason="tools/record_night_frames.py has not been run")
def test_monitor_verb_writes_the_timeline_and_refuses_bad_recordings(tmp_path, capsys):
    from pressurepose.cli import main

    frames, _ = night_recording([("supine", 200), ("left", 200)])
    np.save(tmp_path / "night.npy", frames)
    out = tmp_path / "out"
    args = ["monitor", str(tmp_path / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender", "f",
            "--out", str(out)]
    assert main([*args, "--fps", "1", "--reposition-h", "0.02", "--min-posture-s", "30"]) == 0
    printed = capsys.readouterr().out
    assert "1 turn(s)" in printed and "supine -> left" in printed
    rec = json.loads((out / "timeline.json").read_text())
    assert [t["after"] for t in rec["turns"]] == ["left"] and "frames_table" not in rec
    assert [g["posture"] for g in rec["segments"]] == ["supine", "left"]
    assert rec["segments"][1]["first_frame"] == rec["turns"][0]["frame"] and sum(g["frames"] for g in rec["segments"]) == 400
    assert [r["frames"] for r in rec["per_interval"]] == [60] * 6 + [40] and rec["interval_s"] == 60.0
    assert rec["settings"]["threshold_mmhg"] == 32.0 and rec["alerts"]  # 72 s on the sacrum is past 0.02 h
    assert (out / "night.png").stat().st_size > 0
    assert len((out / "timeline.csv").read_text().splitlines()) == 401
    # the same frames as a folder of one-frame files, with timestamps
    (tmp_path / "frames").mkdir()
    for k in range(0, 400, 40):
        np.save(tmp_path / "frames" / f"f{k}.npy", frames[k])
    np.savetxt(tmp_path / "t.txt", np.arange(0, 400, 40) + 1000.0)
    assert main(["monitor", str(tmp_path / "frames"), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender",
                 "f", "--timestamps", str(tmp_path / "t.txt"), "--out", str(tmp_path / "o2"),
                 "--min-posture-s", "30"]) == 0
    rows = (tmp_path / "o2" / "timeline.csv").read_text().splitlines()[1:]
    assert [float(r.split(",")[0]) for r in rows][:3] == [0.0, 40.0, 80.0]  # f40 after f0, before f80
    capsys.readouterr()
    # bad input: no timing, frames of another mat, a gap in time, a weightless raw recording
    assert main(args) == 2
    np.save(tmp_path / "wrong.npy", frames[:, :60])
    assert main([*args[:1], str(tmp_path / "wrong.npy"), *args[2:], "--fps", "1"]) == 2
    np.savetxt(tmp_path / "gap.txt", np.r_[np.arange(200), np.arange(200) + 500.0])
    assert main([*args, "--timestamps", str(tmp_path / "gap.txt")]) == 2
    assert main([*args[:5], "raw", *args[6:], "--fps", "1"]) == 2
    err = capsys.readouterr().err
    assert "--fps" in err and "(400, 60, 27)" in err and "gap of 301 s" in err and "weight" in err


@pytest.mark.skipif(not NIGHT_FRAMES.is_file(), reason="tools/record_night_frames.py has not been run")
def test_frames_that_do_not_look_like_a_person_lying_are_marked(tmp_path, capsys):
    """A minute of sensor noise amid a night: those frames are marked doubtful (timeline.csv, the
    summary and a warning); the body's frames, the roll included, and the empty mat are not."""
    from pressurepose.cli import main

    frames, _ = night_recording([("supine", 60), ("left", 60), (None, 30)])
    frames[70:80] = np.random.default_rng(1).uniform(0, 20, (10, 64, 27))
    np.save(tmp_path / "night.npy", frames)
    out = tmp_path / "out"
    assert main(["monitor", str(tmp_path / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender",
                 "f", "--fps", "1", "--out", str(out)]) == 0
    out_text, err = capsys.readouterr()
    assert re.search(r"^150 frames over 0:02:30 \(30 without anybody on the mat\); the network read \d+ of them; "
                     r"done in \d+ s$", out_text, re.M)  # what the seconds are
    assert "warning: 10 frame(s) do not look like a person lying on the mat, first frame 70 at 0:01:10" in err
    assert "sensor noise" in err
    rows = (out / "timeline.csv").read_text().splitlines()
    assert rows[0].endswith(",doubtful")
    assert [k for k, r in enumerate(rows[1:]) if r.endswith(",1")] == list(range(70, 80))
    assert json.loads((out / "timeline.json").read_text())["frames_doubtful"] == 10


PMD = __import__("os").environ.get("PRESSUREPOSE_PMD", "")


@pytest.mark.skipif(not PMD or not __import__("pathlib").Path(PMD, "S1", "1.txt").is_file(),
                    reason="PRESSUREPOSE_PMD does not name PhysioNet PMD experiment I")
def test_a_pmd_recording_of_three_postures_turns_where_the_person_turned(tmp_path, capsys):
    """Subject 1 of PMD experiment I (87 kg) lying supine, on the right side, on the left side and
    supine again, two minutes each: its recorded frames cycled, written as one text recording."""
    from pathlib import Path

    from pressurepose.cli import main
    from pressurepose.data.readers.pmd import read_pmd_i_file
    from pressurepose.data.realprep import valid_frames

    lines = []
    for name in ("1", "2", "3", "1"):
        frames = read_pmd_i_file(Path(PMD, "S1", f"{name}.txt"))
        frames = frames[valid_frames(frames)]
        lines += ["\t".join(f"{v:g}" for v in frames[k % len(frames)].ravel()) for k in range(120)]
    (tmp_path / "night.txt").write_text("\n".join(lines) + "\n")
    assert main(["monitor", str(tmp_path / "night.txt"), "--mat", "fsa_softflex_2048", "--units", "raw",
                 "--weight-kg", "87", "--gender", "m", "--fps", "1", "--out", str(tmp_path / "out")]) == 0
    rec = json.loads((tmp_path / "out" / "timeline.json").read_text())
    assert [(t["time_s"], t["before"], t["after"]) for t in rec["turns"]] == [
        (120.0, "supine", "right"), (240.0, "right", "left"), (360.0, "left", "supine")]
    assert rec["frames_estimated"] < 0.25 * 480


def test_frame_times_refuse_counts_gaps_and_timestamps_that_are_not_numbers():
    """Not a TypeError or ValueError, nor a silent result: a count that is not a whole number, a
    max_gap_s that is not positive (NaN let every gap through), timestamps that are text, a dict or
    dates (datetime64 in ms read as seconds would be 1000 times too long)."""
    for count in (-1, 2.5, "3", None):
        with pytest.raises(BadInput, match=r"count \(frames\) is .*; expected a whole number >= 0"):
            frame_times(count, fps=1.0)
    for gap in (0, -1, float("nan"), "60"):
        with pytest.raises(BadInput, match="max_gap_s is"):
            frame_times(3, fps=1.0, max_gap_s=gap)
    for stamps, message in (("0,1,2", "timestamps are '0,1,2'"), (["a", "b", "c"], "not numbers"),
                            ({"a": 1}, "timestamps are"), ([0, [1, 2], 3], "timestamps are"),
                            (np.array(["2020-01-01T00:00:00.000", "2020-01-01T00:00:00.010", "2020-01-01T00:00:00.020"],
                                      dtype="datetime64[ms]"), "datetime64.*not dates or durations")):
        with pytest.raises(BadInput, match=message):
            frame_times(3, timestamps=stamps)
    assert frame_times(0, timestamps=[]).shape == (0,)  # was an IndexError
    np.testing.assert_allclose(frame_times(3, timestamps=["10", "11", "12.5"]), [0, 1, 2.5])  # numbers as text: as before


def test_monitor_checks_its_times_settings_and_gender_before_estimating_a_frame():
    """Times given to monitor() that go backwards, repeat, hold NaN or a gap longer than max_gap_s were
    read as they were (a timeline with wrong durations); a config or gender of the wrong type and a
    chunk of 0 crashed (AttributeError, TypeError, ValueError)."""
    from pressurepose.eval.monitor import monitor

    frames = np.zeros((4, 64, 27), np.float32)
    good = np.arange(4.0)
    for times, message in (([3.0, 2.0, 1.0, 0.0], "times must increase: frame 1 is at 2 s, frame 0 at 3 s"),
                           ([0.0, 1.0, 1.0, 2.0], "times must increase: frame 2 is at 1 s"),
                           ([0.0, np.nan, 2.0, 3.0], "times hold NaN"),
                           ([0.0, 1.0, 500.0, 501.0], "gap of 499 s between frames 1 and 2"),
                           (None, "times are None"), ("abc", "times are 'abc'"), (good[:3], "3 times for 4 frames")):
        with pytest.raises(BadInput, match=message):
            monitor(frames, times, "f")
    with pytest.raises(BadInput, match="gap of 499 s"):  # the config's max_gap_s, 60 s by default
        monitor(frames, [0.0, 1.0, 500.0, 501.0], "f", config=MonitorConfig(max_gap_s=100))
    assert len(monitor(frames, [0.0, 1.0, 500.0, 501.0], "f", config=MonitorConfig(max_gap_s=600))) == 4
    with pytest.raises(BadInput, match="config is dict; expected a MonitorConfig"):
        monitor(frames, good, "f", config={})
    with pytest.raises(BadInput, match=r"chunk .* is 0; expected a whole number >= 1"):
        monitor(frames, good, "f", chunk=0)
    with pytest.raises(BadInput, match="batch size is 0"):  # an empty mat estimates no frame: checked all the same
        monitor(frames, good, "f", batch_size=0)
    for gender, message in ((None, "gender is None; expected f or m"), (["f"] * 4, r"gender is \['f'"),
                            ("x", "gender 'x' is not known")):
        with pytest.raises(BadInput, match=message):
            monitor(frames, good, gender)


def test_monitor_verb_refuses_an_empty_or_many_column_timestamps_file(tmp_path, capsys):
    """An empty timestamps file printed numpy's warning with a line of source; a file of two numbers a
    line (a frame number and a time) was read as one long list of times. Both are one-line refusals
    naming the file, and nothing is written."""
    from pressurepose.cli import main

    np.save(tmp_path / "night.npy", np.zeros((4, 64, 27), np.float32))
    (tmp_path / "empty.txt").write_text("")
    np.savetxt(tmp_path / "two.csv", np.c_[np.arange(2), np.arange(2.0)], delimiter=",")  # 4 numbers, 4 frames
    np.save(tmp_path / "two.npy", np.c_[np.arange(2), np.arange(2.0)])
    for name, message in (("empty.txt", "holds no numbers; expected one number a line"),
                          ("two.csv", r"holds an array of shape \(2, 2\); expected one number a line"),
                          ("two.npy", r"holds an array of shape \(2, 2\); expected one number a line")):
        code = main(["monitor", str(tmp_path / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg",
                     "--gender", "f", "--timestamps", str(tmp_path / name), "--out", str(tmp_path / "out")])
        err = capsys.readouterr().err
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert re.search(rf"timestamps file '.*{name}' {message}", err), err
    assert not (tmp_path / "out").exists()
    np.savetxt(tmp_path / "column.txt", np.arange(4.0)[:, None])  # one number a line, as before
    assert main(["monitor", str(tmp_path / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg",
                 "--gender", "f", "--timestamps", str(tmp_path / "column.txt"), "--out", str(tmp_path / "out")]) == 0


def test_monitor_verb_reads_sites_with_the_site_network_it_is_given(tmp_path, capsys):
    """--site-net: the shipped network by default (it reads the model's mat), none for the body alone;
    one for another mat is refused before anything is read or written."""
    from pressurepose.cli import main
    from pressurepose.mat import custom_mat
    from pressurepose.net.sitenet import SiteNet, SiteNetConfig, save_site_net

    np.save(tmp_path / "night.npy", np.zeros((4, 64, 27), np.float32))
    args = ["monitor", str(tmp_path / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender", "f",
            "--fps", "1"]
    for choice, read_by, network in ((None, "site network", "shipped"), ("none", "estimated body", None)):
        out = tmp_path / f"out-{choice}"
        assert main([*args, "--out", str(out)] + ([] if choice is None else ["--site-net", choice])) == 0
        rec = json.loads((out / "timeline.json").read_text())
        assert rec["sites_read_by"] == read_by and rec["site_network"] == network
    other = save_site_net(tmp_path / "other.json", SiteNet(SiteNetConfig(custom_mat(12, 7, 0.05), width=4)))
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "o3"), "--site-net", str(other)]) == 2
    assert "reads a 12 x 7 mat; the model reads 64 x 27" in capsys.readouterr().err
    assert not (tmp_path / "o3").exists()


def test_frame_times_refuse_timestamps_that_are_not_a_1d_sequence():
    """A (T, 1) column, a (2, T/2) table or a single number were read flat as T times; each is
    refused with its shape, for frame_times' timestamps and monitor's times alike."""
    from pressurepose.eval.monitor import check_times

    for stamps in (np.arange(4.0).reshape(4, 1), np.arange(4.0).reshape(2, 2), [[0.0, 1.0], [2.0, 3.0]]):
        with pytest.raises(BadInput, match=r"timestamps have shape \((4, 1|2, 2)\); expected a 1-D sequence of 4"):
            frame_times(4, timestamps=stamps)
    with pytest.raises(BadInput, match=r"timestamps have shape \(\); expected a 1-D sequence of 1"):
        frame_times(1, timestamps=5.0)
    with pytest.raises(BadInput, match=r"times have shape \(4, 1\)"):
        check_times(np.arange(4.0)[:, None], 4, 60.0)
    np.testing.assert_allclose(frame_times(4, timestamps=np.arange(4.0) + 7), [0, 1, 2, 3])
