"""The one entry point: every registered verb is listed and answers --help."""

import pytest

from pressurepose.cli import VERBS, main


def test_top_level_help_lists_every_verb(capsys):
    assert main([]) == 2  # a verb is required: the usage is the answer, with argparse's error status
    text = capsys.readouterr().err
    for verb in VERBS:
        assert verb in text


@pytest.mark.parametrize("verb", list(VERBS))
def test_every_verb_has_help(verb, capsys):
    with pytest.raises(SystemExit) as exc:
        main([verb, "--help"])
    assert exc.value.code == 0
    assert len(capsys.readouterr().out) > 200


@pytest.mark.parametrize("verb", list(VERBS))
def test_help_speaks_to_users_not_to_the_test_suite_or_the_source(verb, capsys):
    with pytest.raises(SystemExit):
        main([verb, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "'toy'" not in text  # the tests' tiny body model is no choice for a user
    assert ".py)" not in text and ".py;" not in text  # docs/, not the package's source files


@pytest.mark.parametrize("verb", list(VERBS))
def test_every_option_says_what_it_does_and_its_default(verb):
    import argparse
    import importlib
    import re

    module, stem, _ = VERBS[verb]
    p = argparse.ArgumentParser()
    getattr(importlib.import_module(module), f"add_{stem}_arguments")(p)
    for a in p._actions:
        if isinstance(a, argparse._HelpAction):
            continue
        text = a.help or ""
        what = re.sub(r"\(default[^)]*\)|\[[^\]]*\]|^default.*", "", text).split()
        assert len(what) >= 2, f"{verb} {a.option_strings or a.dest}: {text!r} does not say what it does"
        if a.default not in (None, False, []) and not a.required:
            assert "default" in text or "[" in text or str(a.default) in text, \
                f"{verb} {a.option_strings}: {text!r} does not give its default {a.default!r}"


def test_an_estimate_loaded_most_off_the_named_sites_also_names_the_site_loaded_most():
    from types import SimpleNamespace

    import numpy as np

    from pressurepose.body.sites import OTHER, SITES, SiteLoads, site_index
    from pressurepose.cli.net import most_loaded

    share, peak = np.zeros((1, len(SITES))), np.zeros((1, len(SITES)))
    share[0, OTHER], peak[0, OTHER] = 0.6, 50.0
    share[0, site_index("sacrum")], peak[0, site_index("sacrum")] = 0.4, 47.0
    loads = SiteLoads(peak_mmhg=peak, mean_mmhg=peak, area_cm2=share, share=share,
                      taxel_site=np.zeros((1, 2, 2), np.int8))
    said = most_loaded(SimpleNamespace(sites=loads), 0)
    assert said == ("; most loaded: rest of the body (60 %, peak 50 mmHg); of the named sites: sacrum (40 %, "
                    "peak 47 mmHg)")


def test_unknown_verb_is_an_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fly"])
    assert exc.value.code == 2


@pytest.mark.parametrize("module", ["pressurepose", "pressurepose.cli"])
def test_python_m_runs_the_command(module):
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", module, "info", "--help"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "usage:" in done.stdout and "info" in done.stdout


def test_train_help_names_each_default_that_is_not_the_papers():
    """`train`'s defaults are TrainConfig's; it says they are the paper's but for those PAPER_TRAINING
    holds the paper's values of, and names those."""
    import argparse
    import dataclasses

    from pressurepose.cli.net import add_train_arguments
    from pressurepose.net.train_config import PAPER_TRAINING, TrainConfig

    p = argparse.ArgumentParser()
    add_train_arguments(p)
    args = vars(p.parse_args(["--data", "d", "--out", "o"]))
    args["contact_floor_mmhg"] = args.pop("contact_floor")
    defaults = dataclasses.asdict(TrainConfig())
    assert {k: v for k, v in args.items() if k in defaults and v != defaults[k]} == {}
    assert {k: defaults[k] for k in PAPER_TRAINING} == {"contact_floor_mmhg": 5.0, "val_fraction": 0.05}
    assert all(PAPER_TRAINING[k] != defaults[k] for k in PAPER_TRAINING)
    text = " ".join(p.description.split())
    assert "but for the contact floor (5 mmHg) and a 5 % validation share" in text
