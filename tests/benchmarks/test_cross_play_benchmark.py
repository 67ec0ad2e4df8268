"""The cross-play benchmark (benchmarks/cross_play.py): every pair of a root's
configurations at every seed both finished, once, in a file the report reads."""

from __future__ import annotations

from pathlib import Path

import pytest
from configs import train_tiny

from benchmarks import cross_play as benchmark
from rlhc.evaluation.cross_play import cross_play


def rows(seed: int, returns: dict[tuple[str, str], tuple[float, float]]) -> list[dict[str, str]]:
    """A file's rows of configurations ``a`` and ``b`` at ``seed``: ``(predator, prey)
    plays -> (predator, prey) returns``."""
    return [
        {
            "seed": str(seed), "first": "a", "second": "b", "episodes": "10",
            "predator_plays": plays[0], "prey_plays": plays[1],
            "predator_return": str(predator), "prey_return": str(prey),
        }
        for plays, (predator, prey) in returns.items()
    ]  # fmt: skip


def test_a_groups_advantage_is_over_the_same_opponents() -> None:
    # a's predators catch 2 more than b's against either's prey; a's prey lose 1 less.
    seed_0 = {
        ("a", "a"): (5.0, -3.0),
        ("a", "b"): (7.0, -4.0),
        ("b", "a"): (3.0, -2.0),
        ("b", "b"): (5.0, -3.0),
    }
    seed_1 = {plays: (predator + 1.0, prey) for plays, (predator, prey) in seed_0.items()}
    values = benchmark.advantages([*rows(0, seed_0), *rows(1, seed_1)])
    assert [(v.seed, v.group, v.value) for v in values] == [
        (0, "predator", 2.0),
        (0, "prey", 1.0),
        (1, "predator", 2.0),
        (1, "prey", 1.0),
    ]
    assert benchmark.summarise(values)[0] == "predator: a over b by +2.00 [+2.00, +2.00] (2 seeds)"
    assert benchmark.summarise(values[:2])[0] == "predator: a over b by +2.00 (1 seed, no interval)"


def test_each_pair_and_seed_is_played_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "study"
    train_tiny(root / "ppo" / "seed_0", "critic=ppo", "seed=0")
    train_tiny(root / "twin" / "seed_0", "critic=twin", "seed=0")
    train_tiny(root / "twin" / "seed_1", "critic=twin", "seed=1")  # no ppo seed 1: unpaired
    assert benchmark.configs_of(root) == ["ppo", "twin"]
    path = benchmark.play(root, ["ppo", "twin"], episodes=2)
    written = benchmark.read_rows(path)
    assert len(written) == 4 and {row["seed"] for row in written} == {"0"}
    assert {(row["blue_plays"], row["red_plays"]) for row in written} == {
        ("ppo", "ppo"), ("ppo", "twin"), ("twin", "ppo"), ("twin", "twin"),
    }  # fmt: skip
    direct = cross_play([str(root / "ppo" / "seed_0"), str(root / "twin" / "seed_0")], 2, seed=0)
    for value in benchmark.advantages(written):
        assert value.value == pytest.approx(direct.group_advantage(value.group, 0, 1))
    monkeypatch.setattr("rlhc.evaluation.cross_play.cross_play", pytest.fail)
    benchmark.play(root, ["twin", "ppo"], episodes=2)  # nothing left to play
    assert benchmark.read_rows(path) == written


def test_bad_arguments_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    train_tiny(tmp_path / "ppo" / "seed_0", "critic=ppo")
    for argv, message in [
        ([str(tmp_path / "none")], "is not a directory"),
        ([str(tmp_path), "--configs", "ppo", "twin"], "--configs ['twin']: no finished run"),
        ([str(tmp_path)], "cross-play needs two; finished: ['ppo']"),
    ]:
        with pytest.raises(SystemExit) as exit_:
            benchmark.parse_args(argv)
        assert exit_.value.code == 2
        assert message in capsys.readouterr().err
