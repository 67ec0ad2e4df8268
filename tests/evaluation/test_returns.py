"""``python -m rlhc.evaluation.returns``: trained teams on another library's env, their
returns, their contests and a video, on the tiny PettingZoo env."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from configs import train_tiny
from PIL import Image

from rlhc.envs import make_env
from rlhc.envs.generic import render_frame, rendering_options
from rlhc.errors import EnvError
from rlhc.evaluation.cross_play import cross_play
from rlhc.evaluation.returns import record_episode
from rlhc.evaluation.returns.__main__ import main

TINY = {"factory": "tests.envs.tiny_envs:tiny", "kwargs": {}}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str]:
    root = tmp_path_factory.mktemp("runs")
    first = train_tiny(root / "ppo", "critic=ppo", "seed=0")
    second = train_tiny(root / "hierarchical", "critic=hierarchical", "seed=1")
    return str(first), str(second)


def test_one_run_plays_its_own_episodes(
    runs: tuple[str, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "returns.json"
    assert main([runs[0], "--episodes", "4", "--worlds", "2", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["groups"] == ["blue", "red"] and report["advantages"] == []
    (lineup,) = report["lineups"]
    assert lineup["plays"] == {"blue": runs[0], "red": runs[0]}
    # The same numbers as the library call: 4 episodes over 2 worlds, 2 each.
    own = cross_play(runs[:1], episodes=4, num_envs=2)
    for group in ("blue", "red"):
        assert lineup["returns"][group]["episodes"] == 4
        assert lineup["returns"][group]["mean"] == pytest.approx(own.mean((0, 0), group))
        low, high = lineup["returns"][group]["low"], lineup["returns"][group]["high"]
        assert low <= lineup["returns"][group]["mean"] <= high
    printed = capsys.readouterr().out
    assert printed.splitlines()[:3] == [
        f"[1] {runs[0]}",
        "4 episodes per lineup, mode actions, seed 0; returns: mean [95% t]",
        f"blue [1], red [1]: blue {report_line(lineup, 'blue')}, red {report_line(lineup, 'red')}",
    ]


def test_two_runs_play_every_lineup_and_each_groups_advantage(
    runs: tuple[str, str], tmp_path: Path
) -> None:
    out = tmp_path / "returns.json"
    main([*runs, "--episodes", "2", "--worlds", "2", "--out", str(out)])
    report = json.loads(out.read_text())
    assert len(report["lineups"]) == 4
    result = cross_play(runs, episodes=2, num_envs=2)
    assert [(a["group"], a["first"], a["second"]) for a in report["advantages"]] == [
        ("blue", runs[0], runs[1]),
        ("red", runs[0], runs[1]),
    ]
    for advantage in report["advantages"]:
        expected = result.group_advantage(advantage["group"], 0, 1)
        assert advantage["advantage"] == pytest.approx(expected)


def test_a_video_shows_one_episode_from_the_envs_own_renderer(
    runs: tuple[str, str], tmp_path: Path
) -> None:
    # The tiny env's episodes last 8 steps: the reset's frame and one per step.
    path, frames = record_episode(runs[0], tmp_path / "episode.gif")
    assert frames == 9
    with Image.open(path) as gif:
        assert gif.n_frames > 1 and gif.size == (8, 8)
    _, cut = record_episode(runs[0], tmp_path / "cut.gif", max_frames=3)
    assert cut == 3
    with pytest.raises(ValueError, match=r"video '.*episode.avi'; allowed: a file ending in"):
        record_episode(runs[0], tmp_path / "episode.avi")
    with pytest.raises(ValueError, match="max_frames=1; allowed: >= 2"):
        record_episode(runs[0], tmp_path / "episode.gif", max_frames=1)


def test_an_env_that_draws_nothing_is_refused_in_one_line() -> None:
    env = make_env("pettingzoo", num_envs=1, seed=0, **TINY)  # no render_mode
    env.reset()
    with pytest.raises(EnvError, match=r"env=pettingzoo: the environment drew nothing"):
        render_frame(env, "pettingzoo")
    drawn = make_env("pettingzoo", num_envs=1, seed=0, **rendering_options("pettingzoo", TINY))
    drawn.reset()
    assert render_frame(drawn, "pettingzoo").shape == (8, 8, 3)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["{tmp}/missing"], "no final_team.pt in"),
        (["{run}", "--episodes", "0"], "--episodes 0; allowed: >= 1"),
        (["{run}", "{run}"], "given twice; allowed: each run once"),
        (["{run}", "--video", "{tmp}/v.avi"], "v.avi'; allowed: a file ending in .gif, .mp4"),
        (["{run}", "--video", "{tmp}/v.gif", "--max-frames", "1"], "--max-frames 1; allowed"),
    ],
)
def test_bad_input_exits_2_in_one_line(
    runs: tuple[str, str],
    argv: list[str],
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as stop:
        main([a.format(run=runs[0], tmp=tmp_path) for a in argv])
    assert stop.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("python -m rlhc.evaluation.returns: error: ") and message in line


def report_line(lineup: dict, group: str) -> str:
    ci = lineup["returns"][group]
    return f"{ci['mean']:.4g} [{ci['low']:.4g}, {ci['high']:.4g}]"
