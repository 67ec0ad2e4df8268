"""Studies on other libraries' envs (VMAS, PettingZoo) in the plan and the report: each
group's return compared as in a game, and no play metric, matches or aggregates."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from test_report import toy_study

from benchmarks import report as report_cli
from benchmarks.reporting import document
from benchmarks.reporting.blocks import blocks_of
from benchmarks.reporting.document import build_report
from benchmarks.reporting.formatting import fmt_interval
from benchmarks.reporting.plan import ROOT, TASK_KEYS, PlannedRun, Study, Task, studies
from benchmarks.reporting.runs import complete_runs, discover, study_rate
from benchmarks.reporting.statistics import smoothed_final
from benchmarks.reporting.study import groups_of
from benchmarks.reporting.summary import summarise, write_summary
from rlhc.envs import SOURCES
from rlhc.evaluation.stats import t_interval

CRITICS = ("ppo", "hierarchical", "twin")
TAG = Task("factory", "mpe2.simple_tag_v3:parallel_env", (("num_good", 2),))
RAMP = [0.1 * i for i in range(10)]  # logged at steps 10, 20, ..., 100


def tag_study(root: Path, name: str = "tag", task: Task = TAG) -> Study:
    """A study of the three critics on another library's env, 3 seeds of 100 frames."""
    return Study(name, "A toy on MPE.", "pettingzoo", CRITICS, (0, 1, 2), 100, root, task)


def write_generic_run(root: Path, study: str, config: str, seed: int, agent: list[float]) -> Path:
    """A synthetic run on an env with groups ``adversary`` and ``agent`` (the adversaries'
    return is the agents' negated), with its config and summary."""
    run = root / config / f"seed_{seed}"
    (run / ".hydra").mkdir(parents=True)
    (run / ".hydra" / "config.yaml").write_text(
        f"env:\n  name: pettingzoo\n  factory: {TAG.name}\nseed: {seed}\n"
    )
    with (run / "metrics.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(
            ["step", "adversary/cumulative_reward", "agent/cumulative_reward", "agent/entropy",
             "episode_length", "env_steps_per_s", "wall_time", "iteration"]
        )  # fmt: skip
        for i, reward in enumerate(agent):
            writer.writerow([10 * (i + 1), -reward, reward, 1.0, 25, 100.0, 5.0 * (i + 1), i + 1])
    write_summary(run, summarise(PlannedRun(study, config, seed, 100, root), run))
    return run


@pytest.fixture
def tag(tmp_path: Path) -> dict[str, Study]:
    """hierarchical's agents learn twice as fast as ppo's and twin's; seeds 0.05 apart."""
    root = tmp_path / "tag"
    for seed in range(3):
        for config in CRITICS:
            slope = 2.0 if config == "hierarchical" else 1.0
            write_generic_run(root, "tag", config, seed, [slope * v + 0.05 * seed for v in RAMP])
    return {"tag": tag_study(root)}


def test_the_plan_reads_the_peer_checks_tasks_as_studies() -> None:
    assert set(TASK_KEYS) == set(SOURCES)  # every env source has the key of its task
    known = studies()
    expected = {
        "vmas_navigation": ("vmas", "scenario", "navigation", 100, 300_000),
        "vmas_balance": ("vmas", "scenario", "balance", 100, 150_000),
        "pettingzoo_simple_spread": (
            "pettingzoo", "factory", "mpe2.simple_spread_v3:parallel_env", None, 150_000,
        ),
        "pettingzoo_simple_tag": (
            "pettingzoo", "factory", "mpe2.simple_tag_v3:parallel_env", None, 150_000,
        ),
    }  # fmt: skip
    options = {}
    for name, (env, key, task, max_cycles, frames) in expected.items():
        study = known[name]
        assert study.task is not None
        assert (study.env, study.task.key, study.task.name) == (env, key, task)
        assert (study.task.max_cycles, study.max_steps) == (max_cycles, frames)
        assert (study.configs, study.seeds) == (CRITICS, (0, 1, 2, 3, 4))
        assert study.root == ROOT / "benchmarks" / "results" / "learning" / name
        options[name] = dict(study.task.kwargs)
    assert options["vmas_balance"] == {
        "n_agents": 4, "random_package_pos_on_line": True, "package_mass": 5,
    }  # fmt: skip
    assert options["pettingzoo_simple_tag"]["num_adversaries"] == 3
    assert known["soccer_paper"].task is None  # a game


def test_a_generic_study_compares_each_groups_return_and_plays_no_matches(
    tag: dict[str, Study], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(document, "play", lambda *a: pytest.fail("a round robin was played"))
    out = tmp_path / "doc" / "RESULTS.md"
    args = report_cli.parse_args(["--out", str(out), "--matches", "2"])
    blocks = blocks_of(build_report(args, plan=tag))
    section = blocks["study tag"]
    assert (
        f"Environment: `env=pettingzoo` `env.factory={TAG.name}` `env.kwargs={{num_good: 2}}`; "
        "100 frames per run." in section
    )
    assert "left out of the aggregates over games" in section
    assert "groups (`adversary`, `agent`) all learn with the run's critic" in section
    # The groups are the runs' own, each with its finals over seeds and their interval.
    runs = discover(tag)
    assert groups_of(tag["tag"], runs) == ("adversary", "agent")
    for group in ("adversary", "agent"):
        assert f"**{group}** — " in section
        for config in CRITICS:
            finals = [
                smoothed_final(r.curves(), f"{group}/cumulative_reward")
                for r in complete_runs(runs, f"tag/{config}")
            ]
            cell = fmt_interval(t_interval([v for v in finals if v is not None]))
            assert f"| `tag/{config}` | 3 | {cell} |" in section
    # Welch's tests between the critics, per group, and their verdicts.
    for first, second in (("hierarchical", "twin"), ("hierarchical", "ppo"), ("twin", "ppo")):
        for group in ("adversary", "agent"):
            assert f"| `tag/{first}` vs `tag/{second}` | {group} | 3 vs 3 |" in section
    claims = blocks["claims"]
    assert "`tag/hierarchical`'s agent final cumulative reward is higher than `tag/ppo`'s" in claims
    assert "`tag/hierarchical`'s adversary final cumulative reward is lower than `tag/ppo`'s" in (
        claims
    )
    assert "`tag/twin`'s agent final cumulative reward is not significantly different" in claims
    # Curves as for a game, without a play metric; training speed, but no play, no matches.
    assert (tmp_path / "doc" / "images" / "results_tag.png").stat().st_size > 0
    assert "frames/s (training)" in section
    for absent in ("Does the team play", "Sample efficiency", "hits", "goal rate"):
        assert absent not in section
    assert "`tag`" not in blocks["matches"] and "`tag`" not in blocks["aggregates"]


def test_a_study_without_runs_is_reported_as_not_run_with_its_command(tmp_path: Path) -> None:
    plan = {"tag": tag_study(tmp_path / "tag"), "toy": toy_study(tmp_path / "toy")}
    args = report_cli.parse_args(["--out", str(tmp_path / "R.md"), "--matches", "0"])
    blocks = blocks_of(build_report(args, plan=plan))
    for name in plan:
        assert blocks[f"study {name}"].endswith(
            f"No complete run yet: `python -m rlhc.run -m study={name}` trains it (resumable).\n"
        )
    plan_block = blocks["plan"]
    assert "| 3 | 100 | 0 of 9 | — | — | — |" in plan_block  # no rate: no core-hours
    assert "Not counted, without a measured rate (no complete run of their game or task yet): " \
        "`tag`, `toy`." in plan_block  # fmt: skip
    assert "0 of 15 planned runs complete" in blocks["status"]
    assert not (tmp_path / "images").exists()  # nothing to draw


def test_a_task_without_runs_borrows_no_other_tasks_rate(
    tag: dict[str, Study], tmp_path: Path
) -> None:
    other = Task("factory", "mpe2.simple_spread_v3:parallel_env", (("N", 3),))
    plan = {
        **tag,
        "tag_again": tag_study(tmp_path / "again", "tag_again"),  # the same task, no runs
        "spread": tag_study(tmp_path / "spread", "spread", other),  # another task, no runs
    }
    runs = discover(plan)
    rate = study_rate(plan, plan["tag"], runs)
    assert rate == pytest.approx(0.5)  # 50 s of wall time for 100 frames
    assert study_rate(plan, plan["tag_again"], runs) == rate
    assert study_rate(plan, plan["spread"], runs) is None


def test_claims_are_provisional_only_where_their_own_studies_are_partial(
    tag: dict[str, Study], tmp_path: Path
) -> None:
    # A study with no complete run states nothing, so it makes no claim provisional; a
    # missing run of a study that does state something does.
    args = report_cli.parse_args(["--out", str(tmp_path / "R.md"), "--matches", "0"])
    unrun = {"toy": toy_study(tmp_path / "toy")}
    claims = blocks_of(build_report(args, plan={**tag, **unrun}))["claims"]
    assert "`tag/hierarchical`" in claims and "provisional" not in claims
    (tag["tag"].root / "twin" / "seed_2" / "summary.json").unlink()
    claims = blocks_of(build_report(args, plan={**tag, **unrun}))["claims"]
    assert "Statements on `tag` (8 of 9 planned runs) rest on a partial study; they are " \
        "provisional." in claims  # fmt: skip


def test_a_contest_shows_its_cross_play_where_it_was_played(
    tag: dict[str, Study], tmp_path: Path
) -> None:
    args = report_cli.parse_args(["--out", str(tmp_path / "RESULTS.md"), "--no-figures"])
    section = blocks_of(build_report(args, plan=tag))["study tag"]
    assert "**Cross-play** — not played yet: `python -m benchmarks.cross_play " in section
    # hierarchical's adversaries return more than ppo's against the same agents at seeds
    # 0 to 2 (+2, +3, +2.5); the agents' advantage is 0 at all three.
    rows = []
    for seed, edge in ((0, 2.0), (1, 3.0), (2, 2.5)):
        for adversary, agent in (("hierarchical", "hierarchical"), ("hierarchical", "ppo"),
                                 ("ppo", "hierarchical"), ("ppo", "ppo")):  # fmt: skip
            rows.append(
                {
                    "seed": seed, "first": "hierarchical", "second": "ppo", "episodes": 50,
                    "adversary_plays": adversary, "agent_plays": agent,
                    "adversary_return": 10.0 + (edge if adversary == "hierarchical" else 0.0),
                    "agent_return": -5.0,
                }
            )  # fmt: skip
    with (tag["tag"].root / "cross_play.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    section = blocks_of(build_report(args, plan=tag))["study tag"]
    assert "same 50 episodes with mode actions" in section
    edge, none = fmt_interval(t_interval([2.0, 3.0, 2.5])), fmt_interval(t_interval([0.0] * 3))
    assert (
        f"| `hierarchical` vs `ppo` | adversary | 3 | {edge} | `hierarchical`'s adversary better |"
        in section
    )
    assert f"| `hierarchical` vs `ppo` | agent | 3 | {none} | no difference shown |" in section
    # One seed: a value, no verdict.
    with (tag["tag"].root / "cross_play.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows[:4])
    section = blocks_of(build_report(args, plan=tag))["study tag"]
    assert (
        "| `hierarchical` vs `ppo` | adversary | 1 | 2.0000 (n=1, no interval) | — (needs ≥ 2 seeds) |"
        in section
    )
