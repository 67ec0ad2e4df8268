"""The reproduction's studies (``conf/study/``): what they compose, and running them.

A study is one Hydra multirun that can be started again: every run continues from its
own directory's checkpoint (``resume=auto``) and a finished run is skipped, writing
nothing. The runs here use ``experiment=smoke`` and a sweep directory under
``tmp_path``, and start from ``tmp_path``, so a mistake can never write into
``benchmarks/results/``.
"""

from __future__ import annotations

import dataclasses
import functools
import shutil
from pathlib import Path
from typing import Any

import pytest
from cli_runs import run_in_process, run_subprocess, snapshot, steps
from configs import CONF, load, options
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from benchmarks import peer_check
from rlhc.cli.cleanup import remove_if_unused, remove_unused_sweep
from rlhc.cli.hydra_hooks import run_directory
from rlhc.storage.checkpoint import load_checkpoint

#: What each study is: the game, the critics swept, league, shaping, budget, sweep dir.
STUDIES = {
    "tennis_paper": ("tennis", False, ["ppo", "hierarchical", "twin"], "self_play", 0.0, 3_600_000, "tennis/paper"),
    "tennis_extended": ("tennis", True, ["ppo", "hierarchical"], "self_play", 0.0, 3_600_000, "tennis/extended"),
    "tennis_extensions": ("tennis", False, ["manager", "mean", "hierarchical_k5"], "self_play", 0.0, 3_600_000, "tennis/extensions"),
    "soccer_paper": ("soccer", None, ["ppo", "hierarchical", "twin"], "self_play", 0.0, 500_000, "soccer/paper"),
    "soccer_best": ("soccer", None, ["ppo", "hierarchical", "twin"], "mixed", 0.1, 1_000_000, "soccer/best"),
    "tennis_best": ("tennis", False, ["ppo", "hierarchical", "twin"], "mixed", 0.0, 5_000_000, "tennis/best"),
}  # fmt: skip
#: Studies on other libraries' envs: the peer check's task (benchmarks/peer_check.py), budget.
GENERIC = {
    "vmas_navigation": ("vmas/navigation", 300_000),
    "vmas_balance": ("vmas/balance", 150_000),
    "pettingzoo_simple_spread": ("pettingzoo/simple_spread", 150_000),
    "pettingzoo_simple_tag": ("pettingzoo/simple_tag", 150_000),
}
#: League shares of a study that are not its league option's own.
SHARES = {"tennis_best": {"self_play": 0.3, "snapshot": 0.2, "scripted": 0.5, "random": 0.0}}
#: Seeds per configuration where a study has fewer than 5 (the compute plan).
SEEDS = {"tennis_extensions": 3}
#: A small study: 64-frame updates (tennis smoke), a summary and a checkpoint each.
SMALL = ["study=tennis_paper", "experiment=smoke", "logger.summary_freq=64", "checkpoint_freq=64"]
FINISHED = "the run is finished, nothing to do"


@functools.cache
def option(group: str, name: str) -> Any:
    """The section ``group`` of the config that chooses ``name`` in that group."""
    return getattr(load(f"{group}={name}"), group)


def sweep_settings(study: str) -> dict[str, object]:
    """The study's ``hydra.run`` / ``hydra.sweep`` / ``hydra.sweeper.params``, unresolved."""
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose(config_name="train", overrides=[f"study={study}"], return_hydra_config=True)
    own = cfg.hydra
    return OmegaConf.to_container(  # type: ignore[return-value]
        OmegaConf.create({"run": own.run, "sweep": own.sweep, "params": own.sweeper.params}),
        resolve=False,
    )


# --- what a study composes -----------------------------------------------------------
def test_every_study_is_described() -> None:
    assert sorted([*STUDIES, *GENERIC]) == options("study")


@pytest.mark.parametrize("study", sorted(STUDIES))
def test_a_study_composes_its_game_league_shaping_budget_and_sweep(study: str) -> None:
    env, extended, critics, league, shaping, budget, results = STUDIES[study]
    cfg = load(f"study={study}")
    assert cfg.env.name == env
    assert getattr(cfg.env, "extended_obs", None) is extended
    assert cfg.league == dataclasses.replace(option("league", league), **SHARES.get(study, {}))
    assert cfg.shaping.scale == shaping
    assert cfg.algo.max_steps == budget
    assert cfg.resume == "auto"
    assert (cfg.logger.backends, cfg.logger.progress) == (["csv"], False)
    assert sweep_settings(study) == {
        "run": {"dir": "${hydra.sweep.dir}/${hydra.sweep.subdir}"},
        "sweep": {
            "dir": f"benchmarks/results/learning/{results}",
            "subdir": "${hydra:runtime.choices.critic}/seed_${seed}",
        },
        "params": {"critic": ",".join(critics), "seed": f"range({SEEDS.get(study, 5)})"},
    }
    for critic in critics:
        run = load(f"study={study}", f"critic={critic}", "seed=3")
        assert (run.critic, run.seed, run.env.name) == (option("critic", critic), 3, env)


#: The preset each study trains.
PRESETS = {study: ("best" if study.endswith("_best") else "paper") for study in STUDIES}


@pytest.mark.parametrize("study", sorted(STUDIES))
def test_a_study_trains_its_preset(study: str) -> None:
    # A study adds critics, seeds and where its runs live; what trains is the preset's.
    env, extended, *_ = STUDIES[study]
    game = [f"env={env}", f"preset={PRESETS[study]}", "critic=hierarchical", "seed=2"]
    preset = load(*game, *(["env.extended_obs=true"] if extended else []))
    run = load(f"study={study}", "critic=hierarchical", "seed=2")
    for section in ("env", "critic", "algo", "model", "league", "shaping"):
        assert getattr(run, section) == getattr(preset, section), section
    for key in ("checkpoint_freq", "play_freq", "eval_freq", "eval_matches"):
        assert getattr(run, key) == getattr(preset, key), key


@pytest.mark.parametrize("study", sorted(GENERIC))
def test_a_generic_study_trains_what_the_peer_check_trains(study: str) -> None:
    task, budget = GENERIC[study]
    cfg = load(f"study={study}")
    assert (cfg.algo.max_steps, cfg.resume, cfg.logger.backends) == (budget, "auto", ["csv"])
    assert sweep_settings(study) == {
        "run": {"dir": "${hydra.sweep.dir}/${hydra.sweep.subdir}"},
        "sweep": {
            "dir": f"benchmarks/results/learning/{task.replace('/', '_')}",
            "subdir": "${hydra:runtime.choices.critic}/seed_${seed}",
        },
        "params": {"critic": "ppo,hierarchical,twin", "seed": "range(5)"},
    }
    # The peer check's run of the task at the study's budget is the study's run.
    if not (peer_check.PEER_VENV / "bin" / "python").exists():
        pytest.skip("the peer check reads BenchMARL's task options from .venv-peer")
    job = peer_check.Job(task, "ippo", "rlhc", seed=3, frames=budget)
    words = peer_check.command(job)
    assert words[1:3] == ["-m", "rlhc.run"]
    # the study sweeps the critic and names the run directory
    leave_out = {*peer_check.ALGORITHMS["ippo"], f"hydra.run.dir={job.directory}"}
    overrides = [word for word in words[3:] if word not in leave_out]
    assert load(f"study={study}", "critic=hierarchical", "seed=3") == load(
        *overrides, "critic=hierarchical"
    )


def test_hierarchical_k5_consults_the_manager_every_5_decisions() -> None:
    critic = load("study=tennis_extensions", "critic=hierarchical_k5").critic
    assert (critic.fusion, critic.manager_interval, critic.manager_view) == ("max", 5, True)


@pytest.mark.parametrize("study", sorted(STUDIES))
def test_the_smoke_experiment_shrinks_a_study_and_keeps_it_out_of_its_results(study: str) -> None:
    # the experiment comes after the study in the defaults list: smoke's budget wins, even
    # over a study with a budget of its own (soccer_best)
    assert load(f"study={study}", "experiment=smoke").algo.max_steps == 512
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        smoke = compose(
            config_name="train",
            overrides=[f"study={study}", "experiment=smoke"],
            return_hydra_config=True,
        )
    sweep = OmegaConf.to_container(smoke.hydra.sweep, resolve=False)
    # a smoke run never lands in (nor blocks the resume of) the study's real runs ...
    assert sweep == {
        "dir": "multirun/${now:%Y-%m-%d_%H-%M-%S}",
        # ... and keeps the study's layout: a smoke multirun shows what the study writes
        "subdir": "${hydra:runtime.choices.critic}/seed_${seed}",
    }


# --- resume=auto ---------------------------------------------------------------------
def test_resume_auto_keeps_the_configured_run_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "auto" / "checkpoints").mkdir(parents=True)  # a run named "auto" is not meant
    assert run_directory("auto", "outputs/new") == "outputs/new"
    assert run_directory("./auto", "outputs/new") == "auto"


def test_resume_auto_continues_its_own_run_after_the_budget_is_raised(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep = ["hydra.sweep.dir=study", "critic=ppo", "seed=0"]
    first = run_in_process(["-m", *SMALL, *sweep, "algo.max_steps=128"], tmp_path, monkeypatch, capsys)  # fmt: skip
    assert first.code == 0, first.stderr
    run = tmp_path / "study" / "ppo" / "seed_0"
    assert steps(run) == [64, 128]
    # A single run of the study: the same directory, from its checkpoint.
    again = run_in_process([*SMALL, *sweep, "algo.max_steps=256"], tmp_path, monkeypatch, capsys)
    assert again.code == 0, again.stderr
    assert again.stdout.splitlines()[-1].endswith("results in study/ppo/seed_0")
    assert steps(run) == [64, 128, 192, 256]
    assert load_checkpoint(run)["frames"] == 256
    assert (run / "run.log").read_text().count("results in") == 2


# --- a failed job never removes what it did not create -------------------------------
@pytest.mark.parametrize(
    ("files", "removed"),
    [
        ({}, True),
        ({"run.log": ""}, True),  # what Hydra opened before the job failed
        ({"run.log": "[INFO] - results in run\n"}, False),
        ({"checkpoints/step_000000064.pt": "x"}, False),
        ({"metrics.csv": "step\n64\n"}, False),
        ({"train.log": ""}, False),
        ({".hydra/config.yaml": "seed: 0\n", "run.log": ""}, False),
    ],
)
def test_remove_if_unused_removes_only_an_empty_job_directory(
    tmp_path: Path, files: dict[str, str], removed: bool
) -> None:
    run = tmp_path / "run"
    run.mkdir()
    for name, text in files.items():
        (run / name).parent.mkdir(parents=True, exist_ok=True)
        (run / name).write_text(text)
    before = snapshot(run)
    remove_if_unused(run, "run.log")
    assert not run.exists() if removed else snapshot(run) == before


def test_remove_unused_sweep_keeps_a_sweep_that_holds_runs(tmp_path: Path) -> None:
    for sweep, runs in ((tmp_path / "empty", False), (tmp_path / "used", True)):
        sweep.mkdir()
        (sweep / "multirun.yaml").write_text("hydra: {}\n")
        if runs:
            (sweep / "ppo" / "seed_0").mkdir(parents=True)
        remove_unused_sweep(sweep)
        assert sweep.exists() is runs


def test_a_failed_job_leaves_every_existing_run_directory_as_it_was(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep = ["-m", *SMALL, "hydra.sweep.dir=study", "critic=hierarchical"]
    first = run_in_process([*sweep, "seed=0", "algo.max_steps=64"], tmp_path, monkeypatch, capsys)
    assert first.code == 0, first.stderr
    runs = tmp_path / "study" / "hierarchical"  # seed_0: a run with its checkpoint and logs
    crashed = runs / "seed_1"  # a run that stopped before its first checkpoint
    (crashed / ".hydra").mkdir(parents=True)
    (crashed / ".hydra" / "config.yaml").write_text("seed: 1\n")
    for name in ("run.log", "train.log"):
        (crashed / name).touch()
    broken = runs / "seed_2"  # a run whose checkpoints a crash of the machine truncated
    shutil.copytree(runs / "seed_0", broken, symlinks=True)
    for checkpoint in (broken / "checkpoints").glob("step_*.pt"):
        checkpoint.write_bytes(checkpoint.read_bytes()[:100])
    before = snapshot(runs)

    # A bad value: every job fails before resuming; seed_3 had no directory.
    bad_value = run_in_process([*sweep, "seed=0,1,2,3", "critic.weight=2"], tmp_path, monkeypatch, capsys)  # fmt: skip
    assert bad_value.code == 2
    assert bad_value.stderr.splitlines()[-1].startswith("rlhc.run: error: critic.weight=2.0")
    assert snapshot(runs) == before  # not even .hydra/ rewritten, and no seed_3/

    # Settings a resume cannot change (seed_0), checkpoints that do not load (seed_2).
    for seed, expected in ((0, "model.hidden_size: 32 -> 16"), (2, "no loadable checkpoint")):
        refused = run_in_process([*sweep, f"seed={seed}", "model.hidden_size=16"], tmp_path, monkeypatch, capsys)  # fmt: skip
        assert refused.code == 2
        assert expected in refused.stderr.splitlines()[-1]
        assert snapshot(runs) == before


def test_a_study_run_without_its_checkpoints_is_never_trained_over(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # A clone holds a study's committed outputs (metrics.csv, logs) but no checkpoints.
    sweep = ["-m", *SMALL, "hydra.sweep.dir=study", "critic=ppo", "algo.max_steps=128"]
    first = run_in_process([*sweep, "seed=0,1"], tmp_path, monkeypatch, capsys)
    assert first.code == 0, first.stderr
    finished, cut = (tmp_path / "study" / "ppo" / f"seed_{seed}" for seed in (0, 1))
    for run in (finished, cut):
        shutil.rmtree(run / "checkpoints")
    metrics = (cut / "metrics.csv").read_text().splitlines()
    (cut / "metrics.csv").write_text("\n".join(metrics[:-1]) + "\n")  # stopped at 64 frames
    before = snapshot(tmp_path / "study" / "ppo")  # (multirun.yaml: each sweep's own)

    again = run_in_process([*sweep, "seed=0"], tmp_path, monkeypatch, capsys)
    assert again.code == 0, again.stderr
    assert (
        "metrics.csv records 128 frames of algo.max_steps=128: the run is finished" in again.stdout
    )
    refused = run_in_process([*sweep, "seed=1"], tmp_path, monkeypatch, capsys)
    assert refused.code == 2
    assert refused.stderr.splitlines()[-1].endswith(
        "records 64 of algo.max_steps=128 frames in metrics.csv but holds no checkpoint to "
        "continue from; a fresh run would overwrite that record. Move or delete the "
        "directory to train the run again from the start"
    )
    assert snapshot(tmp_path / "study" / "ppo") == before


# --- the study as a multirun, started twice ------------------------------------------
def test_a_study_multirun_trains_every_run_once_then_skips_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep_dir = tmp_path / "study"
    study = ["-m", "study=tennis_paper", "experiment=smoke", f"hydra.sweep.dir={sweep_dir}"]
    # Command-line sweeps replace the study's own (hydra.sweeper.params) key by key.
    grid = ["seed=range(2)", "critic=ppo,twin"]
    trained_runs = run_subprocess(
        [*study, *grid, "hydra/launcher=joblib", "hydra.launcher.n_jobs=2"], cwd=tmp_path
    )
    assert trained_runs.code == 0, trained_runs.stderr[-3000:]
    runs = [sweep_dir / critic / f"seed_{seed}" for critic in ("ppo", "twin") for seed in (0, 1)]
    assert sorted(p for p in sweep_dir.glob("*/*") if p.is_dir()) == runs
    for run in runs:
        assert steps(run)[-1] == 512
        assert load_checkpoint(run)["frames"] == 512
    (runs[0] / "run.log").unlink()  # a run trained by another launcher keeps none
    before = {run: snapshot(run) for run in runs}

    # The same sweep on the basic launcher (here, in this process): a finished job
    # leaves its directory as it was, without even an empty job log.
    again = run_in_process([*study, *grid], tmp_path, monkeypatch, capsys)
    assert again.code == 0, again.stderr[-3000:]
    output = again.stdout + again.stderr
    assert output.count(FINISHED) == 4
    assert "frames/s" not in output and "results in" not in output
    assert {run: snapshot(run) for run in runs} == before
