"""A mistake on the command line gets a one-line message naming the subcommand and, where a
name is mistyped, the nearest right one (controllers, scenarios, options, gaits, subcommands)."""

from __future__ import annotations

import pytest

from mjchar.cli import main


@pytest.mark.parametrize(("argv", "says"), [
    (["run", "simbicom"], "mjchar run: error: argument CONTROLLER: invalid choice: 'simbicom'"),
    (["run", "simbicom"], "(did you mean simbicon?)"),
    (["run", "simbicon", "--scenario", "walks"], "(did you mean walk?)"),
    (["run", "simbicon", "walks"], "unexpected argument 'walks' (did you mean --scenario walk?)"),
    (["run", "simbicon", "--sped", "1.2"],
     "mjchar run: error: unrecognized arguments: --sped 1.2 (did you mean --speed"),
    (["run", "simbicon", "--gait", "naturel"],
     "mjchar run: error: unknown gait 'naturel' (did you mean natural?)"),
    (["gait", "simbicon", "--sped", "1.2"], "mjchar gait: error: unrecognized arguments: --sped"),
    (["rn", "simbicon"], "mjchar: error: argument COMMAND: invalid choice: 'rn'"),
    (["rn", "simbicon"], "(did you mean run?)"),
])
def test_a_mistake_gets_one_line_with_the_subcommand_and_a_suggestion(argv, says, capsys):
    with pytest.raises(SystemExit) as e:
        assert main(argv) == 2  # a project error returns 2; argparse's exits 2
        raise SystemExit(2)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert says in err
    assert err.count("\n") == 1, err


def test_no_suggestion_when_nothing_is_near(capsys):
    with pytest.raises(SystemExit):
        main(["run", "zzzzzz"])
    assert "did you mean" not in capsys.readouterr().err
