"""``python -m benchmarks.report``: plan, summaries, finals, thresholds, tests, verdicts."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import report as report_cli
from benchmarks.reporting.blocks import HAND_WRITTEN, block, blocks_of, body_lines
from benchmarks.reporting.document import build_report, command_line
from benchmarks.reporting.formatting import fmt, fmt_interval, fmt_reach, table
from benchmarks.reporting.head_to_head import Record, match_verdict, pooled, record_of
from benchmarks.reporting.markdown import runs_section
from benchmarks.reporting.plan import STUDIES, PlannedRun, Study, plan
from benchmarks.reporting.runs import complete_runs, discover
from benchmarks.reporting.statistics import (
    Comparison,
    config_finals,
    fill_reach,
    initial_value,
    smoothed_final,
    steps_to_reach,
    threshold,
)
from benchmarks.reporting.summary import (
    RunSummary,
    read_summary,
    summarise,
    write_summary,
)
from rlhc.evaluation.matches import MatchResult
from rlhc.evaluation.stats import t_interval, wilson_interval
from rlhc.runs import ema_smooth

TOY = Study("toy", {"ppo": ("env=tennis", "critic=ppo"), "hierarchical": ("env=tennis",)}, 3, 100)
STUDY = {"toy": TOY}


def write_run(root: Path, config: str, seed: int, rewards: list[float]) -> Path:
    """A synthetic run: metrics.csv (steps 10, 20, …), its Hydra records and train.log,
    and the summary.json that ``reproduce`` writes after training."""
    run = root / "toy" / config / f"seed_{seed}"
    (run / ".hydra").mkdir(parents=True)
    fusion = "local" if config == "ppo" else "max"
    (run / ".hydra" / "config.yaml").write_text(
        f"env:\n  name: tennis\ncritic:\n  fusion: {fusion}\nseed: {seed}\n"
    )
    overrides = [*TOY.configs[config], f"seed={seed}"]
    (run / ".hydra" / "overrides.yaml").write_text("".join(f"- {o}\n" for o in overrides))
    (run / "train.log").write_text("code version: abc123\n")
    with (run / "metrics.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(
            [
                "step",
                "racket/cumulative_reward",
                "racket/entropy",
                "episode_length",
                "wall_time",
                "iteration",
            ]
        )
        for i, reward in enumerate(rewards):
            writer.writerow([10 * (i + 1), reward, 1.0 - 0.01 * i, 20 + i, 5.0 * (i + 1), i + 1])
    planned = PlannedRun("toy", config, seed, TOY.configs[config], TOY.max_steps)
    write_summary(run, summarise(planned, run))
    return run


@pytest.fixture
def results(tmp_path: Path) -> Path:
    ramp = [0.1 * i for i in range(10)]
    write_run(tmp_path, "ppo", 0, ramp)
    write_run(tmp_path, "ppo", 1, [v + 0.05 for v in ramp])
    write_run(tmp_path, "hierarchical", 0, [2 * v for v in ramp])
    write_run(tmp_path, "hierarchical", 1, [2 * v + 0.1 for v in ramp])
    write_run(tmp_path, "hierarchical", 2, ramp[:3])  # stopped at 30 frames of 100
    (tmp_path / "toy" / "ppo" / "seed_2").mkdir()  # started, no summary yet
    return tmp_path


def test_plan_is_seed_major_and_names_unknown_studies() -> None:
    runs = plan(["tennis_extensions"], seeds=2)
    assert [(r.seed, r.config) for r in runs[:4]] == [
        (0, "manager"),
        (0, "mean"),
        (0, "hierarchical_k5"),
        (1, "manager"),
    ]
    assert len(plan(list(STUDIES))) == sum(s.planned for s in STUDIES.values()) == 39
    assert STUDIES["soccer"].env == "soccer" and STUDIES["tennis_extensions"].env == "tennis"
    with pytest.raises(KeyError, match="unknown studies"):
        plan(["nonesuch"])
    with pytest.raises(ValueError, match="share one env= override"):
        _ = Study("mixed", {"a": ("env=tennis",), "b": ("env=soccer",)}, 1, 10).env


def test_summary_from_files_records_frames_budget_and_provenance(tmp_path: Path) -> None:
    run = write_run(tmp_path, "ppo", 0, [0.0] * 10)
    summary = read_summary(run)
    assert summary is not None
    assert (summary.frames, summary.max_steps, summary.completed) == (100, 100, True)
    assert (summary.updates, summary.wall_time_s) == (10, 50.0)
    assert summary.overrides == ("env=tennis", "critic=ppo", "seed=0")
    assert summary.code_versions == ("abc123",)
    assert summary.frames_from == "metrics.csv (last step)"  # no checkpoint kept
    assert json.loads((run / "summary.json").read_text())["completed"] is True
    # What is not recorded is null, and the notes say why.
    (run / "train.log").write_text("a warning\n")
    (run / ".hydra" / "overrides.yaml").unlink()
    bare = summarise(PlannedRun("toy", "ppo", 0, (), 200), run)
    assert (bare.code_versions, bare.overrides, bare.completed) == (None, None, False)
    assert any("no code version" in note for note in bare.notes)
    empty = tmp_path / "empty"
    empty.mkdir()
    nothing = summarise(PlannedRun("toy", "ppo", 0, (), 200), empty)
    assert (nothing.frames, nothing.updates, nothing.wall_time_s) == (None, None, None)


def test_summary_round_trips_and_refuses_bad_files(tmp_path: Path) -> None:
    summary = RunSummary("toy", "ppo", 0, 100, 120, "x", 3, 1.5, ("a",), None, True, ("n",))
    assert RunSummary.from_json(summary.to_json()) == summary
    with pytest.raises(ValueError, match="expected the keys"):
        RunSummary.from_json('{"study": "toy"}', "bad.json")
    with pytest.raises(ValueError, match="completed=True but frames=50"):
        RunSummary("toy", "ppo", 0, 100, 50, "x", 3, 1.5, None, None, True)
    run = tmp_path / "toy" / "ppo" / "seed_0"
    run.mkdir(parents=True)
    write_summary(run, RunSummary("toy", "ppo", 1, 100, 120, "x", 3, 1.5, None, None, True))
    with pytest.raises(ValueError, match="the plan expects"):
        discover(tmp_path, STUDY)


def test_discover_reads_completeness_from_summaries(results: Path) -> None:
    runs = discover(results, STUDY)
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
    run = discover(results, STUDY)[0].curves()
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
    runs = discover(results, STUDY)
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
    runs = discover(tmp_path, STUDY)
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
    runs = discover(results, STUDY)
    STUDIES["toy"] = TOY
    try:
        text = "\n".join(runs_section(runs, ["toy"]))
    finally:
        del STUDIES["toy"]
    assert "2 of 3" in text
    assert "seed 2 (no summary yet)" in text and "seed 2 (30 frames)" in text
    assert "50 [50, 50]" in text  # wall_time of the last row, identical for both seeds
    assert "Total training wall time of the 4 complete runs: 200 s" in text


def test_cli_draws_figures_next_to_out_and_names_the_default_command(tmp_path: Path) -> None:
    default = report_cli.parse_args([])
    assert default.images == report_cli.ROOT / "docs" / "images"
    elsewhere = report_cli.parse_args(["--out", str(tmp_path / "r.md"), "--matches", "0"])
    assert elsewhere.images == tmp_path / "images"  # never docs/images
    given = report_cli.parse_args(["--out", str(tmp_path / "r.md"), "--images", "figs"])
    assert given.images == Path("figs")
    assert command_line(default) == "python -m benchmarks.report --matches 100"
    assert command_line(report_cli.parse_args(["--matches", "0", "--study", "tennis"])) == (
        "python -m benchmarks.report --matches 0 --study tennis"
    )


def test_blocks_parse_back() -> None:
    text = "\n".join(
        ["# t", *block("a", ["x", "", "y"]), *block("b", []), *block("c", ["z"], HAND_WRITTEN)]
    )
    assert blocks_of(text) == {"a": "x\n\ny\n", "b": ""}
    assert blocks_of(text, HAND_WRITTEN) == {"c": "z\n"}
    assert body_lines(blocks_of(text)["a"]) == ["x", "", "y"] and body_lines("") == []
    with pytest.raises(ValueError, match="occurs twice"):
        blocks_of(text + "\n" + "\n".join(block("a", [])))


def test_rebuild_keeps_interpretation_and_matches_only_for_unchanged_runs(
    results: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(STUDIES, "toy", TOY)
    out = tmp_path / "doc" / "RESULTS.md"
    argv = ["--results", str(results), "--out", str(out), "--study", "toy", "--matches", "0"]
    args = report_cli.parse_args([*argv, "--no-figures"])
    first = build_report(args)
    assert "*(to be written)*" in first and "Not played (`--matches 0`)." in first
    assert "2 of 3" in first and "**partial** — 4 of 6 planned runs complete" in first
    # The lead writes the interpretation; matches played elsewhere are in the document.
    edited = first.replace("*(to be written)*", "Read by hand.").replace(
        "Not played (`--matches 0`).", "| played | 100 |"
    )
    again = build_report(args, edited)
    assert "Read by hand." in again and "| played | 100 |" in again
    assert "kept unchanged" in blocks_of(again)["footer"]
    # A run finishing changes the runs: the old matches no longer describe them.
    write_run(results, "ppo", 2, [0.1 * i for i in range(10)])
    changed = build_report(args, edited)
    assert "Read by hand." in changed and "| played | 100 |" not in changed
    assert "**partial** — 5 of 6" in changed
