"""``benchmarks/report.py``: run discovery, smoothed finals, thresholds, tests, verdicts."""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from rlhc.evaluation.matches import MatchResult
from rlhc.evaluation.stats import t_interval, wilson_interval
from rlhc.plotting import ema_smooth

# ``reporting`` and the ``reproduce`` script it reads the plan from live in benchmarks/.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import report as report_cli
from reporting.document import command_line
from reporting.formatting import fmt, fmt_interval, fmt_reach, table
from reporting.head_to_head import Record, match_verdict, pooled, record_of
from reporting.markdown import runs_section
from reporting.runs import complete_runs, discover
from reporting.statistics import (
    Comparison,
    config_finals,
    fill_reach,
    initial_value,
    smoothed_final,
    steps_to_reach,
    threshold,
)
from reporting.study import STUDIES

STUDY = {"toy": ({"ppo": ("env=tennis", "critic=ppo"), "hierarchical": ("env=tennis",)}, 3, 100)}


def write_run(root: Path, config: str, seed: int, rewards: list[float]) -> Path:
    """A synthetic run: metrics.csv (steps 10, 20, …) and a Hydra config record."""
    run = root / "toy" / config / f"seed_{seed}"
    (run / ".hydra").mkdir(parents=True)
    fusion = "local" if config == "ppo" else "max"
    (run / ".hydra" / "config.yaml").write_text(
        f"env:\n  name: tennis\ncritic:\n  fusion: {fusion}\nseed: {seed}\n"
    )
    with (run / "metrics.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(
            ["step", "racket/cumulative_reward", "racket/entropy", "episode_length", "wall_time"]
        )
        for i, reward in enumerate(rewards):
            writer.writerow([10 * (i + 1), reward, 1.0 - 0.01 * i, 20 + i, 5.0 * (i + 1)])
    return run


@pytest.fixture
def results(tmp_path: Path) -> Path:
    ramp = [0.1 * i for i in range(10)]
    write_run(tmp_path, "ppo", 0, ramp)
    write_run(tmp_path, "ppo", 1, [v + 0.05 for v in ramp])
    write_run(tmp_path, "hierarchical", 0, [2 * v for v in ramp])
    write_run(tmp_path, "hierarchical", 1, [2 * v + 0.1 for v in ramp])
    write_run(tmp_path, "hierarchical", 2, ramp[:3])  # still training
    (tmp_path / "toy" / "ppo" / "seed_2").mkdir()  # started, nothing written yet
    return tmp_path


def fake_frames(path: Path) -> int | None:
    """Frames by the synthetic run's last logged step (100 = complete), None if empty."""
    metrics = path / "metrics.csv"
    if not metrics.exists():
        return None
    return int(metrics.read_text().strip().splitlines()[-1].split(",")[0])


def test_discover_marks_complete_and_unfinished_runs(results: Path) -> None:
    runs = discover(results, STUDY, fake_frames)
    status = {(r.config, r.seed): (r.complete, r.frames) for r in runs}
    assert status == {
        ("ppo", 0): (True, 100),
        ("ppo", 1): (True, 100),
        ("ppo", 2): (False, None),
        ("hierarchical", 0): (True, 100),
        ("hierarchical", 1): (True, 100),
        ("hierarchical", 2): (False, 30),
    }
    assert [r.seed for r in complete_runs(runs, "toy/hierarchical")] == [0, 1]


def test_smoothed_final_is_the_last_tenth_of_the_ema_curve(results: Path) -> None:
    run = discover(results, STUDY, fake_frames)[0].curves()
    curve = ema_smooth(np.array([0.1 * i for i in range(10)]), 0.8)
    # steps 10..100: the last 10% is step >= 90, i.e. the last two points.
    expected = curve[-2:].mean()
    assert smoothed_final(run, "racket/cumulative_reward") == pytest.approx(expected)
    assert smoothed_final(run, "not/logged") is None
    assert initial_value(run, "racket/cumulative_reward") == 0.0


def test_threshold_and_steps_to_reach() -> None:
    assert threshold(0.0, 2.0, 0.5) == 1.0
    assert threshold(-1.0, 1.0, 0.25) == -0.5
    steps = np.array([10.0, 20.0, 30.0])
    assert steps_to_reach(steps, np.array([0.0, 0.6, 0.4]), 0.5) == 20.0
    assert steps_to_reach(steps, np.array([0.0, 0.1, 0.2]), 0.5) is None


def test_finals_table_threshold_and_reach(results: Path) -> None:
    runs = discover(results, STUDY, fake_frames)
    tables = [
        config_finals(name, complete_runs(runs, name), "racket")
        for name in ("toy/hierarchical", "toy/ppo")
    ]
    assert [t.seeds for t in tables] == [[0, 1], [0, 1]]
    level = fill_reach(tables, runs, "racket", 0.5)
    initial = np.mean([0.0, 0.05, 0.0, 0.1])
    assert level == pytest.approx(initial + 0.5 * (np.mean(tables[0].reward) - initial))
    for finals in tables:
        for seed, reach in zip(finals.seeds, finals.reach, strict=True):
            run = next(r for r in runs if r.name == finals.name and r.seed == seed)
            curve = ema_smooth(run.curves().columns["racket/cumulative_reward"], 0.8)
            first = int(np.flatnonzero(curve >= level)[0]) if (curve >= level).any() else None
            assert reach == (None if first is None else 10.0 * (first + 1))
    assert tables[0].reach[0] is not None  # the steeper config gets there


def test_no_threshold_when_nothing_improves(tmp_path: Path) -> None:
    write_run(tmp_path, "ppo", 0, [1.0, 0.5, 0.0] * 3 + [0.0])
    runs = discover(tmp_path, {"toy": ({"ppo": ()}, 1, 100)}, fake_frames)
    tables = [config_finals("toy/ppo", runs, "racket")]
    assert fill_reach(tables, runs, "racket", 0.5) is None
    assert tables[0].reach == [None]


def test_comparison_uses_per_seed_values_and_words_the_result() -> None:
    higher = Comparison("a", "b", "racket", (1.0, 1.1, 0.9), (0.0, 0.1, -0.1))
    # Means 1 and 0, sample variances 0.01 each, n = 3: t = 1 / sqrt(2 * 0.01 / 3) = sqrt(150),
    # Welch df = 4; the two-sided p of t = 12.247 with 4 df is 2.552e-4.
    t, p = higher.test()
    assert t == pytest.approx(150**0.5)
    assert p == pytest.approx(2.5521674944e-4, rel=1e-6)
    assert (
        "`a`'s racket final cumulative reward is higher than `b`'s" in higher.verdict()
        and f"p = {p:.3g}" in higher.verdict()
    )
    lower = Comparison("a", "b", "racket", (0.0, 0.1, -0.1), (1.0, 1.1, 0.9))
    assert "is lower than `b`'s" in lower.verdict()
    same = Comparison("a", "b", "racket", (0.0, 1.0), (0.1, 0.9))
    assert "not significantly different" in same.verdict()
    single = Comparison("a", "b", "racket", (0.5,), (0.1, 0.2))
    assert single.test() is None and "not testable yet" in single.verdict()


def test_records_pool_and_rate_with_wilson() -> None:
    result = MatchResult(
        "home",
        "away",
        home_side=np.array([0, 1, 0, 1]),
        home_points=np.array([5, 5, 2, 1]),
        away_points=np.array([3, 0, 2, 5]),
        steps=np.array([90, 80, 300, 70]),
    )
    record = record_of(result.summary())  # outcomes +1, +1, 0, -1
    assert record == Record(2, 1, 1) and record.score == pytest.approx(0.625)
    total = pooled([record, Record(1, 0, 3)])
    assert total == Record(3, 1, 4) and total.matches == 8
    low, high = wilson_interval(3, 8)
    assert total.rate(3) == f"{3 / 8:.1%} [{low:.1%}, {high:.1%}]"
    assert Record(0, 0, 0).rate(0) == "—"
    assert "scores higher" in match_verdict("x", Record(90, 0, 10))
    assert "scores lower" in match_verdict("x", Record(10, 0, 90))
    assert "not distinguishable" in match_verdict("x", Record(5, 1, 4))
    assert "no matches" in match_verdict("x", Record(0, 0, 0))


def test_formatting() -> None:
    ci = t_interval([1.0, 2.0, 3.0])
    assert fmt_interval(ci, 2, fixed=True) == "2.00 [-0.48, 4.48]"
    assert "no interval" in fmt_interval(t_interval([1.0]))
    assert fmt(math.nan) == "—" and fmt(None) == "—"
    assert fmt_reach([10.0, None, 30.0]) == "20 (2/3 seeds)"
    assert table(["a", "b"], [["1", "2"]]) == ["| a | b |", "|---|---|", "| 1 | 2 |"]


def test_runs_section_lists_unfinished_runs_and_wall_time(results: Path) -> None:
    runs = discover(results, STUDY, fake_frames)
    STUDIES["toy"] = STUDY["toy"]
    try:
        text = "\n".join(runs_section(runs, ["toy"]))
    finally:
        del STUDIES["toy"]
    assert "2 of 3" in text
    assert "seed 2 (no checkpoint yet)" in text and "seed 2 (30 frames)" in text
    assert "50 [50, 50]" in text  # wall_time of the last row, identical for both seeds
    assert "Total training wall time of the 4 complete runs: 200 s" in text


def test_cli_draws_figures_next_to_out_and_names_the_default_command(tmp_path: Path) -> None:
    default = report_cli.parse_args([])
    assert default.images == report_cli.ROOT / "docs" / "images"
    elsewhere = report_cli.parse_args(["--out", str(tmp_path / "r.md"), "--matches", "0"])
    assert elsewhere.images == tmp_path / "images"  # never docs/images
    given = report_cli.parse_args(["--out", str(tmp_path / "r.md"), "--images", "figs"])
    assert given.images == Path("figs")
    assert command_line(default) == "python benchmarks/report.py --matches 100"
    assert command_line(report_cli.parse_args(["--matches", "0", "--study", "tennis"])) == (
        "python benchmarks/report.py --matches 0 --study tennis"
    )
