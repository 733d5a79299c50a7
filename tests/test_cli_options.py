"""Each command-line option reaches what it sets, and the options whose effect no other test checks
have it: train's optimiser and schedule options, the sampler's lateral spread and pose-file frame,
generate's ways of running, evaluate-real's gender and frame choices, monitor's timing and reading
options, view-body's capsules."""

import json

import numpy as np
import pytest
import torch

from pressurepose.cli import main

torch.set_num_threads(1)


# --------------------------------------------------------------------------- train
def _train_config(tmp_path, monkeypatch, *extra):
    """The TrainConfig `train` builds from its flags (training itself is skipped)."""
    import pressurepose.net.train as train_module
    from tests.net.synth import write_toy_dataset

    seen = {}

    def fake_train(tensors, out, config, **kwargs):
        seen["config"], seen["progress"] = config, kwargs["progress"]
        return train_module.TrainResult(out, [])

    monkeypatch.setattr(train_module, "train", fake_train)
    if not (tmp_path / "data").exists():
        write_toy_dataset(tmp_path / "data", n=4)
    assert main(["train", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "run"), "--female", "toy",
                 "--male", "toy", *extra]) == 0
    return seen["config"], seen["progress"]


def test_every_train_flag_reaches_the_training_config(tmp_path, monkeypatch):
    from pressurepose.net.train_config import TrainConfig

    d, progress = _train_config(tmp_path, monkeypatch)
    assert progress is True and _train_config(tmp_path, monkeypatch, "--no-progress")[1] is False
    assert d == TrainConfig()  # no options: the Python API's defaults, every field
    assert (d.lr_mod2, d.lr_schedule, d.gender_input, d.loss_sigmas, d.amp, d.save_every, d.cnn, d.cpu_amp,
            d.turn_loss, d.contact_floor_mmhg, d.val_fraction) == (None, "constant", False, "paper", True, 1,
                                                                  "paper", False, 0.0, 5.0, 0.05)
    c, _ = _train_config(tmp_path, monkeypatch, "--epochs-mod1", "3", "--epochs-mod2", "2", "--batch-size", "16",
                      "--lr", "1e-3", "--lr-mod2", "2e-4", "--lr-schedule", "cosine", "--weight-decay", "0",
                      "--no-noise", "--no-pmr", "--no-edges-contact", "--gender-input", "--loss-sigmas", "data",
                      "--val-fraction", "0.1", "--seed", "7", "--device", "cpu", "--no-amp", "--cpu-amp",
                      "--cnn", "half", "--contact-floor", "2", "--turn-loss", "1.5", "--save-every", "4")
    assert (c.epochs_mod1, c.epochs_mod2, c.batch_size, c.lr, c.lr_mod2, c.lr_schedule, c.weight_decay) == \
        (3, 2, 16, 1e-3, 2e-4, "cosine", 0.0)
    assert (c.noise, c.use_pmr, c.edges_contact, c.gender_input, c.loss_sigmas) == (False, False, False, True, "data")
    assert (c.val_fraction, c.seed, c.device, c.amp, c.cpu_amp, c.cnn) == (0.1, 7, "cpu", False, True, "half")
    assert (c.contact_floor_mmhg, c.turn_loss, c.save_every) == (2.0, 1.5, 4)


def test_weight_decay_and_each_stages_rate_reach_the_optimiser():
    from pressurepose.net.train import _optimizer
    from pressurepose.net.train_config import TrainConfig

    module = torch.nn.Linear(2, 2)
    cfg = TrainConfig(lr=1e-3, lr_mod2=2e-4, weight_decay=0.01)
    assert [(_optimizer(module, cfg, s).param_groups[0]["lr"], _optimizer(module, cfg, s).param_groups[0]
             ["weight_decay"]) for s in (1, 2)] == [(1e-3, 0.01), (2e-4, 0.01)]
    assert _optimizer(module, TrainConfig(lr=1e-3), 2).param_groups[0]["lr"] == 1e-3  # Mod2 at --lr by default


def test_loss_sigmas_data_takes_the_training_sets_spread(tmp_path):
    from pressurepose.net.checkpoint import load_model
    from pressurepose.net.losses import PAPER_SIGMA_BETAS
    from pressurepose.net.train import train
    from pressurepose.net.train_config import TrainConfig
    from tests.net.synth import toy_body, toy_dataset
    from tests.net.test_train import GRID

    data = toy_dataset(4, seed=1, grid=GRID)
    body = toy_body()
    scales = {}
    for sigmas in ("paper", "data"):
        cfg = TrainConfig(epochs_mod1=1, epochs_mod2=0, batch_size=4, lr=1e-4, loss_sigmas=sigmas, use_pmr=False)
        result = train(data, tmp_path / sigmas, cfg, bodies=(body, body), grid=GRID)
        scales[sigmas] = load_model(result.model_path)[1]["loss_scales"]
    assert scales["paper"]["betas"] == pytest.approx(PAPER_SIGMA_BETAS)
    assert scales["data"]["betas"] == pytest.approx(float(data["betas"].double().std()), rel=1e-4)
    assert scales["data"]["betas"] != pytest.approx(PAPER_SIGMA_BETAS)


def test_save_every_sets_which_epochs_leave_a_resumable_state(tmp_path, monkeypatch):
    import pressurepose.net.train as train_module
    from pressurepose.net.train_config import TrainConfig
    from tests.net.synth import toy_body, toy_dataset
    from tests.net.test_train import GRID

    saved, real_save = [], train_module._save_state
    monkeypatch.setattr(train_module, "_save_state",
                        lambda out, net, opt, record: saved.append((record["stage"], record["epoch"]))
                        or real_save(out, net, opt, record))
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=5, epochs_mod2=2, batch_size=4, lr=1e-4, save_every=2, use_pmr=False)
    train_module.train(toy_dataset(4, seed=2, grid=GRID), tmp_path, cfg, bodies=(body, body), grid=GRID)
    assert saved == [(1, 1), (1, 3), (1, 4), (2, 1)]  # every second epoch, and each stage's last


# --------------------------------------------------------------------------- sample, simulate, generate
def _generate_calls(tmp_path, monkeypatch, *extra, what=("--partition", "general", "--gender", "f", "--count", "2")):
    """(GenerationConfig, keywords) of the first dataset `generate` would make with these flags."""
    import pressurepose.data.generate as generate_module

    calls = []

    def fake_generate(config, out, **kwargs):
        calls.append((config, kwargs))
        raise SystemExit(0)  # stop before anything is made

    monkeypatch.setattr(generate_module, "generate", fake_generate)
    with pytest.raises(SystemExit):
        main(["generate", *what, "--out", str(tmp_path / "g"), *extra])
    return calls[0]


def test_generate_passes_the_sampler_and_running_flags_on(tmp_path, monkeypatch):
    from pressurepose.pose.posefile import PoseFile
    from tests.data.test_generate_poses import pose_file

    config, kw = _generate_calls(tmp_path, monkeypatch)
    assert (config.across_sd_m, config.across_sd_lateral_m, config.poses) == (0.03, 0.08, "")
    assert (kw["workers"], kw["ray_address"], kw["retries"]) == ("auto", None, 2)
    pose_file(tmp_path / "mine.npz")
    config, kw = _generate_calls(tmp_path, monkeypatch, "--across-sd", "0.05", "--across-sd-lateral", "0.12",
                                 "--poses", str(tmp_path / "mine.npz"), "--pose-frame", "camera",
                                 "--pose-noise", "3", "--workers", "2", "--ray", "auto", "--retries", "5")
    assert (config.across_sd_m, config.across_sd_lateral_m) == (0.05, 0.12)
    assert config.pose_file() == PoseFile.of(tmp_path / "mine.npz", "camera", 3.0)
    assert (kw["workers"], kw["ray_address"], kw["retries"]) == (2, "auto", 5)


def test_generate_passes_the_height_reference_to_the_sampler(tmp_path, monkeypatch):
    """generate --height-reference: the dataset's config and so the sampler it builds ('proximal' unless
    given), for one partition and for a recipe's entries."""
    from pressurepose.data.physics import sampler_config

    config, _ = _generate_calls(tmp_path, monkeypatch)
    assert config.height_reference == "proximal" == sampler_config(config).height_reference
    config, _ = _generate_calls(tmp_path, monkeypatch, "--height-reference", "bed")
    assert config.height_reference == "bed" == sampler_config(config).height_reference
    config, _ = _generate_calls(tmp_path, monkeypatch, "--height-reference", "bed", what=("--recipe", "paper"))
    assert config.height_reference == "bed"


def test_a_dataset_made_with_the_bed_height_reference_resumes_only_with_it(tmp_path, capsys):
    """One physics sample made with --height-reference bed: its manifest records the rule for the
    sampler; rerunning the command resumes, rerunning it without the option is refused by name."""
    out = tmp_path / "bed"
    cmd = ["generate", "--partition", "general_supine", "--gender", "f", "--count", "1", "--seed", "3",
           "--no-progress", "--out", str(out)]
    assert main([*cmd, "--height-reference", "bed"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["height_reference"] == manifest["provenance"]["sampler"]["height_reference"] == "bed"
    assert main([*cmd, "--height-reference", "bed"]) == 0
    assert "kept 1" in capsys.readouterr().out
    assert main(cmd) == 2
    assert "height_reference: 'bed' on disk vs 'proximal' now" in capsys.readouterr().err


def test_the_lateral_spread_moves_side_lying_bodies_across_the_bed(tmp_path):
    """sample --across-sd-lateral: side-lying pelvises spread across the bed by it, not by --across-sd."""
    spread = {}
    for sd in ("0.01", "0.15"):
        out = tmp_path / f"s{sd}.npz"
        assert main(["sample", "--partition", "general_lateral", "--gender", "f", "--count", "40", "--seed", "3",
                     "--across-sd-lateral", sd, "--out", str(out)]) == 0
        spread[sd] = float(np.std(np.load(out)["joints"][:, 0, 0]))  # pelvis x, across the bed
    assert spread["0.01"] < 0.04 < 0.08 < spread["0.15"]


# --------------------------------------------------------------------------- evaluate-real
def test_evaluate_real_force_gender_and_every_frame(tmp_path):
    from pressurepose.net.infer import DEFAULT_MODEL
    from tests.data.realfolders import body_image, write_labelled, write_pmd_i

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    imgs = np.stack([body_image(64, 27, seed=i, scale=20) for i in range(2)])
    folder = write_labelled(tmp_path / "lab", imgs, ["supine", "left"], {"preset": "boditrak_bt3510", "units": "mmHg"},
                            heights=[1.6, 1.7], weights=[60, 70], genders=["f", "m"])
    for flags, models in (([], ["f", "m"]), (["--gender", "m", "--force-gender"], ["m", "m"])):
        out = tmp_path / f"out{len(flags)}"
        assert main(["evaluate-real", str(folder), "--out", str(out), *flags]) == 0
        rows = json.loads((out / "estimates.json").read_text())["rows"]
        assert [r["body_model"] for r in rows] == models
    pmd = write_pmd_i(tmp_path / "pmd", subjects=(1,), postures=(1,), frames=5)
    counts = {}
    for frames in ("one", "all"):
        assert main(["evaluate-real", str(pmd), "--out", str(tmp_path / frames), "--gender", "f",
                     "--frames", frames]) == 0
        m = json.loads((tmp_path / frames / "metrics.json").read_text())
        counts[frames] = (m["n_images"], m["frames"])
    assert counts["one"] == (1, "one") and counts["all"][0] > 1 and counts["all"][1] == "all"


# --------------------------------------------------------------------------- monitor
def test_monitor_change_gap_and_head_row(tmp_path):
    from tests.eval.test_monitor import NIGHT_FRAMES, night_recording

    if not NIGHT_FRAMES.is_file():
        pytest.skip("tools/record_night_frames.py has not been run")
    frames, _ = night_recording([("supine", 30), ("left", 30)])
    np.save(tmp_path / "night.npy", frames)
    np.save(tmp_path / "flipped.npy", frames[:, ::-1])
    t = np.arange(len(frames), dtype=float)
    t[40:] += 90  # a 91 s gap between frames 39 and 40
    np.savetxt(tmp_path / "t.txt", t)

    def run(name, recording, *flags):
        out = tmp_path / name
        rc = main(["monitor", str(tmp_path / recording), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender",
                   "f", "--timestamps", str(tmp_path / "t.txt"), "--min-posture-s", "10", "--out", str(out), *flags])
        if rc:
            return None, None
        rows = [r.split(",") for r in (out / "timeline.csv").read_text().splitlines()[1:]]
        return json.loads((out / "timeline.json").read_text()), [(r[1], r[2]) for r in rows]

    assert run("refused", "night.npy") == (None, None)  # a 91 s gap is past the default --max-gap-s 60
    plain, read = run("plain", "night.npy", "--max-gap-s", "120")
    assert plain["settings"]["max_gap_s"] == 120 and plain["frames_estimated"] < len(frames) / 2
    assert (plain["settings"]["threshold_mmhg"], plain["settings"]["relief_s"]) == (32.0, 60.0)
    low, _ = run("low", "night.npy", "--max-gap-s", "120", "--threshold-mmhg", "20", "--relief-s", "5")
    assert (low["settings"]["threshold_mmhg"], low["settings"]["relief_s"]) == (20.0, 5.0)
    assert sum(low["above_threshold_s"].values()) > sum(plain["above_threshold_s"].values())
    assert {"supine", "left"} <= {posture for posture, _ in read}
    every, _ = run("every", "night.npy", "--max-gap-s", "120", "--change", "0")
    assert every["settings"]["change"] == 0 and every["frames_estimated"] == len(frames)
    # the same night recorded with the feet at row 0: --head-row last reads it as the plain one
    assert run("flipped", "flipped.npy", "--max-gap-s", "120", "--head-row", "last")[1] == read
    assert run("upside-down", "flipped.npy", "--max-gap-s", "120")[1] != read


# --------------------------------------------------------------------------- view-body
def test_view_body_draws_the_capsules_unless_told_not_to(tmp_path, monkeypatch):
    import pressurepose.viz.mesh as mesh

    drawn, real_draw = [], mesh.draw_capsules
    monkeypatch.setattr(mesh, "draw_capsules", lambda *a, **k: drawn.append(1) or real_draw(*a, **k))
    assert main(["view-body", "--out", str(tmp_path / "a.png")]) == 0
    assert drawn
    drawn.clear()
    assert main(["view-body", "--no-capsules", "--out", str(tmp_path / "b.png")]) == 0
    assert not drawn and (tmp_path / "b.png").stat().st_size > 0
