"""The picture of a night on the mat: posture over time with the turns, the body's roll, and the
peak pressure of the body sites against the threshold, alerts shaded."""

from __future__ import annotations

import numpy as np

from pressurepose.body.sites import SITES, site_label
from pressurepose.eval.monitor import EMPTY, UNCLEAR, Timeline

POSTURE_COLORS = {"supine": "tab:blue", "left": "tab:green", "prone": "tab:purple", "right": "tab:orange",
                  EMPTY: "0.85", UNCLEAR: "0.55"}
SHOWN_SITES = 6  # site lines drawn: those longest above the threshold, then the most loaded


# site lines: colours other than red, the colour of the alerts
SITE_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive",
               "tab:cyan", "tab:gray")
ROLL_TICKS = {-180: "prone  -180", -90: "right  -90", 0: "supine  0", 90: "left  +90", 180: "prone  180"}


def _time_axis(times_s: np.ndarray) -> tuple[np.ndarray, str]:
    span = float(times_s[-1] - times_s[0]) if len(times_s) else 0.0
    if span >= 2 * 3600:
        return times_s / 3600.0, "hours"
    if span >= 120:
        return times_s / 60.0, "minutes"
    return times_s, "seconds"


def clock(hours: float) -> str:
    """Hours from the start as h:mm ('2:30'), as the ``monitor`` verb prints the turns' times."""
    minutes = int(round(hours * 60))
    return f"{minutes // 60}:{minutes % 60:02d}"


def night_figure(tl: Timeline):
    """A matplotlib figure of a :class:`~pressurepose.eval.monitor.Timeline`: posture band with the
    turns marked, roll angle (its ticks named by posture), and the peak pressure of the sites that
    were longest above the threshold (or the most loaded), the threshold dashed and each alert
    shaded from when the repositioning interval ran out to when the site was relieved, named at its
    start. Time runs from the first frame: h:mm over a recording of 2 hours or more (as the verb
    prints the turns), else minutes or seconds; legends stand right of the panels, off the data."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    from matplotlib.ticker import FuncFormatter, MultipleLocator

    t, unit = _time_axis(tl.times_s)
    scale = float(t[-1] / tl.times_s[-1]) if len(t) and tl.times_s[-1] > 0 else 1.0
    fig, axes = plt.subplots(3, 1, figsize=(13, 8), sharex=True, gridspec_kw={"height_ratios": [0.5, 1.2, 2.4]})
    ax = axes[0]
    cut = np.flatnonzero(tl.posture[1:] != tl.posture[:-1]) + 1
    end = t[-1] + (t[-1] - t[-2] if len(t) > 1 else 1.0)
    for s, e in zip(np.r_[0, cut], np.r_[cut, len(t)]):
        right = t[e] if e < len(t) else end
        ax.axvspan(t[s], right, color=POSTURE_COLORS.get(str(tl.posture[s]), "0.5"), lw=0)
    ax.set_xlim(t[0] if len(t) else 0.0, end)  # the band fills the recording, no margin either side
    ax.set_yticks([])
    ax.set_title(f"posture ({len(tl.turns)} turn{'' if len(tl.turns) == 1 else 's'}{', dotted' if tl.turns else ''}; "
                 f"body estimated on "
                 f"{int(tl.estimated.sum())} of {len(tl)} frames, the others unchanged since)")
    ax.legend(handles=[Patch(color=c, label=p) for p, c in POSTURE_COLORS.items()
                       if p in set(tl.posture.tolist())], loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              title="posture", title_fontsize=8)
    ax = axes[1]
    ax.plot(t, tl.roll_deg, lw=0.8, color="0.2")
    for b in (-135, -45, 45, 135):
        ax.axhline(b, color="0.8", lw=0.6)
    ax.set_ylim(-185, 185)
    ax.set_yticks(list(ROLL_TICKS), list(ROLL_TICKS.values()), fontsize=8)
    ax.set_ylabel("roll (deg)")
    for turn in tl.turns:
        for a in axes:
            a.axvline(turn.time_s * scale, color="k", ls=":", lw=1)
        axes[1].text(turn.time_s * scale, 170, f" {turn.after}", fontsize=7, va="top")
    ax = axes[2]
    order = sorted(range(len(SITES)), key=lambda k: (tl.above_s[SITES[k]], tl.share[:, k].mean()), reverse=True)
    shown = [k for k in order if SITES[k] != "other" and tl.peak_mmhg[:, k].max() > 0][:SHOWN_SITES]
    for n, k in enumerate(shown):
        ax.plot(t, tl.peak_mmhg[:, k], lw=0.9, label=site_label(SITES[k]), color=SITE_COLORS[n % len(SITE_COLORS)])
    ax.axhline(tl.config.threshold_mmhg, color="k", ls="--", lw=1, label=f"threshold {tl.config.threshold_mmhg:g} mmHg")
    top = ax.get_ylim()[1]
    for n, alert in enumerate(tl.alerts):
        ax.axvspan(alert.due_s * scale, alert.end_s * scale, color="tab:red", alpha=0.15, lw=0,
                   label="alert: turn due" if n == 0 else None)
        ax.text(alert.due_s * scale, top * (0.99 - 0.06 * (n % 5)), site_label(alert.site), color="tab:red",
                fontsize=7, va="top", zorder=5,
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85})
    ax.set_ylabel("peak pressure (mmHg)")
    if unit == "hours":
        ax.xaxis.set_major_locator(MultipleLocator(1.0 if t[-1] - t[0] >= 4 else 0.5))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: clock(v)))
        ax.set_xlabel("time from the start of the recording (h:mm)")
    else:
        ax.set_xlabel(f"time from the start of the recording ({unit})")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="body site", title_fontsize=8)
    ax.set_title(f"peak pressure per body site; red shading: above {tl.config.threshold_mmhg:g} mmHg for longer than "
                 f"{tl.config.reposition_s / 3600:g} h, from when the turn was due ({len(tl.alerts)} "
                 f"alert{'' if len(tl.alerts) == 1 else 's'})")
    fig.tight_layout()
    return fig
