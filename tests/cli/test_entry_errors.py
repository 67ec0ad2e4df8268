"""``python -m rlhc.evaluate`` and ``python -m rlhc.plot`` as a user meets them: a mistake
is one line ``<program>: error: …``, exit code 2, no traceback (``HYDRA_FULL_ERROR=1``
shows it), nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_runs import Outcome, run_in_process, run_subprocess
from configs import load_smoke

from rlhc import evaluate, plot
from rlhc.errors import ConfigError
from rlhc.storage.final_team import TEAM_FILE
from rlhc.training.trainer import Trainer

NOT_A_PLAYER = (
    "is neither a built-in team (random, scripted) nor an existing checkpoint file or run directory"
)


@pytest.fixture(scope="module")
def tennis_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished one-update tennis run: its ``final_team.pt`` is what plays."""
    run_dir = tmp_path_factory.mktemp("tennis_run")
    Trainer(load_smoke("env=tennis", "algo.max_steps=64", "logger.backends=[csv]"), run_dir).train()
    return run_dir


def evaluated(
    args: list[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> Outcome:
    """``python -m rlhc.evaluate <args>`` in this process that fails: it writes nothing."""
    outcome = run_in_process(
        [*args, "matches=2", "hydra.run.dir=eval"], tmp_path, monkeypatch, capsys, evaluate.cli
    )
    assert not (tmp_path / "eval").exists()  # checked before Hydra creates the directory
    return outcome


def the_error(outcome: Outcome, program: str) -> str:
    """The one line a user error printed, checked: exit 2, nothing else, no traceback."""
    assert outcome.code == 2, outcome.stderr
    assert "Traceback" not in outcome.stderr
    (line,) = outcome.stderr.splitlines()
    prefix = f"{program}: error: "
    assert line.startswith(prefix), line
    return line.removeprefix(prefix)


# --- rlhc.evaluate -------------------------------------------------------------------
def test_a_team_of_another_game_is_named_with_both_games(
    tennis_run: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    outcome = evaluated(
        ["env=soccer", f"home={tennis_run}", "away=random"], tmp_path, monkeypatch, capsys
    )
    assert the_error(outcome, "rlhc.evaluate") == (
        f"home='{tennis_run}': checkpoint '{tennis_run}' ({tennis_run / TEAM_FILE}) was "
        "trained on 'tennis', but this evaluation plays 'soccer'"
    )


def test_a_home_path_that_does_not_exist_is_no_player(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    outcome = evaluated(["env=soccer", "home=outputs/nowhere"], tmp_path, monkeypatch, capsys)
    assert the_error(outcome, "rlhc.evaluate") == f"home='outputs/nowhere' {NOT_A_PLAYER}"


def test_an_unknown_player_name_is_no_player(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["mode=elo", "env=soccer", "players=[scripted,randm]"]
    outcome = evaluated(args, tmp_path, monkeypatch, capsys)
    assert the_error(outcome, "rlhc.evaluate") == f"players[1]='randm' {NOT_A_PLAYER}"


def test_a_file_that_is_not_a_checkpoint_is_named_with_the_reason(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "notes.txt").write_text("not a checkpoint\n")
    outcome = evaluated(["env=tennis", "away=notes.txt"], tmp_path, monkeypatch, capsys)
    message = the_error(outcome, "rlhc.evaluate")
    assert message.startswith(
        f"away='notes.txt': '{tmp_path / 'notes.txt'}' is not a loadable rlhc checkpoint: "
    ), message


def test_a_directory_without_a_team_names_both_files_looked_for(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "empty_run").mkdir()
    outcome = evaluated(["env=tennis", "home=empty_run"], tmp_path, monkeypatch, capsys)
    message = the_error(outcome, "rlhc.evaluate")
    assert message.startswith(
        f"home='empty_run': no {TEAM_FILE} in 'empty_run', and no checkpoint in run "
        "directory 'empty_run': looked for checkpoints/latest.pt"
    ), message


def test_a_bad_mode_names_the_allowed_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    outcome = evaluated(["mode=league"], tmp_path, monkeypatch, capsys)
    assert the_error(outcome, "rlhc.evaluate") == "mode='league'; allowed: match, elo, showcase"


def test_a_misspelt_setting_is_hydras_error_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    outcome = evaluated(["matchs=3"], tmp_path, monkeypatch, capsys)
    assert the_error(outcome, "rlhc.evaluate").startswith("Could not override 'matchs'.")


def test_hydra_full_error_shows_the_evaluate_traceback_instead(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("HYDRA_FULL_ERROR", "1")
    with pytest.raises(ConfigError, match="mode='league'"):
        evaluated(["mode=league"], tmp_path, monkeypatch, capsys)


def test_the_evaluate_command_in_a_shell_prints_one_line(tmp_path: Path) -> None:
    outcome = run_subprocess(
        ["env=soccer", "home=scriptd", "hydra.run.dir=eval"], tmp_path, module="rlhc.evaluate"
    )
    assert the_error(outcome, "rlhc.evaluate") == f"home='scriptd' {NOT_A_PLAYER}"
    assert list(tmp_path.iterdir()) == []


# --- rlhc.plot -----------------------------------------------------------------------
def plotted(args: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Outcome:
    """``python -m rlhc.plot <args> --out tmp_path/curves.png`` in this process."""
    capsys.readouterr()
    code = 0
    try:
        plot.cli([*args, "--out", str(tmp_path / "curves.png")])
    except SystemExit as stop:
        code = stop.code if isinstance(stop.code, int) else 1
    captured = capsys.readouterr()
    assert not (tmp_path / "curves.png").exists()
    return Outcome(code, captured.out, captured.err)


def test_a_directory_without_metrics_is_no_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "notes").mkdir()
    outcome = plotted([str(tmp_path / "notes")], tmp_path, capsys)
    assert outcome.code == 2 and "Traceback" not in outcome.stderr
    warning, error = outcome.stderr.splitlines()
    assert warning.startswith("rlhc.plot: warning: skipping 1 path(s) with no metrics.csv")
    assert error == (
        f"rlhc.plot: error: no run directory (one holding metrics.csv) at or under "
        f"{tmp_path / 'notes'}"
    )


def test_a_plot_path_that_does_not_exist_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    outcome = plotted([str(tmp_path / "typo")], tmp_path, capsys)
    assert the_error(outcome, "rlhc.plot") == f"run path '{tmp_path / 'typo'}' does not exist"


def test_an_empty_metrics_file_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "metrics.csv").write_text("")
    outcome = plotted([str(tmp_path / "run")], tmp_path, capsys)
    assert the_error(outcome, "rlhc.plot") == (
        f"'{tmp_path / 'run' / 'metrics.csv'}' has no rows or no 'step' column"
    )


def test_metrics_no_run_logged_are_named(
    tennis_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    outcome = plotted([str(tennis_run), "--metrics", "goals"], tmp_path, capsys)
    assert the_error(outcome, "rlhc.plot") == (
        f"none of the runs logged any of --metrics goals (at or under {tennis_run})"
    )


@pytest.mark.parametrize(
    ("option", "expected"),
    [
        (["--smoothing", "1.5"], "argument --smoothing: 1.5 is not a number in [0, 1)"),
        (["--final-fraction", "0"], "argument --final-fraction: 0 is not a number in (0, 1]"),
        (["--colour", "red"], "unrecognized arguments: --colour red"),
    ],
)
def test_a_bad_plot_option_is_one_line_with_where_to_look(
    option: list[str],
    expected: str,
    tennis_run: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    outcome = plotted([str(tennis_run), *option], tmp_path, capsys)
    assert the_error(outcome, "rlhc.plot") == f"{expected} (usage: python -m rlhc.plot --help)"


def test_hydra_full_error_shows_the_plot_traceback_instead(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("HYDRA_FULL_ERROR", "1")
    with pytest.raises(plot.UsageError, match="does not exist"):
        plotted([str(tmp_path / "typo")], tmp_path, capsys)


def test_the_plot_command_in_a_shell_prints_one_line(tmp_path: Path) -> None:
    outcome = run_subprocess([str(tmp_path / "typo")], tmp_path, module="rlhc.plot")
    assert the_error(outcome, "rlhc.plot") == f"run path '{tmp_path / 'typo'}' does not exist"
