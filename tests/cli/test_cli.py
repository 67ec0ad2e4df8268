"""``python -m rlhc.run`` as a user meets it: progress without a terminal, one-line errors."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from cli_runs import only_child, run_in_process, run_subprocess

from rlhc.building.builders import ConfigError
from rlhc.cli.report import one_line

SMOKE = ["env=tennis", "experiment=smoke"]
#: A progress line: frames of the budget, speeds, the latest reward, the time left.
PROGRESS = re.compile(
    r"frames [\d,]+/640 \(\d+%\) \| [\d,]+ frames/s \(env [\d,]+ steps/s\)"
    r"( \| racket reward [+-]\d\.\d{3} \| hits_over_net \d+\.\d\d/episode)?"
    r" \| elapsed \d+:\d\d:\d\d, left ~\d+:\d\d:\d\d$"
)


# --- progress ------------------------------------------------------------------------
def test_without_a_terminal_progress_lines_go_to_stdout_and_run_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # 64-frame updates: each of the ten crosses a tenth of the 640-frame budget.
    outcome = run_in_process(
        [*SMOKE, "algo.max_steps=640", "hydra.run.dir=run"], tmp_path, monkeypatch, capsys
    )
    assert outcome.code == 0, outcome.stderr
    printed = [line for line in outcome.stdout.splitlines() if "frames/s" in line]
    assert len(printed) == 10
    assert all(PROGRESS.search(line) for line in printed), printed
    assert "frames 640/640 (100%)" in printed[-1] and "racket reward" in printed[-1]
    assert outcome.stdout.splitlines()[-1].endswith("results in run")
    assert "%|" not in outcome.stderr  # no bar
    logged = (tmp_path / "run" / "run.log").read_text().splitlines()
    assert [line for line in logged if "frames/s" in line] == printed
    assert logged[-1].endswith("results in run")


def test_a_requested_bar_stays_and_the_log_still_gets_the_lines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    outcome = run_in_process(
        [*SMOKE, "algo.max_steps=128", "logger.progress=true", "hydra.run.dir=run"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert outcome.code == 0, outcome.stderr
    assert "128/128" in outcome.stderr and "frames/s" in outcome.stderr  # tqdm's bar
    logged = (tmp_path / "run" / "run.log").read_text()
    assert logged.count("frames/s") == 2


# --- user errors ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("algo.lrr=0.1", "Could not override 'algo.lrr'"),  # Hydra: unknown key
        ("env=foo", "Could not find 'env/foo'"),  # Hydra: unknown group option
        ("seed=abc", "Value 'abc' of type 'str' could not be converted to Integer"),
        ("seed=[", "no viable alternative at input '['"),  # override grammar
        ("critic.weight=2", "critic.weight=2.0; allowed: a number in [0, 1]"),  # ConfigError
        ("env.num_envs=3", "env.num_envs=3 does not divide"),  # ConfigError (Layout)
        ("logger.backends=[csv,foo]", "logger.backends has ['foo']"),
        ("resume=nowhere", "resume='nowhere': checkpoint 'nowhere' does not exist"),
        ("resume=.", "resume='.': no checkpoint in run directory '.'"),
    ],
)
def test_a_user_error_is_one_line_exit_2_and_leaves_no_directory(
    override: str,
    expected: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    outcome = run_in_process([*SMOKE, override], tmp_path, monkeypatch, capsys)
    assert outcome.code == 2
    (line,) = outcome.stderr.splitlines()
    assert line.startswith("rlhc.run: error: ") and expected in line, line
    assert outcome.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_hydra_full_error_shows_the_traceback_instead(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("HYDRA_FULL_ERROR", "1")
    with pytest.raises(ConfigError, match=r"critic\.weight"):
        run_in_process([*SMOKE, "critic.weight=2"], tmp_path, monkeypatch, capsys)


def test_one_line_joins_causes_and_lists_and_drops_diagnostics() -> None:
    cause = RuntimeError(
        "Key 'lrr' not in 'PPOConfig'\n    full_key: algo.lrr\n    object_type=PPOConfig"
    )
    error = ValueError("Could not override 'algo.lrr'.\nTo append use +algo.lrr=1")
    error.__cause__ = cause
    assert one_line(error) == (
        "Could not override 'algo.lrr'. To append use +algo.lrr=1 Key 'lrr' not in 'PPOConfig'"
    )
    options = ValueError("Could not find 'env/foo'\n\nAvailable options:\n\tsoccer\n\ttennis\n"
                         "Config search path:\n\tprovider=hydra")  # fmt: skip
    assert one_line(options) == "Could not find 'env/foo' Available options: soccer, tennis"


@pytest.mark.slow  # a subprocess: ~9 s, 18 s in a busy suite
def test_a_multirun_of_bad_values_exits_2_and_leaves_no_directory(tmp_path: Path) -> None:
    outcome = run_subprocess(["-m", *SMOKE, "critic.weight=2,3"], cwd=tmp_path)
    assert outcome.code == 2, outcome.stderr
    assert outcome.stderr.splitlines()[-1] == (
        "rlhc.run: error: critic.weight=2.0; allowed: a number in [0, 1]"
    )
    assert "Traceback" not in outcome.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_multirun_job_directory_passes_back_unquoted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep = ["-m", *SMOKE, "algo.max_steps=64", "critic=ppo,hierarchical", "env.extended_obs=true"]
    outcome = run_in_process(sweep, tmp_path, monkeypatch, capsys)
    assert outcome.code == 0, outcome.stderr
    jobs = sorted(only_child(tmp_path / "multirun").glob("*_*"))
    assert [job.name for job in jobs] == [
        "0_algo.max_steps-64_critic-ppo_env.extended_obs-True_env-tennis_experiment-smoke",
        "1_algo.max_steps-64_critic-hierarchical_env.extended_obs-True_env-tennis_experiment-smoke",
    ]
    job = jobs[0].relative_to(tmp_path)
    resumed = run_in_process(
        [*SMOKE, "algo.max_steps=128", "critic=ppo", "env.extended_obs=true", f"resume={job}"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert resumed.code == 0, resumed.stderr
    assert resumed.stdout.splitlines()[-1].endswith(f"results in {job}")
    assert not (tmp_path / "outputs").exists()
