"""``benchmarks/peer_check.py``: the commands of both sides, the curves, the verdicts."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from benchmarks import peer_check

NAVIGATION = {"max_steps": 100, "n_agents": 3, "collisions": True, "lidar_range": 0.35}


def test_without_the_peer_environment_run_exits_2_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(peer_check, "PEER_VENV", tmp_path / "nowhere")
    with pytest.raises(SystemExit) as exit_:
        peer_check.main(["run", "--tasks", "vmas/navigation", "--frames", "6000"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "peer_check install" in err


def test_both_sides_train_the_same_task_at_benchmarl_settings(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("vmas")
    monkeypatch.setattr(peer_check, "task_options", lambda task: dict(NAVIGATION))
    job = peer_check.Job("vmas/navigation", "mappo", "rlhc", seed=2, frames=60000)
    words = peer_check.command(job)
    assert words[1:3] == ["-m", "rlhc.run"]
    # BenchMARL's task options, its 10 worlds, 6,000 and 400 frames of 3 agents.
    assert {
        "env=vmas",
        "env.scenario=navigation",
        "env.max_cycles=100",
        "env.kwargs={n_agents: 3, collisions: true, lidar_range: 0.35}",
        "env.num_envs=10",
        "algo.buffer_size=18000",
        "algo.batch_size=1200",
        "critic=manager",
        "env.manager_view=world",
        "seed=2",
        "algo.max_steps=60000",
        "resume=auto",
    } <= set(words)
    peer = peer_check.command(peer_check.Job("vmas/navigation", "ippo", "benchmarl", 2, 60000))
    assert peer[0] == str(peer_check.PEER_VENV / "bin" / "python")
    assert peer[2:6] == ["--task=vmas/navigation", "--algorithm=ippo", "--seed=2", "--frames=60000"]


def test_mappo_reads_what_benchmarls_critic_reads() -> None:
    # BenchMARL's MAPPO critic reads the env's global state on its MPE tasks, the group's
    # observations on VMAS (no state there); IPPO reads each agent's own observation.
    def overrides(task: str, algorithm: str) -> list[str]:
        return peer_check.algorithm_overrides(peer_check.Job(task, algorithm, "rlhc", 0, 6000))

    assert overrides("vmas/balance", "mappo") == ["critic=manager", "env.manager_view=world"]
    assert overrides("pettingzoo/simple_tag", "mappo") == [
        "critic=manager",
        "env.manager_view=state",
    ]
    assert overrides("pettingzoo/simple_tag", "ippo") == ["critic=ppo"]


def test_an_rlhc_curve_is_each_groups_return_per_update(tmp_path: Path) -> None:
    with (tmp_path / "metrics.csv").open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["step", "agents/cumulative_reward", "frames", "wall_time"])
        writer.writerows([[6000, -0.5, 6000, 4.0], [12000, -0.25, 12000, 7.0]])
    peer_check.write_rlhc_curve(tmp_path)
    assert (tmp_path / "curve.csv").read_text().splitlines() == [
        "frames,seconds,agents",
        "6000,4.0,-0.5",
        "12000,7.0,-0.25",
    ]
    assert peer_check.steady_rate(tmp_path) == 2000.0


def fake_run(root: Path, arm: str, seed: int, returns: list[float], seconds: float) -> None:
    """A finished run: one update of 6,000 frames every ``seconds``."""
    directory = root / "runs" / "vmas_navigation" / arm / f"seed_{seed}"
    directory.mkdir(parents=True)
    rows = [(6000 * (i + 1), seconds * (i + 1), r) for i, r in enumerate(returns)]
    if arm.startswith("rlhc"):
        with (directory / "metrics.csv").open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(["frames", "wall_time", "agents/cumulative_reward"])
            writer.writerows(rows)
    else:
        with (directory / "curve.csv").open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(["frames", "seconds", "agents"])
            writer.writerows(rows)
    (directory / "done.json").write_text(json.dumps({"frames": rows[-1][0], "seconds": 1.0}))


def test_the_report_scores_the_last_five_updates_against_the_peers_interval(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("matplotlib")
    monkeypatch.setattr(peer_check, "RESULTS", tmp_path)
    # Scores (mean of the last five updates): peer 1.0, 2.0, 3.0 -> mean 2, t95 interval
    # 2 +- 4.303; rlhc: 2.0 (within) for ippo, -10 (below) for mappo.
    for seed, level in enumerate([1.0, 2.0, 3.0]):
        for algorithm in ("ippo", "mappo"):
            fake_run(tmp_path, f"benchmarl_{algorithm}", seed, [-5.0] + [level] * 5, seconds=3.0)
        fake_run(tmp_path, "rlhc_ippo", seed, [-5.0] + [2.0] * 5, seconds=1.0)
        fake_run(tmp_path, "rlhc_mappo", seed, [-5.0] + [-10.0] * 5, seconds=1.0)
    peer_check.main(["report"])
    summary = json.loads((tmp_path / "summary.json").read_text())
    peer = summary["vmas_navigation/benchmarl_ippo"]["score"]["agents"]
    assert peer["mean"] == pytest.approx(2.0)
    assert peer["low"] == pytest.approx(2.0 - 4.303 / 3**0.5)
    assert summary["vmas_navigation/rlhc_ippo"]["frames_per_s"] == pytest.approx(6000)
    rows = (tmp_path / "table.md").read_text().splitlines()[2:]
    assert [row.split(" | ")[1] for row in rows] == ["ippo", "mappo"]
    assert "within or above" in rows[0] and "6,000 / 2,000" in rows[0]
    assert f"below by {(2.0 - 4.303 / 3**0.5) + 10:.3f}" in rows[1]
    assert (tmp_path / "curves.png").stat().st_size > 0


def test_speed_alternates_the_sides_and_writes_their_ratio_per_round(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(peer_check, "RESULTS", tmp_path)
    monkeypatch.setattr(peer_check, "ROOT", tmp_path)
    monkeypatch.setattr(peer_check, "check_peer_venv", lambda: None)
    order = []

    def fake_job(job: peer_check.Job, directory: Path) -> str:
        order.append(job.implementation)
        directory.mkdir(parents=True)
        per_update = 1.0 if job.implementation == "rlhc" else 4.0
        (directory / "curve.csv").write_text(
            f"frames,seconds,agents\n6000,{per_update},0\n12000,{2 * per_update},0\n"
        )
        return str(job)

    monkeypatch.setattr(peer_check, "run_job", fake_job)
    peer_check.main(["speed", "--frames", "12000", "--rounds", "2"])
    assert order == ["rlhc", "benchmarl", "benchmarl", "rlhc"]
    result = json.loads((tmp_path / "speed_vmas_navigation_mappo.json").read_text())
    assert result["median"] == {"rlhc": 6000.0, "benchmarl": 1500.0}
    assert result["ratio_per_round"] == [4.0, 4.0]
