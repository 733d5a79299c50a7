"""CLI verb ``pressurepose evaluate``."""

from __future__ import annotations

import argparse

from pressurepose.cli.args import add_progress_argument

GALLERY_COUNT = 3  # gallery.png of evaluate-real: this many best and as many worst estimates


def add_evaluate_arguments(p: argparse.ArgumentParser) -> None:
    p.description = ("Evaluate a trained PressureNet on a generated dataset: MPJPE (24 joints) and "
                     "vertex-to-vertex error in cm, overall, by partition and by gender, beside the "
                     "paper's mean-pose baseline (mean shape, supine, centred, straight limbs); and the "
                     "posture accuracy and stature error that evaluate-real reports on real images.")
    p.add_argument("--model", default=None,
                   help="trained model (.json with its .safetensors files, .pt, or a run folder; default: the "
                        "shipped PressureNet)")
    p.add_argument("--data", required=True,
                   help="dataset directory (or a folder of datasets) from `generate`, or a training pack (.npz) from `pack`")
    p.add_argument("--out", default=None, help="folder for report.md and report.json (default: print only)")
    p.add_argument("--batch-size", type=int, default=64, help="images per forward pass (default 64)")
    p.add_argument("--limit", type=int, default=None,
                   help="evaluate only the first N samples (default: all; a quick look at a large set)")
    p.add_argument("--device", default="auto", help="auto (CUDA if available, default), cpu, cuda ...")
    from pressurepose.cli.net import add_body_arguments, add_fit_argument, add_mirror_argument

    add_mirror_argument(p)
    add_fit_argument(p)
    add_body_arguments(p)
    add_progress_argument(p)


EVALUATE_LEGEND = (
    "Per group: PressureNet (Mod1 + Mod2) beside the mean-pose baseline (BL); MPJPE: mean distance of the 24 "
    "joints; v2v: mean vertex-to-vertex distance; posture acc.: share of bodies read in the right posture "
    "(supine, left, right, prone); stature bias: estimated less true standing height; roll MAE: mean error of the "
    "body's roll, its turn about its long axis (0 on the back, +-90 deg on a side); turn bias: |estimated roll| less |true roll|, negative "
    "where a turned body is read flatter than it lies.")


def run_evaluate(args) -> int:
    from pressurepose.cli.net import body_specs
    from pressurepose.errors import BadInput
    from pressurepose.eval.report import evaluate, format_table
    from pressurepose.files import (
        check_output_path,
        write_json_atomic,
        write_text_atomic,
    )
    from pressurepose.net.data import load_dataset
    from pressurepose.net.infer import resolve_model
    from pressurepose.net.device import resolve_device

    out = check_output_path(args.out, "--out", directory=True) if args.out else None
    if args.batch_size < 1:
        raise BadInput(f"--batch-size is {args.batch_size}; expected a whole number >= 1")
    if args.limit is not None and args.limit < 1:
        raise BadInput(f"--limit is {args.limit}; expected a whole number >= 1 (or leave it out for all samples)")
    device = resolve_device(args.device)
    net = resolve_model(args.model, body_specs(args))
    net = net.to(device)
    data = load_dataset(args.data, limit=args.limit)
    result = evaluate(data, net, batch_size=args.batch_size, progress=not args.no_progress, mirror=args.mirror, fit=args.fit)
    table = format_table(result["summary"]) + "\n\n" + EVALUATE_LEGEND
    print(f"{len(data)} samples from {args.data}\n\n{table}")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        reading = ", ".join(["the network"] + ["mirror-averaged (--mirror)"] * bool(args.mirror)
                            + ["Mod2's bodies fitted to their prints (--fit)"] * bool(args.fit))
        write_text_atomic(out / "report.md", f"# PressureNet evaluation\n\nmodel: {args.model or 'shipped'}\ndata: {args.data} "
                                             f"({len(data)} samples)\nreading: {reading}\n\n{table}\n")
        write_json_atomic(out / "report.json", {"model": str(args.model or "shipped"), "data": str(args.data),
                                                "mirror": bool(args.mirror),
                                                "fit": bool(args.fit), "summary": result["summary"]})
        print(f"\nreport written to {out}")
    return 0


def add_evaluate_real_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Run a PressureNet on real pressure images with known posture, height and weight and score it: "
        "posture accuracy (supine / left / right / prone from the estimate's orientation; 'lateral' labels "
        "match either side; the estimate's roll about its long axis, 0 on the back and +-90 degrees on a side, is "
        "reported too; bodies propped on a wedge count as right when the estimate turns at least 15 degrees "
        "toward the labelled side), stature error (standing height of the estimated body at zero pose minus the "
        "measured height), mass error, and the contact IoU of the estimated body's contact map with the input. "
        "DIR is a PhysioNet PMD experiment folder (I or II, detected) or a labelled folder (images.npy, "
        "labels.csv, mat.json; docs/real-mats.md). The example real set is PhysioNet's Pressure Map Dataset "
        "(PMD 1.0.0, Open Data Commons Attribution licence; physionet.org/content/pmd/1.0.0/): download it and "
        "give its experiment-i/ folder (S1 ... S13 and subject-info-i.csv). Raw readings are weight-normalised to mmHg and resampled "
        "onto the model's mat; inclined-bed recordings are skipped. Writes OUT/metrics.json, OUT/estimates.json "
        "(one row per estimate), OUT/report.md (tables by posture, confusion matrix) and OUT/gallery.png (the "
        "best and worst estimates, one image each: posture right or wrong first, then the stature error).")
    p.add_argument("dir", help="real-data folder (PMD experiment I or II, or a labelled folder)")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    p.add_argument("--model", default=None, help="trained model (default: the shipped PressureNet)")
    p.add_argument("--gender", choices=("f", "m", "both"), default="both",
                   help="body model for images whose gender is not recorded (PMD records none): f, m, or both "
                        "(default: each such image is estimated with both body models and every summary counts "
                        "both estimates; metrics.json splits them in by_body_model)")
    p.add_argument("--force-gender", action="store_true",
                   help="use --gender (f or m) even for images whose gender is recorded")
    p.add_argument("--frames", choices=("one", "all"), default="one",
                   help="PMD recordings: one image per file (median of its non-blank frames, default) or every "
                        "non-blank frame")
    p.add_argument("--gain", type=float, default=None,
                   help="mmHg per raw unit from your mat's calibration (default: raw images are weight-normalised, "
                        "their total force set to the person's weight)")
    p.add_argument("--contact-mmhg", type=float, default=None,
                   help="input taxels above this pressure count as contact for the IoU (default: the model's "
                        "contact floor, what its contact channel means; 2 mmHg for a model without one)")
    p.add_argument("--batch-size", type=int, default=32, help="images per forward pass (default 32)")
    p.add_argument("--device", default="auto", help="auto (CUDA if available, default), cpu, cuda ...")
    from pressurepose.cli.net import add_fit_argument, add_mirror_argument

    add_mirror_argument(p)
    add_fit_argument(p)
    add_progress_argument(p)


def run_evaluate_real(args) -> int:
    import dataclasses
    import sys
    import warnings

    from pressurepose.data.readers.real import read_real
    from pressurepose.errors import BadInput
    from pressurepose.eval.real import (
        WEDGE_TURN_DEG,
        RealEvalConfig,
        evaluate_real,
        format_confusion,
        format_real_table,
        format_subject_table,
    )
    from pressurepose.files import (
        check_output_path,
        write_json_atomic,
        write_text_atomic,
    )
    from pressurepose.net.infer import resolve_model
    from pressurepose.net.device import resolve_device

    out = check_output_path(args.out, "--out", directory=True)
    device = resolve_device(args.device)
    if args.force_gender and args.gender == "both":
        raise BadInput("--force-gender needs --gender f or m")
    config = RealEvalConfig(gender=args.gender, force_gender=args.force_gender, contact_mmhg=args.contact_mmhg,
                            batch_size=args.batch_size, mirror=args.mirror, fit=args.fit)
    real = read_real(args.dir, frames=args.frames)
    if args.gain is not None:
        if not args.gain > 0:
            raise BadInput(f"--gain is {args.gain}; expected a positive number of mmHg per raw unit")
        real = dataclasses.replace(real, gain=float(args.gain))
    net = resolve_model(args.model).to(device)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = evaluate_real(real, net, config, progress=not args.no_progress)
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    s = result.summary
    out.mkdir(parents=True, exist_ok=True)
    result.write_metrics(out / "metrics.json", data=str(args.dir), model=str(args.model or "shipped"),
                         frames=args.frames, gender=args.gender, mirror=bool(args.mirror),
                         fit=bool(args.fit))
    write_json_atomic(out / "estimates.json", {"units": "metres, kg, degrees", "rows": result.per_estimate()})
    acc = "-" if s["posture_accuracy"] is None else f"{s['posture_accuracy']:.2f}"
    corr = "-" if s["stature_r"] is None else f"{s['stature_r']:.2f}"
    headline = (f"{result.n_images} images ({s['n_estimates']} estimates) from {args.dir} ({real.layout}); "
                f"skipped: {result.skipped['inclined_bed']} inclined-bed, {result.skipped['weak_recording']} "
                f"weak recordings.\n\nposture accuracy {acc}, stature MAE {100 * s['stature_mae_m']:.1f} cm "
                f"(bias {100 * s['stature_bias_m']:+.1f} cm, correlation with height "
                f"{corr}), mass MAE {s['mass_mae_kg']:.1f} kg "
                f"(bias {s['mass_bias_kg']:+.1f} kg), contact IoU {s['contact_iou']:.2f}")
    if s.get("without_wedge") and s["without_wedge"]["posture_accuracy"] is not None:
        by = ", ".join(f"{g} {a:.2f}" for g, a in s["flat_bed_by_posture"].items())
        headline += (f"\nflat bed: posture accuracy {s['without_wedge']['posture_accuracy']:.2f} over "
                     f"{s['without_wedge']['n']} estimates ({by})")
    if s.get("wedge"):
        w = s["wedge"]
        turns = ", ".join(f"{a} deg: {t:+.0f}" if a != "unknown" else f"{t:+.0f}"
                          for a, t in w["median_turn_deg"].items())
        headline += (f"\npropped on a wedge: {w['turned_right_way']:.2f} of {w['n']} estimates turn at least "
                     f"{WEDGE_TURN_DEG:.0f} degrees toward the labelled side (median turn toward it by wedge, {turns})")
    if s.get("taller_than_mat"):
        headline += (f"\nstature: {s['taller_than_mat']:.0%} of the people are taller than the mat is long "
                     f"({s['mat_length_m']:.2f} m): their images cannot show the whole body")
    if s.get("load_kg_mean") is not None and s.get("weight_kg_mean") is not None:
        headline += (f"\nmass: the images carry {s['load_kg_mean']:.1f} kg on average; the people weigh "
                     f"{s['weight_kg_mean']:.1f} kg")
    report = (f"# PressureNet on real images\n\nmodel: {args.model or 'shipped'}\n\n{headline}\n\n"
              f"## By posture\n\n{format_real_table(s)}\n\n## By posture label\n\n"
              f"{format_real_table(s, 'per_posture')}\n\n## By body model\n\n{format_real_table(s, 'by_body_model')}"
              f"\n\n## By subject\n\n{format_subject_table(s)}"
              f"\n\n## Posture confusion\n\n{format_confusion(s['confusion'])}\n")
    write_text_atomic(out / "report.md", report)
    write_gallery(result, out / "gallery.png")
    print(f"{headline}\n\n{format_real_table(s)}\n\n{format_confusion(s['confusion'])}\n\nwritten to {out}")
    return 0


def write_gallery(result, path) -> None:
    """Draw the gallery of a real-image evaluation (:func:`pressurepose.viz.gallery.gallery_figure`)
    and save it at ``path``, saying so on stderr first: drawing its rows takes seconds (most of them
    in matplotlib's layout and rendering, when the figure is saved)."""
    import sys

    import matplotlib.pyplot as plt

    from pressurepose.files import save_figure_atomic
    from pressurepose.viz.gallery import gallery_figure, gallery_picks

    kinds = [kind for kind, _ in gallery_picks(result.rows, GALLERY_COUNT)]
    print(f"drawing {path} ({kinds.count('best')} best and {kinds.count('worst')} worst estimates) ...",
          file=sys.stderr, flush=True)
    fig = gallery_figure(result, GALLERY_COUNT)
    save_figure_atomic(fig, path, dpi=100)
    plt.close(fig)


def add_realism_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Compare simulated pressure images with real ones, by posture (supine, lateral, prone): contact area "
        "(taxels > 5 mmHg, and cm^2), load share by body region along the bed (head, shoulders, back, pelvis, "
        "thighs, calves, heels: fractions of the body's contact extent, the same image-only rule for both), "
        "peak and mean contact pressure, head-imprint rate and (simulated) load off the mat; medians, quartiles "
        "and distances (median ratio, Kolmogorov-Smirnov, Wasserstein, share differences in percentage points). "
        "Real images are weight-normalised to mmHg and resampled onto the simulated mat. Prints whether each "
        "posture meets the realism targets (median contact area within 20 % of the real, a head imprint in "
        ">= 80 % of simulated images, every region's mean load share within 5 percentage points of the real). Writes OUT/realism.json "
        "and OUT/realism.png (distributions and example images side by side at one colour scale).")
    p.add_argument("--real", required=True, help="real-data folder (PMD experiment I or II, or a labelled folder)")
    p.add_argument("--synthetic", required=True,
                   help="generated dataset directory (or a folder of datasets), or a `simulate` .npz")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    p.add_argument("--mat", default=None, help="mat preset of a simulate .npz (default: found from its image shape)")
    p.add_argument("--keep-wedge", action="store_true",
                   help="also compare real images recorded on a wedge (PMD postures 4-7; left out by default: "
                        "the body is turned 30-60 deg, not lying on its side)")
    p.add_argument("--only-wedge", action="store_true",
                   help="compare only the real images recorded on a wedge (PMD postures 4-7), e.g. with a "
                        "propped_lateral dataset")
    p.add_argument("--examples", type=int, default=3, help="example images per set and posture (default 3)")
    p.add_argument("--match-extent", action="store_true",
                   help="compare like postures: resample the simulated images of each posture so that how long "
                        "the body lies (contact extent over stature) follows the real images'; region shares are "
                        "fractions of that extent, so bent or spread legs otherwise move the bands")


def run_realism(args) -> int:
    from pressurepose.cli.args import MAX_EXAMPLES
    from pressurepose.errors import BadInput
    from pressurepose.eval.realism_report import (
        draw_report,
        goal_verdicts,
        headline,
        load_real,
        load_synthetic,
        realism_report,
    )
    from pressurepose.files import check_output_path, write_json_atomic

    out = check_output_path(args.out, "--out", directory=True)
    if not 0 <= args.examples <= MAX_EXAMPLES:
        raise BadInput(f"--examples is {args.examples}; expected 0 to {MAX_EXAMPLES} images per set and posture")
    if args.keep_wedge and args.only_wedge:
        raise BadInput("--keep-wedge and --only-wedge go one at a time: --only-wedge already keeps the wedge images")
    sim = load_synthetic(args.synthetic, args.mat)
    wedge = args.keep_wedge or args.only_wedge
    real = load_real(args.real, sim.mat, exclude_detail=() if wedge else ("wedge",),
                     only_detail=("wedge",) if args.only_wedge else ())
    report = realism_report(real, sim, match=args.match_extent)
    report["headline"] = headline(report)
    report["goals"] = goal_verdicts(report["headline"])
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "realism.json", report)
    draw_report(real, sim, report, out / "realism.png", examples=args.examples)
    print(format_realism(report["headline"]))
    print("\nThe real people's 90 % intervals (resampling the people):\n\n" + format_real_intervals(report["headline"]))
    print("\n" + format_region_contacts(report))
    print("\n" + format_goals(report["goals"]))
    for g, d in report["postures"].items():
        if "match" in d:
            m = d["match"]
            print(f"{g}: matched by extent ratio (real median {m['extent_ratio_real']:.2f}, simulated "
                  f"{m['extent_ratio_sim_before']:.2f} before, {m['extent_ratio_sim']:.2f} after; "
                  f"{m['distinct_sim_images']} distinct simulated images; coverage {m['coverage']:.2f})")
    print(f"\nwritten to {out}")
    return 0


def format_region_contacts(report: dict) -> str:
    """A Markdown table of each posture's ``regions`` in a realism report: per region, the median contact
    taxels and mean reading over them, real / simulated."""
    f = lambda v, fmt: "-" if v is None else fmt.format(v)  # noqa: E731
    lines = ["| posture | region | contact taxels real / sim | mean mmHg over them real / sim |", "|---|---|---|---|"]
    for g, d in report["postures"].items():
        for region, v in d.get("regions", {}).items():
            lines.append(f"| {g} | {region} | {f(v['taxels_real'], '{:.0f}')} / {f(v['taxels_sim'], '{:.0f}')} | "
                         f"{f(v['mmhg_real'], '{:.1f}')} / {f(v['mmhg_sim'], '{:.1f}')} |")
    return "\n".join(lines)


def format_goals(verdicts: list[dict]) -> str:
    """A Markdown table of :func:`pressurepose.eval.realism_report.goal_verdicts`."""
    lines = ["| posture | measure | simulated | realism target | met |", "|---|---|---|---|---|"]
    for v in verdicts:
        value = "-" if v["value"] is None else f"{v['value']:.1f}" if "pp" in v["goal"] else f"{v['value']:.2f}"
        met = "yes" if v["met"] else "no"
        if v.get("interval") is not None:
            value += f" ({v['interval'][0]:.1f}-{v['interval'][1]:.1f})"
            if not v["met"] and v["interval_holds_goal"]:
                met = "no (the interval reaches it)"
        lines.append(f"| {v['posture']} | {v['goal']} | {value} | {v['target']} | {met} |")
    return "\n".join(lines)


def format_worst_gap(row: dict) -> str:
    """'4.4 (2.9-6.8)': the worst region's share gap with its bootstrap interval where there is one."""
    ci = row.get("share_worst_pp_interval")
    return f"{row['share_worst_pp']:.1f}" + (f" ({ci[0]:.1f}-{ci[1]:.1f})" if ci else "")


def format_real_intervals(rows: list[dict]) -> str:
    """A Markdown table of the real people's 90 % intervals of each headline statistic (rows of
    :func:`pressurepose.eval.realism_report.headline`): how far each moves with other people like
    them, so a simulated value inside it cannot be told from the real one."""
    from pressurepose.eval.realism import REGIONS

    cols = [("contact_taxels", "contact taxels", 1, "{:.0f}"), ("head_imprint", "head imprint", 1, "{:.2f}"),
            ("mean_mmhg", "mean mmHg", 1, "{:.1f}"), ("peak_mmhg", "peak mmHg", 1, "{:.1f}"),
            *((f"share_{r}", f"{r} %", 100, "{:.1f}") for r in REGIONS)]
    lines = ["| posture | " + " | ".join(c[1] for c in cols) + " |", "|---" * (1 + len(cols)) + "|"]
    for r in rows:
        ci = r.get("real_interval") or {}
        cells = ["-" if ci.get(k) is None else f"{fmt.format(scale * ci[k][0])}-{fmt.format(scale * ci[k][1])}"
                 for k, _, scale, fmt in cols]
        lines.append(f"| {r['posture']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def format_realism(rows: list[dict]) -> str:
    """A Markdown table of :func:`pressurepose.eval.realism_report.headline` rows."""
    from pressurepose.eval.realism import REGIONS

    f = lambda v, fmt: "-" if v is None else fmt.format(v)  # noqa: E731
    lines = ["| posture | images real / sim | contact taxels real / sim (ratio) | head imprint real / sim | "
             "mean mmHg real / sim | peak mmHg real / sim | load off mat (sim) | "
             + " | ".join(f"{r} % real / sim" for r in REGIONS) + " | worst share gap (pp; 90 % interval) |",
             "|---" * (8 + len(REGIONS)) + "|"]
    for r in rows:
        shares = " | ".join(f"{100 * r['share_real'][k]:.1f} / {100 * r['share_sim'][k]:.1f}" for k in REGIONS)
        lines.append(
            f"| {r['posture']} | {r['n_real']} / {r['n_sim']} | {r['area_real']:.0f} / {r['area_sim']:.0f} "
            f"({r['area_ratio']:.2f}) | {r['head_real']:.2f} / {r['head_sim']:.2f} | {r['mean_real']:.1f} / "
            f"{r['mean_sim']:.1f} | {r['peak_real']:.1f} / {r['peak_sim']:.1f} | {f(r['off_mat_sim'], '{:.3f}')} | "
            f"{shares} | {format_worst_gap(r)} |")
    return "\n".join(lines)
