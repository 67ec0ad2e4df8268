"""The generic environment path (rlhc/envs/generic.py): PettingZoo and VMAS in the contract,
every critic mode trains on them, and a bad environment is refused in one line."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from configs import load
from torchrl.envs.utils import check_env_specs

from rlhc.building.builders import Layout, make_agents
from rlhc.building.flops import network_flops
from rlhc.config.validation import validate
from rlhc.envs import make_env
from rlhc.envs.generic import make_source_env
from rlhc.envs.keys import DONE, MANAGER_OBSERVATION, NEXT, OBSERVATION, STEP_COUNT, TEAM
from rlhc.errors import ConfigError, EnvError

TINY = "tests.envs.tiny_envs"
CRITICS = ["ppo", "hierarchical", "twin", "manager", "mean", "weighted", "hierarchical_k5"]
#: A run of a few seconds on a generic env (3 agents in blue, the largest group).
SMALL = [
    "algo.max_steps=96",
    "algo.buffer_size=96",
    "algo.batch_size=48",
    "algo.time_horizon=16",
    "algo.epochs=1",
    "model.num_layers=1",
    "model.hidden_size=16",
    "logger.summary_freq=48",
    "logger.backends=[csv]",
    "checkpoint_freq=48",
]


def tiny(num_envs: int = 2, **options: object):
    return make_source_env(
        "pettingzoo", num_envs=num_envs, seed=0, factory=f"{TINY}:tiny", **options
    )


def test_a_pettingzoo_env_meets_the_contract() -> None:
    env = tiny(kwargs={"episode": 5})
    check_env_specs(env)
    rollout = env.rollout(7, break_when_any_done=False)
    assert rollout[NEXT, "blue", OBSERVATION].shape == (2, 7, 2, 4)
    assert rollout["blue", "action"].dtype == torch.int64  # Discrete: categorical
    assert rollout["red", "action"].shape == (2, 7, 1, 2)  # a 1-D Box
    assert rollout[NEXT, STEP_COUNT][0].flatten().tolist() == [1, 2, 3, 4, 5, 1, 2]
    assert rollout[NEXT, "blue", DONE][0, 4].all() and not rollout[NEXT, "blue", DONE][0, 3].any()
    assert (rollout["blue", TEAM] == 0).all()


def test_the_team_view_puts_each_agents_own_observation_first() -> None:
    td = tiny().reset()
    obs, view = td["blue", OBSERVATION], td["blue", MANAGER_OBSERVATION]
    assert view.shape == (2, 2, 8)
    assert torch.equal(view[:, 0], torch.cat([obs[:, 0], obs[:, 1]], -1))
    assert torch.equal(view[:, 1], torch.cat([obs[:, 1], obs[:, 0]], -1))


def test_the_world_view_is_every_agents_and_its_critic_runs_once() -> None:
    td = tiny(manager_view="world").reset()
    obs, view = td["blue", OBSERVATION], td["blue", MANAGER_OBSERVATION]
    assert view.shape == (2, 2, 8)
    for agent in range(2):
        assert torch.equal(view[:, agent], torch.cat([obs[:, 0], obs[:, 1]], -1))
    # The builder shares the manager critic's input on this view (and on state), not on team.
    for manager_view, shared in (("world", True), ("state", True), ("team", False)):
        cfg = load("env=pettingzoo", f"env.factory={TINY}:tiny", f"env.manager_view={manager_view}")
        _, losses = make_agents(cfg, tiny(manager_view=manager_view))
        mlp = losses["blue"].value_estimator.manager_value_network.module
        assert mlp.shared_input is shared, manager_view
    # ... and counts its arithmetic once per world: blue's two agents read 8 inputs either way.
    flops = {
        view: network_flops(load("env=pettingzoo", f"env.factory={TINY}:tiny", f"env.manager_view={view}"))
        for view in ("team", "world")
    }  # fmt: skip
    assert flops["team"]["blue"].manager_critic == 2 * flops["world"]["blue"].manager_critic > 0


def test_the_state_view_and_a_user_view() -> None:
    td = tiny(manager_view="state").reset()
    assert td["red", MANAGER_OBSERVATION].shape == (2, 1, 12)
    assert torch.equal(td["blue", MANAGER_OBSERVATION][:, 0], td["state"])
    td = tiny(manager_view=f"{TINY}:team_view_sum").reset()
    assert torch.allclose(td["blue", MANAGER_OBSERVATION][:, 1], td["blue", OBSERVATION].sum(1))


def test_on_simple_spread_the_state_view_is_the_world_view() -> None:
    # MPE's state() concatenates every agent's observation and simple_spread has one group:
    # the two views give the manager critic the same input, step for step, across resets.
    pytest.importorskip("mpe2")
    kwargs = {"N": 3, "max_cycles": 5, "continuous_actions": True}
    views = {}
    for view in ("world", "state"):
        torch.manual_seed(0)  # the random actions of rollout()
        env = make_source_env(
            "pettingzoo",
            num_envs=2,
            seed=0,
            factory="mpe2.simple_spread_v3:parallel_env",
            kwargs=kwargs,
            manager_view=view,
        )
        views[view] = env.rollout(8, break_when_any_done=False)[NEXT, "agent", MANAGER_OBSERVATION]
    assert views["world"].shape == (2, 8, 3, 54)
    assert torch.equal(views["world"], views["state"])


def test_seeded_envs_repeat_themselves() -> None:
    rollouts = []
    for _ in range(2):
        torch.manual_seed(0)  # the random actions of rollout()
        rollouts.append(tiny().rollout(5))
    first, second = rollouts
    assert torch.equal(first[NEXT, "red", OBSERVATION], second[NEXT, "red", OBSERVATION])


@pytest.mark.parametrize("critic", CRITICS)
def test_every_critic_trains_on_a_pettingzoo_env(critic: str, tmp_path: Path) -> None:
    from rlhc.training.trainer import Trainer

    cfg = load("env=pettingzoo", f"env.factory={TINY}:tiny", f"critic={critic}", *SMALL)
    validate(cfg)
    metrics = Trainer(cfg, tmp_path).train()
    assert metrics["frames"] == 96
    assert metrics["blue/experiences"] == 2 * 96 and metrics["red/experiences"] == 96
    assert torch.isfinite(torch.tensor(metrics["red/loss_objective"]))
    assert (tmp_path / "metrics.csv").exists()


def test_the_layout_counts_the_largest_group() -> None:
    cfg = load("env=pettingzoo", f"env.factory={TINY}:tiny", *SMALL, "algo.batch_size=47")
    with pytest.raises(ConfigError, match="a multiple of 2, the agents of the largest group"):
        Layout.from_config(cfg)


# --- refused in one line -------------------------------------------------------------------
@pytest.mark.parametrize(
    ("factory", "message"),
    [
        ("no_such_module:env", "module 'no_such_module' does not import"),
        (f"{TINY}:missing", "has no attribute 'missing'"),
        (f"{TINY}", "allowed: <module>:<callable>"),
        (f"{TINY}:dict_observations", "agent 'blue_0' observes Dict"),
        ("rlhc.envs.tennis:env", "returned an AEC env"),
        (f"{TINY}:multi_discrete_actions", "agent 'red_0' acts in MultiDiscrete"),
    ],
)
def test_a_bad_factory_is_named(factory: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        make_source_env("pettingzoo", num_envs=1, seed=0, factory=factory)


def test_bad_options_are_named() -> None:
    with pytest.raises(ConfigError, match=r"env.kwargs=.*unexpected keyword"):
        tiny(kwargs={"colour": "green"})
    with pytest.raises(ConfigError, match=r"manager_view=state: .* has no state"):
        tiny(kwargs={"with_state": False}, manager_view="state")
    with pytest.raises(ConfigError, match="manager_view='everyone'; allowed: team, world, state"):
        tiny(manager_view="everyone")
    with pytest.raises(ConfigError, match=r"env.groups="):
        tiny(groups=["blue_0"])
    with pytest.raises(ConfigError, match="decision_interval=2 on env=pettingzoo"):
        tiny(decision_interval=2)


def test_an_observation_that_is_not_finite_names_the_agent_and_step() -> None:
    env = tiny(kwargs={"nan_at": 3})
    with pytest.raises(EnvError, match="agent blue_1's observation is NaN or infinite at step 3"):
        env.rollout(5)


def test_an_agent_that_leaves_mid_episode_is_refused() -> None:
    env = tiny(kwargs={"leave_at": 2})
    with pytest.raises(EnvError, match=r"agent red_0 left at step 2 .* did not"):
        env.rollout(5)


def test_a_user_view_of_the_wrong_shape_is_named() -> None:
    with pytest.raises(EnvError, match="wrong_view: for group 'blue' it returned"):
        tiny(manager_view=f"{TINY}:wrong_view")


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("eval_freq=100", "eval_freq=100 on env=pettingzoo: it needs matches against the scr"),
        ("play_freq=100", "play_freq=100 on env=pettingzoo"),
        ("league=mixed", "on env=pettingzoo: it needs opponents other than the learner"),
        ("shaping.scale=0.5", "shaping.scale=0.5 on env='pettingzoo'; allowed: 0, or shaping"),
    ],
)
def test_what_needs_a_built_in_game_is_refused(override: str, message: str) -> None:
    cfg = load("env=pettingzoo", f"env.factory={TINY}:tiny", *SMALL, override)
    with pytest.raises(ConfigError, match=message):
        validate(cfg)


def test_a_bad_factory_on_the_command_line_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from cli_runs import run_in_process

    outcome = run_in_process(
        ["env=pettingzoo", "env.factory=nowhere:env", f"hydra.run.dir={tmp_path / 'run'}"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert outcome.code == 2
    assert outcome.stderr.strip().splitlines() == [
        "rlhc.run: error: env.factory='nowhere:env': module 'nowhere' does not import "
        "(ModuleNotFoundError: No module named 'nowhere')"
    ]
    assert not (tmp_path / "run").exists()


def test_rlhc_evaluate_refuses_a_generic_env() -> None:
    from rlhc.config.evaluate_schema import EvaluateConfig
    from rlhc.config.validation import validate_evaluate
    from rlhc.envs.schemas import VmasEnvConfig

    with pytest.raises(
        ConfigError,
        match=r"env=vmas: rlhc.evaluate plays matches.*python -m rlhc.evaluation.returns",
    ):
        validate_evaluate(EvaluateConfig(env=VmasEnvConfig(scenario="navigation")))


# --- VMAS (the envs extra) -----------------------------------------------------------------
def test_a_vmas_scenario_meets_the_contract() -> None:
    pytest.importorskip("vmas")
    env = make_env("vmas", num_envs=3, seed=0, scenario="navigation", max_cycles=4)
    check_env_specs(env)
    rollout = env.rollout(6, break_when_any_done=False)
    assert rollout[NEXT, "agents", MANAGER_OBSERVATION].shape == (3, 6, 4, 4 * 18)
    assert rollout[NEXT, "truncated"][0].flatten().tolist() == [0, 0, 0, 1, 0, 0]
    # VMAS's numeric infos become events, summed over the group's agents.
    assert ("next", "info", "agents_pos_rew") in rollout.keys(include_nested=True)


def test_vmas_refuses_a_state_view_and_an_unknown_scenario() -> None:
    pytest.importorskip("vmas")
    with pytest.raises(ConfigError, match="VMAS scenarios have no global state"):
        make_env("vmas", scenario="navigation", manager_view="state")
    with pytest.raises(ConfigError, match=r"env.scenario='curling'; allowed: one of"):
        make_env("vmas", scenario="curling")


#: The peer check's tasks (benchmarks/peer_check.py): source, its option, what it needs.
TASKS = {
    "navigation": ("vmas", "env.scenario=navigation", "vmas"),
    "balance": ("vmas", "env.scenario=balance", "vmas"),
    "simple_spread": ("pettingzoo", "env.factory=mpe2.simple_spread_v3:parallel_env", "mpe2"),
    "simple_tag": ("pettingzoo", "env.factory=mpe2.simple_tag_v3:parallel_env", "mpe2"),
}
#: One update of a few seconds on any of them (multiples of every group size up to 6).
ONE_UPDATE = [
    *(s for s in SMALL if not s.startswith(("algo.buffer_size", "algo.batch_size", "algo.max"))),
    "algo.buffer_size=240",
    "algo.batch_size=120",
    "algo.max_steps=1",
    "env.num_envs=4",
]


@pytest.mark.parametrize("critic", [*CRITICS, "manager env.manager_view=world"])
@pytest.mark.parametrize("task", list(TASKS))
def test_every_critic_trains_on_every_named_task(task: str, critic: str, tmp_path: Path) -> None:
    source, option, package = TASKS[task]
    pytest.importorskip(package)
    from rlhc.training.trainer import Trainer

    cfg = load(f"env={source}", option, *f"critic={critic}".split(), *ONE_UPDATE)
    validate(cfg)
    metrics = Trainer(cfg, tmp_path).train()
    losses = [value for key, value in metrics.items() if key.endswith("/loss_objective")]
    assert losses and all(torch.isfinite(torch.tensor(losses)))
    assert metrics["frames"] == Layout.from_config(cfg).frames_per_batch


def test_a_vmas_run_resumes_and_plots(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("vmas")
    from cli_runs import run_in_process, steps

    from rlhc import plot

    run_dir = tmp_path / "run"
    small = [s for s in ONE_UPDATE if not s.startswith(("algo.max_steps", "logger.summary"))]
    args = ["env=vmas", "env.scenario=navigation", *small, "logger.summary_freq=60"]
    args.append(f"hydra.run.dir={run_dir}")
    assert run_in_process([*args, "algo.max_steps=60"], tmp_path, monkeypatch, capsys).code == 0
    resumed = [*args, "algo.max_steps=120", f"resume={run_dir}"]
    assert run_in_process(resumed, tmp_path, monkeypatch, capsys).code == 0
    assert steps(run_dir) == [60, 120]
    plot.main([str(run_dir), "--out", str(tmp_path / "curves.png")])
    assert (tmp_path / "curves.png").stat().st_size > 0
