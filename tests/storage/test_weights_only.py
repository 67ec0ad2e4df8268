"""Loading a team or a checkpoint never runs code: a file that needs more than tensors,
numbers, strings and containers is refused in one line, before anything in it runs."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
import torch
from cli_runs import ROOT, run_in_process
from configs import load_smoke

from rlhc import evaluate, run
from rlhc.envs import SOURCES
from rlhc.evaluation.matches import make_match_env
from rlhc.evaluation.opponents import make_team_policy
from rlhc.storage.checkpoint import FORMAT_VERSION, load_checkpoint
from rlhc.storage.final_team import load_team
from rlhc.training.trainer import Trainer

#: The final teams the repository keeps (benchmarks/results): they must load and play.
COMMITTED_TEAMS = subprocess.run(
    ["git", "ls-files", "*.pt"], cwd=ROOT, capture_output=True, text=True, check=False
).stdout.split()


class Payload:
    """What a shared file could carry: unpickling it makes the directory ``marker``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str]]:
        return os.mkdir, (str(self.marker),)


#: The name torch's loader gives the payload's callable.
PAYLOAD_GLOBAL = f"{os.mkdir.__module__}.{os.mkdir.__name__}"


def payload_file(path: Path, marker: Path) -> Path:
    """A team file of the right format whose actors would make ``marker`` when loaded."""
    torch.save(
        {
            "format_version": FORMAT_VERSION,
            "env": "tennis",
            "config": {},
            "frames": 0,
            "actors": Payload(marker),
            "env_transform": {},
        },
        path,
    )
    return path


def the_error(stderr: str, program: str) -> str:
    (line,) = stderr.splitlines()
    assert line.startswith(f"{program}: error: "), line
    return line


@pytest.mark.parametrize("team", COMMITTED_TEAMS)
def test_every_committed_final_team_loads_and_plays(team: str) -> None:
    path = str(ROOT / team)
    saved = load_team(path)  # weights_only
    if saved["env"] in SOURCES:  # another library's env has no matches: its weights load
        weights = [w for actor in saved["actors"].values() for w in actor.values()]
        assert weights and all(torch.isfinite(w).all() for w in weights)
        return
    env = make_match_env(saved["env"], num_envs=1, seed=0, players=[path])
    try:
        actions = make_team_policy(path, env)(env.reset())
    finally:
        env.close()
    assert all(torch.isfinite(a).all() for a in actions.values())


def test_a_league_checkpoint_of_today_loads(tmp_path: Path) -> None:
    # Its random states and the league's opponents are numpy arrays (allow-listed).
    cfg = load_smoke("env=soccer", "league=mixed", "algo.max_steps=256", "logger.backends=[csv]")
    Trainer(cfg, tmp_path).train()
    state = load_checkpoint(tmp_path)
    assert state["frames"] == 256 and state["league"] is not None


def test_a_payload_is_refused_unrun(tmp_path: Path) -> None:
    marker = tmp_path / "marker"
    file = payload_file(tmp_path / "shared.pt", marker)
    with pytest.raises(ValueError, match=f"'{file}' .* carries {PAYLOAD_GLOBAL}"):
        load_team(file)
    assert not marker.exists()


def test_a_shared_team_carrying_a_payload_is_one_line_and_runs_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    marker = tmp_path / "marker"
    payload_file(tmp_path / "shared.pt", marker)
    outcome = run_in_process(
        ["env=tennis", "home=shared.pt", "away=random", "matches=2", "hydra.run.dir=eval"],
        tmp_path,
        monkeypatch,
        capsys,
        evaluate.cli,
    )
    assert outcome.code == 2, outcome.stderr
    line = the_error(outcome.stderr, "rlhc.evaluate")
    assert str(tmp_path / "shared.pt") in line and PAYLOAD_GLOBAL in line, line
    assert not marker.exists()
    assert not (tmp_path / "eval").exists()


def test_a_resume_from_a_payload_is_one_line_and_runs_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    marker = tmp_path / "marker"
    payload_file(tmp_path / "shared.pt", marker)
    outcome = run_in_process(
        ["env=tennis", "experiment=smoke", "resume=shared.pt", "hydra.run.dir=run"],
        tmp_path,
        monkeypatch,
        capsys,
        run.cli,
    )
    assert outcome.code == 2, outcome.stderr
    line = the_error(outcome.stderr, "rlhc.run")
    assert str(tmp_path / "shared.pt") in line and PAYLOAD_GLOBAL in line, line
    assert not marker.exists()
    assert not (tmp_path / "run").exists()
