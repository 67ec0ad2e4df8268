"""A TorchRL ``EnvBase`` over any :class:`~rlhc.envs.base.BatchedGame` (the training path).

The env has ``batch_size=[N]`` (one entry per simulated world) and follows the
TensorDict contract below (the key names are defined in :mod:`rlhc.envs.keys`); for
each group ``g`` with ``n_g`` agents:

| key | spec | shape |
|---|---|---|
| ``(g, "observation")`` | ``Unbounded`` float32 | ``[N, n_g, d_w]`` |
| ``(g, "manager_observation")`` | ``Unbounded`` float32 | ``[N, n_g, d_m]`` |
| ``(g, "team")`` | ``Bounded`` int64 in {0, 1} | ``[N, n_g, 1]`` |
| ``(g, "action")`` | ``Bounded`` [-1, 1] float32 (continuous) or ``Categorical`` int64 (discrete) | ``[N, n_g, size]`` or ``[N, n_g]`` |
| ``("next", g, "reward")`` | ``Unbounded`` float32 | ``[N, n_g, 1]`` |
| ``(g, "done" / "terminated" / "truncated")`` | bool | ``[N, n_g, 1]`` |
| ``"done" / "terminated" / "truncated"`` | bool | ``[N, 1]`` |
| ``"step_count"`` | int64, steps of the episode before this observation (0 at reset) | ``[N, 1]`` |
| ``"scoring_team"`` | int64, the team that scored on the step that led here, -1 if none | ``[N, 1]`` |
| ``("info", k)`` | float32, each of the game's ``published_info`` entries (0 at reset) | ``[N, *shape]`` |

All agents of a world end together, so the per-agent done flags equal the root
ones and the root ``"_reset"`` mask is the only reset key needed for partial
resets. Arrays cross from numpy with ``torch.from_numpy`` (no copy) and there is no
per-world Python loop: the game steps all worlds at once.

This is the only module of :mod:`rlhc.envs` that imports torch.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase, TransformedEnv

from rlhc.envs.base import BatchedGame, ContinuousAction, DiscreteAction
from rlhc.envs.keys import (
    ACTION,
    DONE,
    DONE_KEYS,
    INFO,
    MANAGER_OBSERVATION,
    OBSERVATION,
    RESET,
    REWARD,
    SCORING_TEAM,
    STEP_COUNT,
    TEAM,
    TERMINATED,
    TRUNCATED,
)


class BatchedGameEnv(EnvBase):
    """TorchRL view of a numpy :class:`BatchedGame` with ``batch_size=[game.num_worlds]``.

    Args:
        game: the game (any :class:`BatchedGame`); the env owns it from now on.
        device: torch device of the returned tensors.

    Examples:
        >>> from rlhc.envs import make_game
        >>> from torchrl.envs.utils import check_env_specs
        >>> env = BatchedGameEnv(make_game("tennis", num_envs=4, seed=0))
        >>> check_env_specs(env)
        >>> td = env.rollout(5, break_when_any_done=False)
        >>> td["next", "racket", "reward"].shape
        torch.Size([4, 5, 4, 1])
    """

    def __init__(self, game: BatchedGame, device: str | torch.device = "cpu") -> None:
        super().__init__(device=device, batch_size=torch.Size([game.num_worlds]))
        self.game = game
        n = game.num_worlds
        self._teams = {
            spec.name: torch.tensor(spec.teams, dtype=torch.int64).view(1, -1, 1).expand(n, -1, 1)
            for spec in game.groups
        }
        self._make_specs()

    # --- the game's state, for trainers and opponents -----------------------------------
    @property
    def group_names(self) -> list[str]:
        """The game's agent groups, in its order (e.g. ``["striker", "goalie"]``)."""
        return [spec.name for spec in self.game.groups]

    @property
    def game_rng_state(self) -> Mapping[str, Any]:
        """The state of the game's random generator (numpy ``bit_generator.state``).

        What a checkpoint stores so that a resumed run draws the same resets.

        Examples:
            >>> from rlhc.envs import make_game
            >>> env = BatchedGameEnv(make_game("soccer", num_envs=2, seed=0))
            >>> state = env.game_rng_state
            >>> first = env.reset()
            >>> env.set_game_rng_state(state)
            >>> bool((env.reset()["striker", "observation"] == first["striker", "observation"]).all())
            True
        """
        return self.game.rng.bit_generator.state

    def set_game_rng_state(self, state: Mapping[str, Any]) -> None:
        """Restore a state of :attr:`game_rng_state`."""
        self.game.rng.bit_generator.state = state

    def worker_observations(self) -> dict[str, torch.Tensor]:
        """Every group's current worker observations as the game computes them.

        ``group -> float32 [N, n_g, d_w]``, untouched by any transform of the env
        (e.g. observation normalisation): what a scripted team reads.
        """
        return {
            group: torch.from_numpy(observed.observation)
            for group, observed in self.game.observe().items()
        }

    # --- specs -------------------------------------------------------------------------
    def _make_specs(self) -> None:
        game = self.game
        n = game.num_worlds
        observation, action, reward, done = {}, {}, {}, {}
        for spec in game.groups:
            k = spec.num_agents
            observation[spec.name] = Composite(
                {
                    OBSERVATION: Unbounded((n, k, spec.observation_size), dtype=torch.float32),
                    MANAGER_OBSERVATION: Unbounded(
                        (n, k, spec.manager_observation_size), dtype=torch.float32
                    ),
                    TEAM: Bounded(0, 1, (n, k, 1), dtype=torch.int64),
                },
                shape=(n, k),
            )
            if isinstance(spec.action, ContinuousAction):
                leaf: Bounded | Categorical = Bounded(
                    spec.action.low,
                    spec.action.high,
                    (n, k, spec.action.size),
                    dtype=torch.float32,
                )
            elif isinstance(spec.action, DiscreteAction):
                leaf = Categorical(spec.action.n, (n, k), dtype=torch.int64)
            else:  # pragma: no cover - the ActionSpace union is closed
                raise TypeError(f"unsupported action space {spec.action!r}")
            action[spec.name] = Composite({ACTION: leaf}, shape=(n, k))
            reward[spec.name] = Composite(
                {REWARD: Unbounded((n, k, 1), dtype=torch.float32)}, shape=(n, k)
            )
            done[spec.name] = Composite(
                {key: Categorical(2, (n, k, 1), dtype=torch.bool) for key in DONE_KEYS},
                shape=(n, k),
            )
        if game.published_info:
            observation[INFO] = Composite(
                {
                    key: Unbounded((n, *shape), dtype=torch.float32)
                    for key, shape in game.published_info.items()
                },
                shape=(n,),
            )
        observation[STEP_COUNT] = Bounded(0, game.max_cycles, (n, 1), dtype=torch.int64)
        observation[SCORING_TEAM] = Bounded(-1, 1, (n, 1), dtype=torch.int64)
        for key in DONE_KEYS:
            done[key] = Categorical(2, (n, 1), dtype=torch.bool)
        self.observation_spec = Composite(observation, shape=(n,), device=self.device)
        self.action_spec = Composite(action, shape=(n,), device=self.device)
        self.reward_spec = Composite(reward, shape=(n,), device=self.device)
        self.done_spec = Composite(done, shape=(n,), device=self.device)

    # --- EnvBase hooks -----------------------------------------------------------------
    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: object) -> TensorDictBase:
        mask = None
        if tensordict is not None and RESET in tensordict:
            mask = tensordict.get(RESET).reshape(self.game.num_worlds).cpu().numpy()
        self.game.reset(mask)
        n = self.game.num_worlds
        no = torch.zeros(n, dtype=torch.bool)
        return self._output(no, no, np.full(n, -1, dtype=np.int64), rewards=None, info=None)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        actions = {}
        for spec in self.game.groups:
            action = tensordict.get((spec.name, ACTION), None)
            if action is None:
                raise ValueError(f"missing {(spec.name, ACTION)!r} in the input tensordict")
            actions[spec.name] = action.detach().cpu().numpy()
        outcome = self.game.step(actions)
        return self._output(
            torch.from_numpy(outcome.terminated),
            torch.from_numpy(outcome.truncated),
            outcome.scoring_team,
            rewards=outcome.rewards,
            info=outcome.info,
        )

    def _set_seed(self, seed: int | None) -> None:
        self.game.seed(seed)

    # --- helpers -----------------------------------------------------------------------
    def _output(
        self,
        terminated: torch.Tensor,
        truncated: torch.Tensor,
        scoring_team: np.ndarray,
        rewards: dict[str, np.ndarray] | None,
        info: dict[str, np.ndarray] | None,
    ) -> TensorDictBase:
        """The TensorDict of one reset or step (observations, dones, rewards)."""
        n = self.game.num_worlds
        terminated = terminated.view(n, 1)
        truncated = truncated.view(n, 1)
        done = terminated | truncated
        flags = {DONE: done, TERMINATED: terminated, TRUNCATED: truncated}
        out: dict[str, object] = dict(flags)
        observations = self.game.observe()
        for spec in self.game.groups:
            k = spec.num_agents
            group_observation = observations[spec.name]
            entry: dict[str, torch.Tensor] = {
                OBSERVATION: torch.from_numpy(group_observation.observation),
                MANAGER_OBSERVATION: torch.from_numpy(group_observation.manager_observation),
                TEAM: self._teams[spec.name].clone(),
            }
            for key, flag in flags.items():
                entry[key] = flag.unsqueeze(1).expand(n, k, 1).clone()
            if rewards is not None:
                entry[REWARD] = torch.from_numpy(
                    np.ascontiguousarray(rewards[spec.name], dtype=np.float32)
                ).unsqueeze(-1)
            out[spec.name] = TensorDict(entry, batch_size=(n, k))
        out[STEP_COUNT] = torch.from_numpy(self.game.step_count.copy()).view(n, 1)
        out[SCORING_TEAM] = torch.from_numpy(scoring_team.astype(np.int64, copy=False)).view(n, 1)
        if self.game.published_info:
            out[INFO] = TensorDict(
                {
                    key: torch.zeros((n, *shape))
                    if info is None
                    else torch.from_numpy(
                        np.asarray(info[key], dtype=np.float32).reshape(n, *shape)
                    )
                    for key, shape in self.game.published_info.items()
                },
                batch_size=(n,),
            )
        result = TensorDict(out, batch_size=(n,))
        return result if self.device == torch.device("cpu") else result.to(self.device)


def batched_game_env(env: EnvBase) -> BatchedGameEnv | None:
    """``env`` itself, or the env under its transforms, if that is a :class:`BatchedGameEnv`.

    ``None`` for an env of another kind (e.g. TorchRL's ``PettingZooWrapper`` route).

    Examples:
        >>> from rlhc.envs import make_env
        >>> batched_game_env(make_env("tennis", num_envs=1, seed=0)).group_names
        ['racket']
    """
    base = env.base_env if isinstance(env, TransformedEnv) else env
    return base if isinstance(base, BatchedGameEnv) else None
