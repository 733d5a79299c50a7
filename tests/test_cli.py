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


def test_unknown_verb_is_an_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fly"])
    assert exc.value.code == 2
