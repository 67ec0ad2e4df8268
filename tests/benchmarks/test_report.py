"""``python -m benchmarks.report``: plan, summaries, finals, thresholds, tests, verdicts."""

from __future__ import annotations

import csv
import json
import math
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from benchmarks import report as report_cli
from benchmarks.reporting import document
from benchmarks.reporting.blocks import HAND_WRITTEN, block, blocks_of, body_lines
from benchmarks.reporting.document import build_report, command_line
from benchmarks.reporting.formatting import (
    fmt,
    fmt_interval,
    fmt_reach,
    positive_interval,
    share_interval,
    table,
)
from benchmarks.reporting.markdown import finals_section, runs_section
from benchmarks.reporting.plan import PlannedRun, Study, plan, read_study, studies
from benchmarks.reporting.runs import StudyRun, complete_runs, discover
from benchmarks.reporting.standings import BUILT_IN as BUILT_INS
from benchmarks.reporting.standings import STORE, study_matches
from benchmarks.reporting.statistics import (
    Comparison,
    config_finals,
    corrected,
    fill_reach,
    initial_value,
    smoothed_final,
    steps_to_reach,
    threshold,
)
from benchmarks.reporting.study import PLAY_METRIC, PlayMetric, comparisons_of, table_configs
from benchmarks.reporting.summary import (
    RunSummary,
    read_summary,
    summarise,
    write_summary,
)
from benchmarks.reporting.tournament import Series
from rlhc.analysis.curves import ema_smooth
from rlhc.evaluation.stats import t_interval


def toy_study(root: Path) -> Study:
    """A tennis study of two critics, 3 seeds of 100 frames, its runs under ``root``."""
    return Study("toy", "A toy study.", "tennis", ("hierarchical", "ppo"), (0, 1, 2), 100, root)


def write_run(root: Path, config: str, seed: int, rewards: list[float], study: str = "toy") -> Path:
    """A synthetic run: metrics.csv (steps 10, 20, …), its Hydra records and train.log,
    and the summary.json that ``reproduce`` writes after training."""
    run = root / config / f"seed_{seed}"
    (run / ".hydra").mkdir(parents=True)
    fusion = "local" if config == "ppo" else "max"
    (run / ".hydra" / "config.yaml").write_text(
        f"env:\n  name: tennis\ncritic:\n  fusion: {fusion}\nseed: {seed}\n"
    )
    overrides = [f"study={study}", f"critic={config}", f"seed={seed}"]
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
                "events/hits_over_net_per_episode",
                "env_steps_per_s",
                "wall_time",
                "iteration",
            ]
        )
        for i, reward in enumerate(rewards):
            row = [
                10 * (i + 1),
                reward,
                1.0 - 0.01 * i,
                20 + i,
                reward,
                100.0,
                5.0 * (i + 1),
                i + 1,
            ]
            writer.writerow(row)
    planned = PlannedRun(study, config, seed, 100, root)
    write_summary(run, summarise(planned, run))
    return run


def matches_with(played: list[Series], study: Study, runs: list[StudyRun]) -> tuple[str, list[str]]:
    """The study's match section (as one text) and verdicts, its store holding ``played``."""
    store = {"format": 2, "env": study.env, "series": [x.__dict__ for x in played]}
    (study.root / STORE).write_text(json.dumps(store))
    lines, verdicts = study_matches(study, runs)
    return "\n".join(lines), verdicts


@pytest.fixture
def results(tmp_path: Path) -> Path:
    ramp = [0.1 * i for i in range(10)]
    write_run(tmp_path, "ppo", 0, ramp)
    write_run(tmp_path, "ppo", 1, [v + 0.05 for v in ramp])
    write_run(tmp_path, "hierarchical", 0, [2 * v for v in ramp])
    write_run(tmp_path, "hierarchical", 1, [2 * v + 0.1 for v in ramp])
    write_run(tmp_path, "hierarchical", 2, ramp[:3])  # stopped at 30 frames of 100
    (tmp_path / "ppo" / "seed_2").mkdir()  # started, no summary yet
    return tmp_path


@pytest.fixture
def toy(results: Path) -> dict[str, Study]:
    return {"toy": toy_study(results)}


def test_plan_reads_the_study_configs_and_is_seed_major() -> None:
    known = studies()
    assert list(known) == [
        "tennis_paper", "tennis_extended", "soccer_paper", "tennis_extensions", "soccer_best",
        "tennis_best", "vmas_navigation", "vmas_balance", "pettingzoo_simple_spread",
        "pettingzoo_simple_tag",
    ]  # fmt: skip
    assert known["soccer_paper"].configs == ("ppo", "hierarchical", "twin")
    assert (known["soccer_paper"].env, known["soccer_paper"].max_steps) == ("soccer", 500_000)
    assert (known["tennis_paper"].env, known["tennis_paper"].max_steps) == ("tennis", 3_600_000)
    assert known["soccer_best"].max_steps == 1_000_000  # the study's own budget
    assert (known["tennis_best"].env, known["tennis_best"].max_steps) == ("tennis", 5_000_000)
    assert known["tennis_extended"].configs == ("ppo", "hierarchical")
    assert all(s.seeds == (0, 1, 2, 3, 4) for n, s in known.items() if n != "tennis_extensions")
    assert (
        known["soccer_paper"].root == report_cli.ROOT / "benchmarks/results/learning/soccer/paper"
    )
    assert known["soccer_paper"].command == "python -m rlhc.run -m study=soccer_paper"
    runs = plan(["tennis_extensions"], seeds=2)
    assert [(r.seed, r.config) for r in runs[:4]] == [
        (0, "manager"),
        (0, "mean"),
        (0, "hierarchical_k5"),
        (1, "manager"),
    ]
    assert runs[0].overrides == ("study=tennis_extensions", "critic=manager", "seed=0")
    assert runs[0].run_dir == known["tennis_extensions"].root / "manager" / "seed_0"
    assert len(plan(list(known))) == sum(s.planned for s in known.values()) == 139
    assert known["tennis_extensions"].seeds == (0, 1, 2)  # the compute plan's 3 seeds
    with pytest.raises(KeyError, match="unknown studies"):
        plan(["nonesuch"])


def test_a_study_config_must_sweep_critics_and_seeds(tmp_path: Path) -> None:
    bad = tmp_path / "soccer_paper.yaml"  # a real study's name: it composes
    bad.write_text("hydra:\n  sweep:\n    dir: x\n  sweeper:\n    params:\n      seed: range(2)\n")
    with pytest.raises(ValueError, match="must sweep 'critic'"):
        read_study(bad)
    bad.write_text("hydra:\n  sweeper:\n    params:\n      seed: range(2)\n")
    with pytest.raises(ValueError, match=r"must set hydra\.sweep\.dir"):
        read_study(bad)


def test_compared_pairs() -> None:
    known = studies()
    assert comparisons_of(known["soccer_paper"]) == [
        ("soccer_paper/hierarchical", "soccer_paper/twin"),
        ("soccer_paper/hierarchical", "soccer_paper/ppo"),
        ("soccer_paper/twin", "soccer_paper/ppo"),
    ]
    assert comparisons_of(known["tennis_extended"]) == [
        ("tennis_extended/hierarchical", "tennis_extended/ppo")
    ]
    extensions = known["tennis_extensions"]
    assert ("tennis_extensions/mean", "tennis_paper/ppo") in comparisons_of(extensions)
    assert table_configs(extensions)[-2:] == ["tennis_paper/hierarchical", "tennis_paper/ppo"]


def test_summary_from_files_records_frames_budget_and_provenance(tmp_path: Path) -> None:
    run = write_run(tmp_path, "ppo", 0, [0.0] * 10)
    summary = read_summary(run)
    assert summary is not None
    assert (summary.frames, summary.max_steps, summary.completed) == (100, 100, True)
    assert (summary.updates, summary.wall_time_s) == (10, 50.0)
    assert summary.overrides == ("study=toy", "critic=ppo", "seed=0")
    assert summary.code_versions == ("abc123",)
    assert summary.frames_from == "metrics.csv (last step)"  # no checkpoint kept
    assert json.loads((run / "summary.json").read_text())["completed"] is True
    # What is not recorded is null, and the notes say why.
    (run / "train.log").write_text("a warning\n")
    (run / ".hydra" / "overrides.yaml").unlink()
    bare = summarise(PlannedRun("toy", "ppo", 0, 200, tmp_path), run)
    assert (bare.code_versions, bare.overrides, bare.completed) == (None, None, False)
    assert any("no code version" in note for note in bare.notes)
    empty = tmp_path / "empty"
    empty.mkdir()
    nothing = summarise(PlannedRun("toy", "ppo", 0, 200, tmp_path), empty)
    assert (nothing.frames, nothing.updates, nothing.wall_time_s) == (None, None, None)
    (empty / "metrics.csv").write_text("step\n")  # a run that has just started
    started = summarise(PlannedRun("toy", "ppo", 0, 200, tmp_path), empty)
    assert (started.frames, started.completed) == (None, False)
    assert any("nothing trained yet" in note for note in started.notes)


def test_summary_round_trips_and_refuses_bad_files(tmp_path: Path) -> None:
    summary = RunSummary("toy", "ppo", 0, 100, 120, "x", 3, 1.5, ("a",), None, True, ("n",))
    assert RunSummary.from_json(summary.to_json()) == summary
    with pytest.raises(ValueError, match="expected the keys"):
        RunSummary.from_json('{"study": "toy"}', "bad.json")
    with pytest.raises(ValueError, match="completed=True but frames=50"):
        RunSummary("toy", "ppo", 0, 100, 50, "x", 3, 1.5, None, None, True)
    run = tmp_path / "ppo" / "seed_0"
    run.mkdir(parents=True)
    write_summary(run, RunSummary("toy", "ppo", 1, 100, 120, "x", 3, 1.5, None, None, True))
    with pytest.raises(ValueError, match="the plan expects"):
        discover({"toy": toy_study(tmp_path)})


def test_discover_reads_completeness_from_summaries(toy: dict[str, Study]) -> None:
    runs = discover(toy)
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


def test_smoothed_final_is_the_last_tenth_of_the_ema_curve(toy: dict[str, Study]) -> None:
    run = next(r for r in discover(toy) if r.name == "toy/ppo").curves()
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


def test_finals_table_threshold_and_reach(toy: dict[str, Study]) -> None:
    runs = discover(toy)
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


def test_the_play_metric_interval_is_clipped_to_where_the_metric_lives(
    toy: dict[str, Study], monkeypatch: pytest.MonkeyPatch
) -> None:
    assert [PLAY_METRIC[game].share for game in ("tennis", "soccer")] == [False, True]
    runs = discover(toy)

    def final_cell(share: bool) -> list[float]:
        column, title, _ = PLAY_METRIC["tennis"]
        monkeypatch.setitem(document.PLAY_METRIC, "tennis", PlayMetric(column, title, share))
        lines = document.play_and_speed(toy["toy"], runs, 0.5)
        row = next(line for line in lines if line.startswith("| `toy/hierarchical`"))
        interval = row.split(" | ")[1].partition("[")[2].rstrip("]")
        return [float(x) for x in interval.split(", ")]

    # two seeds ending near 1.7 hits per point: the t interval reaches above 1
    low, high = final_cell(share=False)
    assert 0.0 < low < 1.0 < high
    assert final_cell(share=True) == [low, 1.0]  # a share (the goal rate) stays in [0, 1]


def test_no_threshold_when_nothing_improves(tmp_path: Path) -> None:
    write_run(tmp_path, "ppo", 0, [1.0, 0.5, 0.0] * 3 + [0.0])
    runs = discover({"toy": toy_study(tmp_path)})
    tables = [config_finals("toy/ppo", runs, "racket")]
    assert fill_reach(tables, runs, "racket", 0.5) is None
    assert tables[0].reach == [None]


def test_a_finals_table_without_a_testable_pair_says_so(tmp_path: Path) -> None:
    for config in ("ppo", "hierarchical"):
        write_run(tmp_path, config, 0, [0.1 * i for i in range(10)])
    study = toy_study(tmp_path)
    lines, comparisons = finals_section(study, discover({"toy": study}), 0.5)
    assert comparisons and not any(c.testable for c in comparisons)
    text = "\n".join(lines)
    assert "No test yet: each needs 2 complete seeds per side." in text
    assert "Holm's p corrects" not in text


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


def test_comparisons_are_decided_on_holm_over_their_family() -> None:
    # p = 2.6e-4 and p ~ 0.04 alone; over a family of three, Holm keeps the first (x 3)
    # and not the second (x 2 = 0.08), and names the correction in both sentences.
    strong = Comparison("a", "b", "racket", (1.0, 1.1, 0.9), (0.0, 0.1, -0.1))
    weak = Comparison("a", "c", "racket", (1.0, 1.2, 1.4, 1.1), (0.9, 0.8, 1.0, 0.7))
    null = Comparison("b", "c", "racket", (0.0, 1.0), (0.1, 0.9))
    untestable = Comparison("c", "d", "racket", (0.5,), (0.1, 0.2))
    assert weak.test()[1] < 0.05 and "higher than" in weak.verdict()
    family = corrected([strong, weak, null, untestable])
    assert [c.family for c in family[:3]] == [3, 3, 3] and family[3] is untestable
    assert family[0].family_p == pytest.approx(3 * strong.test()[1])
    assert "higher than `b`'s" in family[0].verdict() and "over 3 tests" in family[0].verdict()
    sentence = family[1].verdict()
    assert (
        "not significantly different" in sentence
        and "`c`'s after Holm's correction (Welch" in sentence
    )
    assert f"detectable at power 0.8: {fmt(weak.detectable())}" in sentence
    assert untestable.detectable() is None


def test_formatting() -> None:
    ci = t_interval([1.0, 2.0, 3.0])
    assert fmt_interval(ci, 2, fixed=True) == "2.00 [-0.48, 4.48]"
    assert "no interval" in fmt_interval(t_interval([1.0]))
    assert fmt(math.nan) == "—" and fmt(None) == "—"
    assert fmt_reach([10.0, None, 30.0]) == "20 [0, 147] (2/3 seeds)"  # t: [-107, 147]
    assert positive_interval([1.0, 2.0, 3.0]).low == 0.0
    assert positive_interval([10.0, 11.0, 12.0]) == t_interval([10.0, 11.0, 12.0])
    assert fmt_reach([None, None]) == "— (0/2 seeds)"
    clipped = share_interval([0.0, 0.05, 0.3])
    assert (clipped.low, clipped.high) == (0.0, pytest.approx(t_interval([0.0, 0.05, 0.3]).high))
    assert share_interval([0.9, 1.0, 0.2]).high == 1.0
    assert table(["a", "b"], [["1", "2"]]) == ["| a | b |", "|---|---|", "| 1 | 2 |"]


def test_runs_section_lists_unfinished_runs_and_wall_time(toy: dict[str, Study]) -> None:
    text = "\n".join(runs_section(discover(toy), toy))
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
    assert command_line(default) == "python -m benchmarks.report --matches 20"
    assert command_line(report_cli.parse_args(["--matches", "0", "--study", "soccer_paper"])) == (
        "python -m benchmarks.report --matches 0 --study soccer_paper"
    )
    for bad in (["--matches", "3"], ["--matches", "-2"], ["--threshold-fraction", "0"]):
        with pytest.raises(SystemExit):
            report_cli.parse_args(bad)


def test_blocks_parse_back() -> None:
    text = "\n".join(
        ["# t", *block("a", ["x", "", "y"]), *block("b", []), *block("c", ["z"], HAND_WRITTEN)]
    )
    assert blocks_of(text) == {"a": "x\n\ny\n", "b": ""}
    assert blocks_of(text, HAND_WRITTEN) == {"c": "z\n"}
    assert body_lines(blocks_of(text)["a"]) == ["x", "", "y"] and body_lines("") == []
    with pytest.raises(ValueError, match="occurs twice"):
        blocks_of(text + "\n" + "\n".join(block("a", [])))


def test_rebuild_keeps_the_interpretation_and_counts_runs(
    toy: dict[str, Study], results: Path, tmp_path: Path
) -> None:
    out = tmp_path / "doc" / "RESULTS.md"
    args = report_cli.parse_args(["--out", str(out), "--matches", "0", "--no-figures"])
    first = build_report(args, plan=toy)
    assert "*(to be written)*" in first and "No series played yet." in first
    assert "2 of 3" in first and "**partial** — 4 of 6 planned runs complete" in first
    assert "`toy/hierarchical` vs `toy/ppo`" in blocks_of(first)["study toy"]
    edited = first.replace("*(to be written)*", "Read by hand.")
    write_run(results, "ppo", 2, [0.1 * i for i in range(10)])
    again = build_report(args, edited, plan=toy)
    assert "Read by hand." in again and "**partial** — 5 of 6" in again


def test_matches_section_reads_the_store(toy: dict[str, Study], results: Path) -> None:
    runs = discover(toy)

    def series(home: str, away: str, wins: int, draws: int, losses: int) -> Series:
        return Series(home, away, "v", "v", 10, 0, wins, draws, losses, "c", wins, losses)

    teams = ["hierarchical/seed_0", "hierarchical/seed_1", "ppo/seed_0", "ppo/seed_1"]
    played = [series(t, "scripted", 1, 1, 8) for t in teams]
    played += [series(t, "random", 9, 1, 0) for t in teams]
    played += [series("scripted", "random", 10, 0, 0)]
    played += [series(h, p, 7, 0, 3) for h in teams[:2] for p in teams[2:]]
    played += [series(teams[0], teams[1], 5, 0, 5), series(teams[2], teams[3], 5, 0, 5)]
    text, verdicts = matches_with(played, toy["toy"], runs)
    assert "15 series, 150 matches (10 per pairing" in text
    row = next(line for line in text.splitlines() if line.startswith("| `hierarchical` vs `ppo` |"))
    # 0.700 [low, high] | half-width | detectable = half-width x (1.960 + 0.842) / 1.960
    score, half, edge = (cell.strip() for cell in row.strip("|").split("|")[2:])
    low, high = (float(x) for x in score.split("[")[1].rstrip("]").split(","))
    assert score.startswith("0.700 [") and float(half) == pytest.approx((high - low) / 2, abs=1e-3)
    assert float(edge) == pytest.approx(float(half) * 2.8015 / 1.95996, abs=2e-3)
    assert "| `hierarchical` (rows) vs `ppo` | `seed_0` | `seed_1` |" in text
    assert "| `seed_0` | 0.700 | 0.700 |" in text
    assert "| `hierarchical` | 0.150 [0.150, 0.150] | 0.15, 0.15 | 0.111 [0.111, 0.111] |" in text
    assert verdicts == [
        next(v for v in verdicts if v.startswith("toy: `hierarchical` vs `ppo` head-to-head"))
    ]
    # One seed a side: the interval cannot include seed spread, so no verdict is drawn.
    lines, verdicts = study_matches(toy["toy"], [r for r in runs if r.seed == 0])
    assert verdicts == [] and "one seed on a side: no seed spread" in "\n".join(lines)


def test_teams_without_weights_keep_their_series_and_miss_only_new_pairings(
    toy: dict[str, Study], results: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from benchmarks.reporting import standings
    from rlhc.storage.final_team import save_team

    runs = discover(toy)
    teams = ["hierarchical/seed_0", "hierarchical/seed_1", "ppo/seed_0", "ppo/seed_1"]
    # hierarchical/seed_1 and ppo/seed_1 were trained later: they never met seed_0 of the
    # other critic, whose weights are gone (no final team, no checkpoint).
    for team in teams[1::2]:
        state = {"env": "tennis", "config": {}, "frames": 100, "actors": {}, "env_transform": {}}
        save_team(results / team, state)
    played = [Series(h, p, "v", "v", 10, 0, 7, 0, 3, "c", 7, 3) for h, p in
              [(teams[0], teams[2]), (teams[1], teams[3]), (teams[1], teams[2])]]  # fmt: skip
    played += [Series(t, o, "v", "v", 10, 0, 5, 0, 5, "c") for t in teams for o in BUILT_INS]
    text = matches_with(played, toy["toy"], runs)[0]
    assert "| `hierarchical` vs `ppo` | 2 x 2 (3 of 4 pairs played) | 0.700 [" in text
    # Rows hierarchical seed_0, seed_1; columns ppo seed_0, seed_1.
    assert "| `seed_0` | 0.700 | — |" in text and "| `seed_1` | 0.700 | 0.700 |" in text
    assert "Teams whose weights are lost" in text
    assert "meet no team trained after them: `hierarchical/seed_0`, `ppo/seed_0`." in text
    # Only the teams with weights on disk enter the next round robin.
    entered: list[list[str]] = []
    monkeypatch.setattr(
        standings, "play_round_robin", lambda env, e, *rest: entered.append([x.name for x in e])
    )
    standings.play(toy["toy"], runs, 2, 0)
    assert entered == [["hierarchical/seed_1", "ppo/seed_1", *BUILT_INS]]


def test_a_borrowing_study_meets_the_lenders_teams_that_kept_their_weights(
    toy: dict[str, Study],
    results: Path,
    tmp_path_factory: pytest.TempPathFactory,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from benchmarks.reporting import standings, study
    from rlhc.storage.final_team import save_team

    # "toy" borrows ppo from "lender": lender's ppo seed 0 kept its weights, seed 1 did not.
    lender_root = tmp_path_factory.mktemp("lender")
    lender = Study("lender", "Lends.", "tennis", ("ppo",), (0, 1), 100, lender_root)
    for seed in (0, 1):
        write_run(lender_root, "ppo", seed, [0.1 * i for i in range(10)], study="lender")
    state = {"env": "tennis", "config": {}, "frames": 100, "actors": {}, "env_transform": {}}
    save_team(lender_root / "ppo" / "seed_0", state)
    for seed in (0, 1):
        save_team(results / "hierarchical" / f"seed_{seed}", state)
    monkeypatch.setitem(study.BORROWED, "toy", ("lender/ppo",))
    runs = discover({**toy, "lender": lender})
    assert [e.name for e in standings.guests(toy["toy"], runs)] == ["lender/ppo/seed_0"]

    entered: list[tuple[list[str], object]] = []
    monkeypatch.setattr(standings, "play_round_robin",
                        lambda env, e, m, s, store, involving: entered.append(
                            ([x.name for x in e], involving)))  # fmt: skip
    standings.play(toy["toy"], runs, 2, 0)
    ((names, involving),) = entered
    assert "lender/ppo/seed_0" in names and "lender/ppo/seed_1" not in names
    assert involving == {"hierarchical/seed_0", "hierarchical/seed_1"}  # with weights

    guest = "lender/ppo/seed_0"
    played = [Series(h, guest, "v", "v", 10, 0, 6, 0, 4, "c") for h in
              ["hierarchical/seed_0", "hierarchical/seed_1"]]  # fmt: skip
    played += [Series(t, "random", "v", "v", 10, 0, 9, 0, 1, "c") for t in names if "/" in t]
    text, verdicts = matches_with(played, toy["toy"], runs)
    assert "| `hierarchical` vs `lender/ppo` | 2 x 1 | 0.600 [" in text
    assert "| `hierarchical` (rows) vs `lender/ppo` | `seed_0` |" in text
    assert "whose weights are lost could not come: `lender/ppo/seed_1`." in text
    assert "| `ppo` vs `lender/ppo` | 2 x 1 | no pair played |" in text  # own ppo: lost
    assert "no verdict" in text and verdicts == []  # one guest seed: no seed spread


def test_reproduce_trains_each_run_through_its_study_config(tmp_path: Path) -> None:
    from benchmarks import reproduce

    run = plan(["soccer_paper"], seeds=1)[2]
    assert reproduce.command(run)[1:] == [
        "-m", "rlhc.run", "study=soccer_paper", "critic=twin", "seed=0",
    ]  # fmt: skip
    args = reproduce.parse_args(["--study", "soccer_paper", "--seeds", "2", "--jobs", "1"])
    assert (args.study, args.seeds, args.jobs) == (["soccer_paper"], 2, 1)
    for bad in (["--seeds", "0"], ["--jobs", "0"], ["--study", "nonesuch"]):
        with pytest.raises(SystemExit):
            reproduce.parse_args(bad)
    # --summaries-only: a summary for every run that has a directory, none for the others.
    toy = [PlannedRun("toy", "ppo", seed, 100, tmp_path) for seed in (0, 1)]
    write_run(tmp_path, "ppo", 0, [0.0] * 10)
    (toy[0].run_dir / "summary.json").unlink()
    assert reproduce.write_summaries(toy) == 1
    assert read_summary(toy[0].run_dir) is not None and not toy[1].run_dir.exists()
    assert not (toy[0].run_dir / "final_team.pt").exists()  # no checkpoint to take it from


def test_reproduce_starts_only_runs_that_fit_in_hours(
    toy: dict[str, Study], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from benchmarks import reproduce

    # Measured: 0.5 s per frame (test_plan_section_...). hierarchical/seed_2 has 70 of
    # 100 frames left (35 s), ppo/seed_2 no summary: all 100 (50 s).
    runs = discover(toy)
    planned = [r.planned for r in runs if not r.complete]
    monkeypatch.setattr(reproduce, "studies", lambda: toy)
    expected = reproduce.expected_seconds(planned)
    assert [expected[p] for p in planned] == [35.0, 50.0]
    deadline = reproduce.Deadline(40.0, time.monotonic(), expected)
    assert deadline.refusal(planned[0]) is None
    assert "needs ~1 min at its study's measured rate, 1 min left" in str(
        deadline.refusal(planned[1])
    )
    unknown = PlannedRun("toy", "ppo", 9, 100, toy["toy"].root)
    assert "no measured rate" in str(deadline.refusal(unknown))
    # A refused run is not started: no process, no directory, no summary.
    monkeypatch.setattr(reproduce.subprocess, "call", lambda *a, **k: pytest.fail("started"))
    assert reproduce.execute(planned[1], deadline) == (planned[1], None, 0.0)
    assert "ppo/seed_2: not started" in capsys.readouterr().out
    assert not (planned[1].run_dir / "summary.json").exists()
    assert reproduce.parse_args(["--hours", "2.5"]).hours == 2.5
    with pytest.raises(SystemExit):
        reproduce.parse_args(["--hours", "0"])


def test_reproduce_keeps_the_final_team_of_a_complete_run(tmp_path: Path) -> None:
    from benchmarks import reproduce
    from rlhc.storage.checkpoint import save_checkpoint
    from rlhc.storage.final_team import TEAM_FILE, load_team

    state = {"env": "tennis", "config": {}, "actors": {}, "env_transform": {}, "optimizer": {}}
    done, partial = (PlannedRun("toy", "ppo", seed, 100, tmp_path) for seed in (0, 1))
    write_run(tmp_path, "ppo", 0, [0.0] * 10)
    write_run(tmp_path, "ppo", 1, [0.0] * 5)
    save_checkpoint(done.run_dir / "checkpoints" / "step_000000100.pt", {**state, "frames": 100})
    save_checkpoint(partial.run_dir / "checkpoints" / "step_000000050.pt", {**state, "frames": 50})
    assert reproduce.write_summaries([done, partial]) == 2
    team = load_team(done.run_dir)
    assert Path(team["path"]).name == TEAM_FILE and "optimizer" not in team
    assert not (partial.run_dir / TEAM_FILE).exists()  # unfinished: no final team yet
    # On a clone without checkpoints, a complete run's summary (frames read from its
    # checkpoint) is kept, not replaced by one that can only read metrics.csv.
    kept = (done.run_dir / "summary.json").read_text()
    assert json.loads(kept)["frames_from"] == "checkpoints/latest.pt"
    shutil.rmtree(done.run_dir / "checkpoints")
    assert reproduce.write_summaries([done, partial]) == 1
    assert (done.run_dir / "summary.json").read_text() == kept


def test_plan_section_costs_each_study_from_its_measured_rate(toy: dict[str, Study]) -> None:
    from benchmarks.reporting.document import plan_section
    from benchmarks.reporting.runs import seconds_per_frame

    # 4 complete runs of 100 frames in 50 s each: 0.5 s per frame, 50 s per run.
    # Left: hierarchical seed 2 (70 frames) and ppo seed 2 (100) = 170 frames = 85 s.
    assert seconds_per_frame(discover(toy)) == 0.5
    text = "\n".join(plan_section(toy, discover(toy)))
    assert "| 4 of 6 | 0.01 | 0.1 | 0.0 |" in text
    assert "In all: 0.1 core-hours planned, 0.0 left" in text


def test_a_probability_of_improvement_on_too_few_runs_gets_no_verdict(
    toy: dict[str, Study], monkeypatch: pytest.MonkeyPatch
) -> None:
    from benchmarks.reporting import aggregates

    monkeypatch.setattr(aggregates, "TASK_GROUPS", {"the toy budget": ("toy",)})
    runs = discover(toy)
    # Both RLHC seeds outscore both PPO seeds against the built-in teams: P = 1, and every
    # resample agrees, yet 2 runs against 2 separate completely by chance with p = 1/3.
    wins = {"hierarchical": 8, "ppo": 2}
    played = [Series(f"{c}/seed_{s}", o, "v", "v", 10, 0, w, 0, 10 - w, "c")
              for c, w in wins.items() for s in (0, 1) for o in BUILT_INS]  # fmt: skip
    matches_with(played, toy["toy"], runs)
    lines, verdicts = aggregates.aggregates_section(toy, runs)
    text = "\n".join(lines)
    assert "| P(`hierarchical` > `ppo`) | `toy` | 1.000 [1.000, 1.000] (too few runs" in text
    assert "p = 0.33 > 0.05" in text and verdicts == []
    # The same runs at a level they can reach get their verdict.
    monkeypatch.setattr(aggregates, "ALPHA", 0.5)
    verdicts = aggregates.aggregates_section(toy, runs)[1]
    assert verdicts == [
        "The toy budget (`toy`): a run of `hierarchical` is more likely than not to outscore "
        "a run of `ppo` (P = 1.000, 95% CI [1.000, 1.000])."
    ]
