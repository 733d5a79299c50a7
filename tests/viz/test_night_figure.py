"""The night plot (``monitor``'s night.png) without being looked at: time from the start in h:mm
over hours, the posture band filling the recording, roll ticks named by posture, sites named for
people in colours other than the alerts' red, legends off the data, and no matplotlib warnings."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pressurepose.body.sites import SITES, site_index  # noqa: E402
from pressurepose.eval.monitor import Alert, MonitorConfig, Timeline, Turn  # noqa: E402
from pressurepose.viz.monitor import clock, night_figure  # noqa: E402


def _night(hours=8.0, step_s=60.0):
    t = np.arange(0.0, hours * 3600, step_s)
    n, s = len(t), len(SITES)
    turn_at = int(n * 0.4)
    posture = np.array(["supine"] * turn_at + ["right"] * (n - turn_at))
    roll = np.where(posture == "supine", 2.0, -85.0)
    peak = np.zeros((n, s))
    peak[:turn_at, site_index("sacrum")] = 45.0
    peak[turn_at:, site_index("right_trochanter")] = 60.0
    peak[:, site_index("head")] = 20.0
    share = np.where(peak > 0, 0.1, 0.0)
    above = {name: 0.0 for name in SITES}
    above["sacrum"], above["right_trochanter"] = t[turn_at], t[-1] - t[turn_at]
    config = MonitorConfig()
    alerts = [Alert(site="sacrum", start_s=0.0, end_s=float(t[turn_at]), duration_s=float(t[turn_at]),
                    due_s=config.reposition_s, peak_mmhg=45.0)]
    return Timeline(times_s=t, posture=posture, roll_deg=roll, estimated=np.ones(n, bool), peak_mmhg=peak,
                    mean_mmhg=peak / 2, share=share,
                    turns=[Turn(time_s=float(t[turn_at]), frame=turn_at, before="supine", after="right",
                                roll_change_deg=-87.0)],
                    posture_s={"supine": float(t[turn_at]), "right": float(t[-1] - t[turn_at])}, above_s=above,
                    longest_above_s=above, alerts=alerts, config=config)


def test_night_plot_reads_hours_as_clock_time_names_sites_for_people_and_keeps_legends_off_the_data(no_warnings, drawn):
    tl = _night()
    fig = night_figure(tl)
    try:
        renderer = drawn(fig)
        band, roll, sites = fig.axes[:3]
        assert "h:mm" in sites.get_xlabel()
        ticks = [t.get_text() for t in sites.get_xticklabels() if t.get_text()]
        assert "2:00" in ticks and "8:00" in ticks
        # the posture band fills the recording: no blank margin before the first frame or after the last
        assert band.get_xlim()[0] == pytest.approx(0.0) and band.get_xlim()[1] == pytest.approx(8.0)
        assert sites.get_ylabel() == "peak pressure (mmHg)"
        assert [t.get_text() for t in roll.get_yticklabels()][1:4] == ["right  -90", "supine  0", "left  +90"]
        names = [t.get_text() for t in sites.get_legend().get_texts()]
        assert "right hip (trochanter)" in names and "sacrum" in names and "threshold 32 mmHg" in names
        assert not any("_" in name for name in names)
        # site lines are not red, the alerts' colour
        lines = [ln for ln in sites.get_lines() if ln.get_label() in names and ln.get_linestyle() == "-"]
        assert lines and all(matplotlib.colors.to_hex(ln.get_color()) != matplotlib.colors.to_hex("tab:red")
                             for ln in lines)
        # the alert is named for people where it starts, in red
        alert = [t for t in sites.texts if t.get_text() == "sacrum"]
        assert len(alert) == 1 and alert[0].get_position()[0] == pytest.approx(2.0)
        for ax in (band, sites):  # legends stand right of their panels
            assert ax.get_legend().get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1
        assert "1 alert)" in sites.get_title()
    finally:
        plt.close(fig)


def test_a_short_recording_reads_seconds_and_says_no_turn_marks():
    tl = _night(hours=0.1, step_s=1.0)
    tl = Timeline(**{**tl.__dict__, "turns": [], "alerts": []})
    fig = night_figure(tl)
    try:
        assert fig.axes[2].get_xlabel() == "time from the start of the recording (minutes)"
        assert "dotted" not in fig.axes[0].get_title() and "0 alerts" in fig.axes[2].get_title()
    finally:
        plt.close(fig)


def test_clock_reads_hours_as_h_mm():
    assert [clock(h) for h in (0.0, 0.5, 2.25, 7.999)] == ["0:00", "0:30", "2:15", "8:00"]


