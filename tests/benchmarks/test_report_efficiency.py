"""The report's sample-efficiency section: curves at shares of the budget, the mean over
training (area under the curve over its span), Welch's test of that mean."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from test_report import toy_study, write_run

from benchmarks.reporting.efficiency import (
    SCORE,
    SELF_PLAY,
    efficiency_section,
    mean_over_training,
    measures,
    value_at,
)
from benchmarks.reporting.runs import discover
from rlhc.analysis.curves import Run, ema_smooth

RAMP = [0.1 * i for i in range(10)]  # logged at steps 10, 20, ..., 100


def test_the_mean_over_training_is_the_trapezoid_area_over_the_span() -> None:
    steps = np.array([10.0, 20.0, 40.0, 100.0])
    values = np.array([0.0, 1.0, np.nan, 4.0])  # a row that did not log it is skipped
    run = Run(Path("r"), {"step": steps, "hits": values})
    # (0 + 1) / 2 * 10 + (1 + 4) / 2 * 80, over 90 steps
    assert mean_over_training(run, "hits") == pytest.approx((5.0 + 200.0) / 90.0)
    assert mean_over_training(run, "missing") is None
    single = Run(Path("r"), {"step": np.array([5.0]), "hits": np.array([2.0])})
    assert mean_over_training(single, "hits") == 2.0


def test_the_curve_is_read_at_the_last_row_before_the_mark() -> None:
    run = Run(Path("r"), {"step": 10.0 * np.arange(1, 11), "hits": np.array(RAMP)})
    smoothed = ema_smooth(np.array(RAMP), 0.8)
    assert value_at(run, "hits", 25.0) == pytest.approx(smoothed[1])  # the row at step 20
    assert value_at(run, "hits", 100.0) == pytest.approx(smoothed[-1])
    assert value_at(run, "hits", 5.0) is None  # nothing logged yet


def test_the_critic_that_learns_faster_has_the_larger_mean_and_the_verdict_says_so(
    tmp_path: Path,
) -> None:
    # Equal finals, but hierarchical gets there at a fifth of the budget and stays.
    fast = [min(0.9, 0.45 * i) for i in range(10)]
    for seed, offset in enumerate((0.0, 0.05)):
        write_run(tmp_path, "ppo", seed, [v + offset for v in RAMP])
        write_run(tmp_path, "hierarchical", seed, [v + offset for v in fast])
    study = toy_study(tmp_path)
    lines, verdicts = efficiency_section(study, discover({"toy": study}))
    rows = {line.split(" | ")[0]: line.split(" | ") for line in lines if line.startswith("| `")}
    area = {name: float(row[-1].split()[0]) for name, row in rows.items()}
    assert area["| `toy/hierarchical`"] > area["| `toy/ppo`"]
    assert area["| `toy/ppo`"] == pytest.approx(np.mean([0.45, 0.5]), abs=1e-3)
    assert len(verdicts) == 1
    assert verdicts[0].startswith(
        "`toy/hierarchical`'s team mean hits over the net per point over training is higher "
        "than `toy/ppo`'s"
    )


def test_the_match_score_is_read_only_where_matches_were_logged(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path, "ppo", 0, RAMP)
    write_run(tmp_path, "hierarchical", 0, RAMP)
    study = toy_study(tmp_path)
    assert [m.column for m in measures(study, discover({"toy": study}))] == [
        "events/hits_over_net_per_episode"
    ]
    # Periodic matches on the second row and the last: score = wins + draws / 2.
    path = run_dir / "metrics.csv"
    rows = list(csv.DictReader(path.open()))
    for row in rows:
        row["eval/win_rate"], row["eval/draw_rate"] = "", ""
    rows[1]["eval/win_rate"], rows[1]["eval/draw_rate"] = "0.25", "0.5"
    rows[-1]["eval/win_rate"], rows[-1]["eval/draw_rate"] = "0.75", "0.0"
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    runs = discover({"toy": study})
    assert [m.column for m in measures(study, runs)][-1] == SCORE
    lines, _ = efficiency_section(study, runs)
    score_table = lines[lines.index("*score against the scripted team*") :]
    ppo = next(line for line in score_table if line.startswith("| `toy/ppo`"))
    # rows at steps 20 (0.5) and 100 (0.75): area (0.5 + 0.75) / 2 over 80 steps
    assert ppo.split(" | ")[-1].startswith("0.625")
    hierarchical = next(line for line in score_table if line.startswith("| `toy/hierarchical`"))
    assert hierarchical.split(" | ")[-1] == "— |"


def test_tennis_play_with_itself_is_a_measure_where_it_was_measured(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path, "ppo", 0, RAMP)
    study = toy_study(tmp_path)  # a tennis study
    path = run_dir / "metrics.csv"
    rows = list(csv.DictReader(path.open()))
    for step, row in enumerate(rows):
        row[SELF_PLAY] = "" if step % 2 else str(2.0 * step)  # measured on every other row
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    runs = discover({"toy": study})
    assert [m.column for m in measures(study, runs)] == [
        "events/hits_over_net_per_episode",
        SELF_PLAY,
    ]
    lines, _ = efficiency_section(study, runs)
    table_lines = lines[lines.index("*hits over the net per point with itself (play/)*") :]
    ppo = next(line for line in table_lines if line.startswith("| `toy/ppo`"))
    # measured at steps 10, 30, ..., 90: 0, 4, ..., 16, a straight line: its mean is 8
    assert ppo.split(" | ")[-1].startswith("8")
