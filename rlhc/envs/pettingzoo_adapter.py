"""A PettingZoo ``ParallelEnv`` over a one-world :class:`~rlhc.envs.base.BatchedGame`.

For users, the PettingZoo test suite and rendering; training uses the batched
TorchRL adapter instead (one Python round-trip per world-step here).

| PettingZoo | from the game |
|---|---|
| ``observations[agent]`` | the worker observation, ``float32 [d_w]`` |
| ``infos[agent]["manager_observation"]`` | the manager observation, ``float32 [d_m]`` |
| ``infos[agent]["team"]`` | the agent's team (0 or 1) |
| ``infos[agent]["scoring_team"]`` | the team that won the point/goal this step, -1 if none (-1 at reset) |
| ``action_space(agent)`` | ``Box(low, high, (size,))`` (clipped) or ``Discrete(n)`` |
| ``state()`` / ``state_space`` | the full world, absolute frame |

All agents end together (a point or goal ends the episode), after which
``agents`` is empty until the next ``reset``.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from rlhc.envs.base import BatchedGame, ContinuousAction, GroupSpec
from rlhc.envs.keys import MANAGER_OBSERVATION, SCORING_TEAM, TEAM


class BatchedGameParallelEnv(ParallelEnv):
    """PettingZoo parallel API over world 0 of ``game`` (which must have one world).

    Args:
        game: a :class:`BatchedGame` with ``num_worlds == 1``.
        render_mode: ``None`` or ``"rgb_array"``.

    Examples:
        >>> from rlhc.envs import make_game
        >>> env = BatchedGameParallelEnv(make_game("tennis", seed=0))
        >>> observations, infos = env.reset(seed=0)
        >>> observations["racket_0"].shape, infos["racket_0"]["manager_observation"].shape
        ((8,), (10,))
    """

    def __init__(self, game: BatchedGame, render_mode: str | None = None) -> None:
        if game.num_worlds != 1:
            raise ValueError(f"a PettingZoo env wraps one world, got num_worlds={game.num_worlds}")
        # "human" shows the game's rgb frames in a matplotlib window.
        render_modes = [*game.metadata.get("render_modes", ["rgb_array"]), "human"]  # type: ignore[misc]
        if render_mode is not None and render_mode not in render_modes:
            raise ValueError(f"render_mode {render_mode!r} is not one of {render_modes}")
        self.game = game
        self.render_mode = render_mode
        self._figure: Any = None
        self._image: Any = None
        self.metadata = {
            "name": f"rlhc_{game.name}_v0",
            "render_modes": render_modes,
            "render_fps": game.metadata.get("render_fps", 30),
            "is_parallelizable": True,
        }
        self.possible_agents = list(game.agents)
        self.agents: list[str] = []
        # agent -> (group spec, index within the group)
        self._where: dict[str, tuple[GroupSpec, int]] = {
            agent: (spec, i) for spec in game.groups for i, agent in enumerate(spec.agents)
        }
        self.state_space = spaces.Box(
            -np.inf, np.inf, shape=game.state().shape[1:], dtype=np.float32
        )

    # --- spaces --------------------------------------------------------------------------
    @functools.cache  # noqa: B019 - one env, a handful of agents: the cache is the point
    def observation_space(self, agent: str) -> spaces.Space:
        spec, _ = self._locate(agent)
        return spaces.Box(-np.inf, np.inf, shape=(spec.observation_size,), dtype=np.float32)

    @functools.cache  # noqa: B019
    def action_space(self, agent: str) -> spaces.Space:
        spec, _ = self._locate(agent)
        if isinstance(spec.action, ContinuousAction):
            return spaces.Box(
                spec.action.low, spec.action.high, shape=(spec.action.size,), dtype=np.float32
            )
        return spaces.Discrete(spec.action.n)

    # --- API -----------------------------------------------------------------------------
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        if seed is not None:
            self.game.seed(seed)
        self.game.reset()
        self.agents = list(self.possible_agents)
        observations, infos = self._observe()
        return observations, infos

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        dict[str, np.ndarray],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        unknown = sorted(set(actions) - set(self.possible_agents))
        if unknown:
            raise ValueError(f"unknown agent(s) {unknown}; agents are {self.possible_agents}")
        missing = sorted(set(self.agents) - set(actions))
        if missing:
            raise ValueError(f"missing actions for live agent(s) {missing}")
        if not self.agents:
            raise ValueError("the episode is over: call reset() before step()")
        batched = {}
        for spec in self.game.groups:
            if isinstance(spec.action, ContinuousAction):
                rows = [np.asarray(actions[agent], dtype=np.float64) for agent in spec.agents]
                for agent, row in zip(spec.agents, rows, strict=True):
                    if row.shape != (spec.action.size,):
                        raise ValueError(
                            f"action of {agent!r} has shape {row.shape}; expected ({spec.action.size},)"
                        )
            else:
                rows = [np.asarray(actions[agent]).reshape(()) for agent in spec.agents]
            batched[spec.name] = np.stack(rows)[None]
        outcome = self.game.step(batched)
        terminated = bool(outcome.terminated[0])
        truncated = bool(outcome.truncated[0])
        rewards = {
            agent: float(outcome.rewards[spec.name][0, i])
            for agent, (spec, i) in self._where.items()
        }
        observations, infos = self._observe(int(outcome.scoring_team[0]))
        terminations = dict.fromkeys(self.agents, terminated)
        truncations = dict.fromkeys(self.agents, truncated)
        if terminated or truncated:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def state(self) -> np.ndarray:
        return self.game.state()[0]

    def render(self) -> np.ndarray | None:
        """The frame (``rgb_array``), or ``None`` after drawing it in a window (``human``)."""
        if self.render_mode is None:
            return None
        frame = self.game.render(0)
        if self.render_mode == "rgb_array":
            return frame
        import matplotlib.pyplot as plt

        if self._figure is None:
            self._figure, axes = plt.subplots()
            axes.set_axis_off()
            self._image = axes.imshow(frame)
        else:
            self._image.set_data(frame)
        self._figure.canvas.draw_idle()
        self._figure.canvas.flush_events()
        return None

    def close(self) -> None:
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None

    # --- helpers -------------------------------------------------------------------------
    def _locate(self, agent: str) -> tuple[GroupSpec, int]:
        if agent not in self._where:
            raise ValueError(f"unknown agent {agent!r}; agents are {self.possible_agents}")
        return self._where[agent]

    def _observe(
        self, scoring_team: int = -1
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Observations and infos; the info keys are the same at reset and at every step
        (wrappers such as TorchRL's ``PettingZooWrapper`` size their specs from reset)."""
        group_observations = self.game.observe()
        observations: dict[str, np.ndarray] = {}
        infos: dict[str, dict[str, Any]] = {}
        for agent, (spec, i) in self._where.items():
            seen = group_observations[spec.name]
            observations[agent] = seen.observation[0, i].copy()
            infos[agent] = {
                MANAGER_OBSERVATION: seen.manager_observation[0, i].copy(),
                TEAM: spec.teams[i],
                SCORING_TEAM: scoring_team,
            }
        return observations, infos
