"""``benchmarks/train_throughput.py``: ``--variant`` parsing, the ratios, the reference setup.

The pure parts, and smoke-sized runs of the in-process ``reference`` setup: no training
subprocesses, no git worktree (the script's smoke check does).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest


@pytest.fixture
def tt() -> ModuleType:
    """``benchmarks/train_throughput.py`` as a module."""
    from benchmarks import train_throughput

    return train_throughput


def run(variant: str, round_: int, rate: float, setup: str = "one") -> dict[str, Any]:
    """One run as ``run_rounds`` records it (the keys :func:`compare` reads)."""
    processes = 2 if setup == "pipeline" else 1
    return {"env": "tennis", "setup": setup, "variant": variant, "round": round_,
            "processes": processes, "frames_per_s": rate}  # fmt: skip


def test_without_comparison_options_nothing_changes(tt: ModuleType) -> None:
    args = tt.parse_args([])
    assert args.baseline is None and args.variant == [] and args.overrides == []
    assert args.output == tt.RESULTS
    assert tt.parse_args(["--out", "/tmp/x.json"]).output == Path("/tmp/x.json")


def test_variants_parse_name_and_overrides(tt: ModuleType) -> None:
    args = tt.parse_args([
        "--baseline", "HEAD~3",
        "--variant", "ppo=critic=ppo",
        "--variant", "big=model.hidden_size=256 algo.epochs=4",
        "--variant", "again=",
    ])  # fmt: skip
    assert args.baseline == "HEAD~3"
    assert [(v.name, v.overrides, v.source) for v in args.variant] == [
        ("ppo", ("critic=ppo",), None),
        ("big", ("model.hidden_size=256", "algo.epochs=4"), None),
        ("again", (), None),  # the working tree again: an A/A check
    ]


def test_overrides_reach_every_variant_the_baselines_too(
    tt: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    args = tt.parse_args(["--env", "tennis", "--setups", "one", "--updates", "1", "2",
                          "--overrides", "study=tennis_best", "resume=null"])  # fmt: skip
    seen = []

    def fake_run(env: str, critic: str, setup: str, updates: int, overrides: Any, source: Any):
        seen.append((source, tuple(overrides)))
        return {"frames_per_s": 1.0, "env_steps_per_s": 1.0}

    monkeypatch.setattr(tt, "run_setup", fake_run)
    variants = [tt.Variant("baseline", (), Path("/tmp/tree")), tt.Variant("current"),
                tt.Variant("ppo", ("critic=ppo",))]  # fmt: skip
    tt.run_rounds(args, variants, label=True)
    assert seen == [
        (Path("/tmp/tree"), ("study=tennis_best", "resume=null")),
        (None, ("study=tennis_best", "resume=null")),
        (None, ("study=tennis_best", "resume=null", "critic=ppo")),
    ]


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        ("foo", "NAME=OVERRIDES"),
        ("=critic=ppo", "NAME=OVERRIDES"),
        ("critic=ppo", "'ppo' is not a Hydra override"),  # the name forgotten
        ("baseline=critic=ppo", "reserved"),
        ("current=", "reserved"),
        ("q=model.name='open", "quotation"),
    ],
)
def test_bad_variant_is_an_argparse_error_naming_the_value(
    tt: ModuleType, capsys: pytest.CaptureFixture[str], value: str, reason: str
) -> None:
    with pytest.raises(SystemExit) as exit_:
        tt.parse_args(["--variant", value])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "argument --variant" in err and repr(value) in err
    assert reason in err and "expected NAME=OVERRIDES" in err


def test_a_variant_name_given_twice_is_an_error(
    tt: ModuleType, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        tt.parse_args(["--variant", "a=critic=ppo", "--variant", "a=critic=mean"])
    assert "'a' is given twice" in capsys.readouterr().err


def test_ratios_pair_runs_of_the_same_round_and_take_the_median(tt: ModuleType) -> None:
    runs = [
        *(run("baseline", r, rate) for r, rate in enumerate([100.0, 200.0, 100.0])),
        *(run("current", r, rate) for r, rate in enumerate([110.0, 180.0, 120.0])),
        *(run("baseline", r, rate, "pipeline") for r, rate in enumerate([300.0, 300.0, 300.0])),
        *(run("current", r, rate, "pipeline") for r, rate in enumerate([150.0, 300.0, 600.0])),
    ]
    ceilings = {"baseline": {"tennis": 1000.0}, "current": {"tennis": 500.0}}
    rows = {(row["setup"], row["variant"]): row for row in tt.compare(runs, "baseline", ceilings)}

    current = rows["one", "current"]
    assert current["per_round"] == [110.0, 180.0, 120.0]
    assert current["frames_per_s"] == 120.0  # the median rate
    assert current["ratios_per_round"] == [1.1, 0.9, 1.2]
    assert math.isclose(current["ratio_to_reference"], 1.1)  # median of the ratios
    assert math.isclose(current["share_of_ceiling"], 120.0 / 500.0)  # its own ceiling

    baseline = rows["one", "baseline"]
    assert baseline["frames_per_s"] == 100.0 and baseline["ratio_to_reference"] == 1.0
    assert math.isclose(baseline["share_of_ceiling"], 0.1)

    # Per round, not medians over rounds: 0.5, 1, 2 -> 1 (the medians' ratio is 1 too,
    # the mean of the ratios would be 7/6); the ceiling times the two processes.
    pipeline = rows["pipeline", "current"]
    assert pipeline["ratios_per_round"] == [0.5, 1.0, 2.0]
    assert pipeline["ratio_to_reference"] == 1.0
    assert math.isclose(pipeline["share_of_ceiling"], 300.0 / (2 * 500.0))


def test_rounds_without_a_reference_run_are_left_out(tt: ModuleType) -> None:
    runs = [run("current", 0, 100.0), run("current", 1, 100.0), run("ppo", 0, 50.0),
            run("ppo", 1, 80.0), run("ppo", 2, 1000.0)]  # fmt: skip
    ceilings = {name: {"tennis": 1000.0} for name in ("current", "ppo")}
    rows = {row["variant"]: row for row in tt.compare(runs, "current", ceilings)}
    assert rows["ppo"]["rounds"] == [0, 1, 2]
    assert rows["ppo"]["ratios_per_round"] == [0.5, 0.8]
    assert math.isclose(rows["ppo"]["ratio_to_reference"], 0.65)
    assert rows["ppo"]["frames_per_s"] == 80.0

    alone = tt.compare([run("ppo", 0, 50.0)], "current", ceilings)
    assert alone[0]["ratios_per_round"] == [] and alone[0]["ratio_to_reference"] is None


def test_markdown_table(tt: ModuleType) -> None:
    runs = [run("baseline", 0, 1000.0), run("current", 0, 1100.0),
            run("baseline", 1, 2000.0), run("current", 1, 1800.0)]  # fmt: skip
    ceilings = {name: {"tennis": 10_000.0} for name in ("baseline", "current")}
    lines = tt.markdown_table(tt.compare(runs, "baseline", ceilings)).splitlines()
    assert "ratio to baseline (median of per-round ratios)" in lines[0]
    assert len(lines) == 4
    assert lines[2] == "| tennis | one | baseline | 1,000 / 2,000 | 1,500 | reference | 15.0% |"
    assert (
        lines[3]
        == "| tennis | one | current | 1,100 / 1,800 | 1,450 | 1.000 (1.100 / 0.900) | 14.5% |"
    )


def test_a_source_tree_goes_first_on_pythonpath(
    tt: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert tt.source_env(None) is None  # the working tree: the environment inherited
    monkeypatch.setenv("PYTHONPATH", "/elsewhere")
    assert tt.source_env(Path("/tmp/tree"))["PYTHONPATH"] == f"/tmp/tree{os.pathsep}/elsewhere"
    monkeypatch.delenv("PYTHONPATH")
    assert tt.source_env(Path("/tmp/tree"))["PYTHONPATH"] == "/tmp/tree"


def test_summary_ratios_pair_each_setup_with_one_and_reference_of_its_round(
    tt: ModuleType,
) -> None:
    runs = [{**run("current", r, rate, setup), "setup": setup}
            for setup, rates in (("one", [100.0, 200.0]), ("reference", [400.0, 400.0]))
            for r, rate in enumerate(rates)]  # fmt: skip
    ceilings = {"tennis": {"ceiling_frames_per_s_one_core": 1000.0}}
    rows = {row["setup"]: row for row in tt.summarise(runs, ceilings)}
    assert rows["one"]["ratios_vs_reference_per_round"] == [0.25, 0.5]
    assert math.isclose(rows["one"]["ratio_vs_reference"], 0.375)
    assert rows["reference"]["ratio_vs_one"] == 3.0
    assert rows["reference"]["ratio_vs_reference"] == 1.0


@pytest.mark.parametrize("env", ["tennis", "soccer"])
def test_reference_setup_runs_with_the_trainers_networks(tt: ModuleType, env: str) -> None:
    """A smoke-sized reference run has a rate and counts the trainer's FLOP; at Table 3 its
    networks (actor, worker and manager critic per group) hold the trainer's parameters."""
    from benchmarks.reference_loop import Reference
    from rlhc.building.builders import make_agents, trainable_parameters
    from rlhc.envs import make_env

    result = tt.run_setup(env, "hierarchical", "reference", 2, ["experiment=smoke"])
    assert result["setup"] == "reference" and result["frames_per_s"] > 0
    assert result["frames"] == result["frames_per_batch"] and result["checks"]["flop_ok"]

    cfg = tt.compose_config(env, "hierarchical", [])
    _, losses = make_agents(cfg, make_env(env, num_envs=1, seed=0, **cfg.env.game_options()))
    nets = Reference(cfg).nets
    assert all(len(list(group.children())) == 3 for group in nets.values())
    assert {g: sum(p.numel() for p in group.parameters()) for g, group in nets.items()} == {
        g: sum(p.numel() for p in trainable_parameters({g: loss})) for g, loss in losses.items()
    }
