"""Tiny hand-written PettingZoo ``ParallelEnv``\\ s for the generic environment path
(``env=pettingzoo env.factory=tests.envs.tiny_envs:<name>``): each breaks, or keeps, one
rule of :mod:`rlhc.envs.generic` on purpose."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv


class Tiny(ParallelEnv):
    """Two groups, ``blue`` (2 agents, 3 actions) and ``red`` (1 agent, a 2-D box): each
    agent observes a 4-vector that drifts with its actions; rewards favour moving right.

    Args:
        episode: steps per episode (all agents truncated together).
        nan_at: the step at which ``blue_1`` observes NaN (``None``: never).
        leave_at: the step at which ``red_0`` terminates alone (``None``: never).
        with_state: give a global ``state()``.
        render_mode: ``"rgb_array"``: ``render()`` draws each agent's first two coordinates
            as a pixel of an 8 x 8 image; ``None``: it draws nothing.
    """

    metadata: ClassVar[dict[str, str]] = {"name": "tiny_v0"}

    def __init__(
        self,
        episode: int = 8,
        nan_at: int | None = None,
        leave_at: int | None = None,
        with_state: bool = True,
        render_mode: str | None = None,
    ) -> None:
        self.render_mode = render_mode
        self.possible_agents = ["blue_0", "blue_1", "red_0"]
        self.episode, self.nan_at, self.leave_at = episode, nan_at, leave_at
        self._observation = spaces.Box(-10.0, 10.0, (4,), np.float32)
        self._actions = {
            "blue_0": spaces.Discrete(3),
            "blue_1": spaces.Discrete(3),
            "red_0": spaces.Box(-1.0, 1.0, (2,), np.float32),
        }
        if with_state:
            self.state_space = spaces.Box(-10.0, 10.0, (12,), np.float32)
        self.rng = np.random.default_rng(0)

    def observation_space(self, agent: str) -> spaces.Space:
        return self._observation

    def action_space(self, agent: str) -> spaces.Space:
        return self._actions[agent]

    def state(self) -> np.ndarray:
        return np.concatenate([self.positions[a] for a in self.possible_agents])

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        image = np.zeros((8, 8, 3), np.uint8)
        for channel, agent in enumerate(self.possible_agents):
            x, y = np.clip((self.positions[agent][:2] + 1.0) * 4.0, 0, 7).astype(int)
            image[y, x, channel] = 255
        return image

    def reset(self, seed: int | None = None, options: Any = None) -> tuple[dict, dict]:
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.agents = list(self.possible_agents)
        self.t = 0
        self.positions = {
            a: self.rng.uniform(-1, 1, 4).astype(np.float32) for a in self.possible_agents
        }
        return dict(self.positions), {a: {} for a in self.agents}

    def step(self, actions: dict) -> tuple[dict, dict, dict, dict, dict]:
        self.t += 1
        rewards = {}
        for agent, action in actions.items():
            move = float(action) - 1.0 if agent.startswith("blue") else float(np.sum(action))
            self.positions[agent] = np.clip(self.positions[agent] + 0.1 * move, -10, 10).astype(
                np.float32
            )
            rewards[agent] = move
        observations = {a: self.positions[a].copy() for a in self.agents}
        if self.nan_at is not None and self.t == self.nan_at:
            observations["blue_1"][0] = np.nan
        truncated = self.t >= self.episode
        terminations = {a: False for a in self.agents}
        if self.leave_at is not None and self.t == self.leave_at:
            terminations["red_0"] = True
        truncations = {a: truncated for a in self.agents}
        infos = {a: {} for a in self.agents}
        return observations, rewards, terminations, truncations, infos


def tiny(**kwargs: Any) -> Tiny:
    return Tiny(**kwargs)


def dict_observations() -> Tiny:
    """``blue_0`` observes a Dict space: not supported."""
    env = Tiny()
    env._observation = spaces.Dict({"x": spaces.Box(-1.0, 1.0, (2,))})
    return env


def multi_discrete_actions() -> Tiny:
    """``red_0`` acts in a MultiDiscrete space: not supported."""
    env = Tiny()
    env._actions["red_0"] = spaces.MultiDiscrete([2, 2])
    return env


def team_view_sum(observations: dict) -> dict:
    """A user manager view: the sum of the group's observations, for every agent."""
    return {
        group: obs.sum(dim=-2, keepdim=True).expand_as(obs).clone()
        for group, obs in observations.items()
    }


def wrong_view(observations: dict) -> dict:
    """A user manager view that forgets the agents' dimension."""
    return {group: obs.sum(dim=-2) for group, obs in observations.items()}
