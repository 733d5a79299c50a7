"""CLI verb ``pressurepose monitor``: a recording over time, read by PressureNet."""

from __future__ import annotations

import argparse

from pressurepose.cli.args import add_progress_argument, add_recording_arguments
from pressurepose.eval.monitor import (
    CAPILLARY_CLOSING_MMHG,
    REPOSITION_S,
    MonitorConfig,
)

SHOWN_TURNS = 12


def add_monitor_arguments(p: argparse.ArgumentParser) -> None:
    d = MonitorConfig()
    p.description = (
        "Read a recording of one person over time (a night on the mat) with PressureNet: posture and roll "
        "per frame, when the person turned, time in each posture, the peak pressure of each body site over "
        "time, the time each site spent above a threshold, and an alert where a site stayed above it for "
        "longer than a repositioning interval. A frame is estimated only when its load changed since the "
        "last estimated frame; every frame's own readings are split over the body sites. Writes "
        "timeline.csv (a row per frame), timeline.json (the findings, per posture held and per minute) and "
        "night.png in --out (docs/monitoring.md).")
    p.add_argument("recording", metavar="RECORDING",
                   help="the frames: a .npy of (T, rows, cols), a .txt of one frame a line (PMD experiment I's "
                        "layout), a single frame (.npy of (rows, cols), .csv, .txt), or a folder of one-frame "
                        "files (.npy, .csv, .txt) in the natural order of their names")
    add_recording_arguments(p, required=True)
    p.add_argument("--gender", required=True, help="f or m")
    timing = p.add_mutually_exclusive_group()
    timing.add_argument("--fps", type=float, default=None, help="frames per second of the recording")
    timing.add_argument("--timestamps", default=None, metavar="FILE",
                        help="a timestamp (seconds) per frame: .npy, or a .csv / .txt of one number a line")
    p.add_argument("--threshold-mmhg", type=float, default=CAPILLARY_CLOSING_MMHG,
                   help=f"pressure above which a site counts as loaded (default {CAPILLARY_CLOSING_MMHG:g} mmHg, the "
                        f"capillary closing pressure most cited in the pressure-injury literature: Landis 1930)")
    p.add_argument("--reposition-h", type=float, default=REPOSITION_S / 3600,
                   help=f"alert when a site stays above the threshold longer than this (default "
                        f"{REPOSITION_S / 3600:g} hours, the common repositioning interval)")
    p.add_argument("--relief-s", type=float, default=d.relief_s,
                   help=f"a site is relieved when it stays at or under the threshold this long (default "
                        f"{d.relief_s:g} s)")
    p.add_argument("--change", type=float, default=d.change,
                   help=f"estimate a frame again when its load changed by more than this fraction (relative L1) "
                        f"since the last estimated frame (default {d.change:g}; 0 estimates every frame)")
    p.add_argument("--min-posture-s", type=float, default=d.min_posture_s,
                   help=f"a posture held for less than this is a movement, not a turn (default {d.min_posture_s:g} s)")
    p.add_argument("--max-gap-s", type=float, default=d.max_gap_s,
                   help=f"refuse a recording with a longer gap between frames (default {d.max_gap_s:g} s)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--model", default=None, help="trained model (default: the shipped PressureNet)")
    p.add_argument("--batch-size", type=int, default=64, help="frames per forward pass (default 64)")
    from pressurepose.cli.net import add_body_arguments, add_site_net_argument

    add_site_net_argument(p)
    add_body_arguments(p)
    add_progress_argument(p)


def _timestamps(path):
    """(T,) seconds from a timestamps file: a .npy, or a .csv / .txt of one number a line."""
    import warnings
    from pathlib import Path

    import numpy as np

    from pressurepose.data.readers.recording import read_array_file
    from pressurepose.errors import BadInput

    path = Path(path)
    if path.suffix.lower() == ".npy":
        values = read_array_file(path, "timestamps")
    elif path.suffix.lower() not in (".csv", ".txt"):
        raise BadInput(f"timestamps file {str(path)!r}: expected .npy, .csv or .txt (one number a line)")
    elif not path.is_file():
        raise BadInput(f"timestamps file {str(path)!r} does not exist")
    else:
        try:
            with warnings.catch_warnings():  # an empty file: our error below, not numpy's warning
                warnings.simplefilter("ignore", UserWarning)
                values = np.loadtxt(path, delimiter="," if path.suffix.lower() == ".csv" else None, ndmin=1)
        except ValueError as exc:
            raise BadInput(f"timestamps file {str(path)!r} could not be read ({exc})") from None
        if values.size == 0:
            raise BadInput(f"timestamps file {str(path)!r} holds no numbers; expected one number a line")
    if sum(n > 1 for n in np.shape(values)) > 1:  # e.g. a frame number and a time a line
        raise BadInput(f"timestamps file {str(path)!r} holds an array of shape {np.shape(values)}; expected one "
                       f"number a line (a timestamp per frame, in seconds)")
    return np.asarray(values).ravel()


def _clock(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def run_monitor(args) -> int:
    import sys
    import time
    import warnings

    import matplotlib.pyplot as plt
    import numpy as np

    from pressurepose.body.sites import site_label
    from pressurepose.cli.net import body_specs, site_net_choice
    from pressurepose.data.readers.recording import read_frames, resolve_mat
    from pressurepose.data.schema import check_gender
    from pressurepose.errors import BadInput
    from pressurepose.eval.monitor import (
        frame_times,
        monitor,
        recording_input,
    )
    from pressurepose.files import (
        check_output_path,
        save_figure_atomic,
        write_json_atomic,
        write_text_atomic,
    )
    from pressurepose.net.infer import resolve_model
    from pressurepose.viz.monitor import night_figure

    out = check_output_path(args.out, "--out", directory=True)
    if args.fps is None and args.timestamps is None:
        raise BadInput("the recording's timing is needed: give --fps (frames per second) or --timestamps FILE")
    if args.batch_size < 1:
        raise BadInput(f"--batch-size is {args.batch_size}; expected 1 or more")
    from pressurepose.errors import require_non_negative, require_positive

    for flag in ("--threshold-mmhg", "--reposition-h", "--max-gap-s"):  # named as the user typed them
        require_positive(flag, getattr(args, flag[2:].replace("-", "_")))
    for flag in ("--relief-s", "--change", "--min-posture-s"):
        require_non_negative(flag, getattr(args, flag[2:].replace("-", "_")))
    config = MonitorConfig(threshold_mmhg=args.threshold_mmhg, reposition_s=args.reposition_h * 3600.0,
                           relief_s=args.relief_s, change=args.change, min_posture_s=args.min_posture_s,
                           max_gap_s=args.max_gap_s)
    gender = check_gender(args.gender)
    net = resolve_model(args.model, body_specs(args))
    from pressurepose.net.sitenet import resolve_site_net

    site_net = resolve_site_net(site_net_choice(args.site_net), net.config.grid)  # refused before reading
    mat, _ = resolve_mat(args.mat)
    started = time.perf_counter()
    raw = read_frames(args.recording, mat.shape)
    times = frame_times(len(raw), fps=args.fps, max_gap_s=config.max_gap_s,
                        timestamps=None if args.timestamps is None else _timestamps(args.timestamps))
    frames, occupied = recording_input(raw, args.mat, args.units, net.config.grid, weight_kg=args.weight_kg,
                                       gain=args.gain, head_row=args.head_row)
    del raw
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tl = monitor(frames, times, gender, net, config, batch_size=args.batch_size, site_net=site_net,
                     progress=len(frames) > 2000 and not args.no_progress)
    for w in caught[:5]:
        print(f"warning: {w.message}", file=sys.stderr)
    elapsed = time.perf_counter() - started
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "timeline.json", tl.to_dict())
    write_text_atomic(out / "timeline.csv", tl.to_csv())
    fig = night_figure(tl)
    save_figure_atomic(fig, out / "night.png", dpi=110)
    plt.close(fig)
    dur = float(tl.summary()["duration_s"] or 0.0)
    print(f"{len(tl)} frames over {_clock(dur)} ({int((~occupied).sum())} without anybody on the mat); the network "
          f"read {int(tl.estimated.sum())} of them; done in {elapsed:.0f} s")
    doubtful = np.flatnonzero(tl.doubtful)
    if len(doubtful):
        first = int(doubtful[0])
        print(f"warning: {len(doubtful)} frame(s) do not look like a person lying on the mat, first frame {first} at "
              f"{_clock(tl.times_s[first])}: {tl.plausibility.reason[first]}; their posture and pressures mean nothing "
              f"(\"doubtful\" in timeline.csv)", file=sys.stderr)
    print("time in each posture: " + ", ".join(f"{k} {_clock(v)}" for k, v in tl.posture_s.items() if v > 0))
    print(f"{len(tl.turns)} turn(s)" + (":" if tl.turns else ""))
    for turn in tl.turns[:SHOWN_TURNS]:
        print(f"  {_clock(turn.time_s)}  {turn.before} -> {turn.after} (roll {turn.roll_change_deg:+.0f} deg)")
    if len(tl.turns) > SHOWN_TURNS:
        print(f"  ... and {len(tl.turns) - SHOWN_TURNS} more (timeline.json)")
    above = sorted(((v, k) for k, v in tl.above_s.items() if v > 0 and k != "other"), reverse=True)
    print(f"above {config.threshold_mmhg:g} mmHg: " + (", ".join(
        f"{site_label(k)} {_clock(v)} (longest {_clock(tl.longest_above_s[k])})" for v, k in above[:6])
        or "no site"))
    print(f"{len(tl.alerts)} alert(s): a site above {config.threshold_mmhg:g} mmHg longer than "
          f"{config.reposition_s / 3600:g} h" + (":" if tl.alerts else ""))
    for a in tl.alerts[:SHOWN_TURNS]:
        print(f"  {site_label(a.site)}: loaded from {_clock(a.start_s)}, due to turn at {_clock(a.due_s)}, "
              f"relieved at {_clock(a.end_s)} (peak {a.peak_mmhg:.0f} mmHg)")
    print(f"written: {out / 'timeline.json'}, {out / 'timeline.csv'}, {out / 'night.png'}")
    return 0
