"""A league of opponents: who the learning team plays in each world (beyond the paper).

Pure self-play (the paper's) can settle into a joint habit (in soccer: neither team
scores), hence ML-Agents' later *ghost* trainer. Here fixed shares of the worlds play
the learner against a past ``snapshot`` of itself, the ``scripted`` team or ``random``
actions (:data:`KINDS`); only the learner's experiences train (every loss term is
weighted by the ``(g, "learner")`` mask of :class:`LeaguePolicy`), and every result
updates the Elo ratings (:mod:`rlhc.evaluation.elo`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, exploration_type

from rlhc.config.train_schema import LeagueConfig
from rlhc.envs.keys import ACTION, DONE, LEARNER, NEXT, OBSERVATION, SCORING_TEAM, STEP_COUNT, TEAM
from rlhc.envs.torchrl_adapter import BatchedGameEnv, batched_game_env
from rlhc.evaluation.elo import INITIAL_RATING, K_FACTOR, elo_update, expected_score
from rlhc.evaluation.teams import RandomPolicy, ScriptedPolicy, TeamPolicy
from rlhc.modules.policies import actor_parts, draw_action

KINDS = ("self", "snapshot", "scripted", "random")
#: Root keys the league policy writes at every step (stored by the collector).
OPPONENT = "league_opponent"
LEARNER_TEAM = "league_learner_team"
#: Opponent ids of the built-in teams (snapshots count up from 0; self-play is -1).
SELF_ID, SCRIPTED_ID, RANDOM_ID = -1, -2, -3


def allocate_worlds(shares: Mapping[str, float], num_worlds: int) -> np.ndarray:
    """Each world's kind (an index into :data:`KINDS`): ``round(share × worlds)`` of each,
    by largest remainder.

    Examples:
        >>> allocate_worlds({"self": 0.5, "snapshot": 0.25, "scripted": 0.25, "random": 0}, 8)
        array([0, 0, 0, 0, 1, 1, 2, 2])
    """
    unknown = sorted(set(shares) - set(KINDS))
    if unknown:
        raise ValueError(f"unknown opponent kind(s) {unknown}; allowed: {', '.join(KINDS)}")
    quotas = np.array([shares.get(kind, 0.0) * num_worlds for kind in KINDS])
    counts = np.floor(quotas).astype(np.int64)
    order = np.argsort(-(quotas - counts), kind="stable")
    counts[order[: num_worlds - counts.sum()]] += 1
    return np.repeat(np.arange(len(KINDS)), counts)


@dataclass
class Snapshot:
    """A frozen past learner: its actors' weights and its Elo rating."""

    id: int
    actors: dict[str, dict[str, torch.Tensor]]
    rating: float


class League:
    """The opponents of the learner in each of ``num_worlds`` worlds, with their ratings;
    ``seed`` seeds the snapshot draws."""

    def __init__(self, cfg: LeagueConfig, num_worlds: int, seed: int) -> None:
        self.cfg = cfg
        self.kinds = allocate_worlds(cfg.shares, num_worlds)
        is_league = self.kinds != KINDS.index("self")
        # League worlds alternate the learner's side.
        self.learner_team = np.where(is_league, np.cumsum(is_league) % 2, -1)
        fixed = {KINDS.index("scripted"): SCRIPTED_ID, KINDS.index("random"): RANDOM_ID}
        self.opponent = np.array([fixed.get(int(k), SELF_ID) for k in self.kinds])
        self.rng = np.random.default_rng(seed)
        self.pool: list[Snapshot] = []
        self.next_id = 0
        self.rating = INITIAL_RATING
        self.built_in_ratings = {SCRIPTED_ID: INITIAL_RATING, RANDOM_ID: INITIAL_RATING}
        self.results: list[tuple[int, float]] = []  # (opponent id, learner score) since last log

    # --- the pool ----------------------------------------------------------------------
    def add_snapshot(self, actors: Mapping[str, torch.nn.Module]) -> None:
        """Freeze the learner's actors into the pool, dropping the oldest snapshot (whose
        worlds draw another one at once)."""
        weights = {g: copy.deepcopy(actor.state_dict()) for g, actor in actors.items()}
        self.pool.append(Snapshot(self.next_id, weights, self.rating))
        self.next_id += 1
        del self.pool[: -self.cfg.pool_size]
        kept = {s.id for s in self.pool}
        orphaned = (self.opponent >= 0) & ~np.isin(self.opponent, list(kept))
        self.draw(np.flatnonzero(orphaned))

    def draw(self, worlds: np.ndarray) -> None:
        """New opponents for the snapshot ``worlds`` whose episode starts (the learner
        itself while the pool is empty)."""
        if len(worlds) == 0:
            return
        if not self.pool:
            self.opponent[worlds] = SELF_ID
            return
        if self.cfg.sampling == "elo":
            weights = np.array([expected_score(s.rating, self.rating) for s in self.pool])
            probabilities = weights / weights.sum()
        else:
            probabilities = np.full(len(self.pool), 1.0 / len(self.pool))
        chosen = self.rng.choice(len(self.pool), size=len(worlds), p=probabilities)
        self.opponent[worlds] = [self.pool[i].id for i in chosen]

    # --- results and ratings -----------------------------------------------------------
    def record(self, opponents: np.ndarray, scores: np.ndarray) -> None:
        """Episode results against league opponents: ``scores`` 1 win, 0.5 draw, 0 loss."""
        for opponent, score in zip(opponents.tolist(), scores.tolist(), strict=True):
            if opponent == SELF_ID:
                continue
            if opponent in self.built_in_ratings:
                self.rating, self.built_in_ratings[opponent] = elo_update(
                    self.rating, self.built_in_ratings[opponent], score, K_FACTOR
                )
            else:
                found = [s for s in self.pool if s.id == opponent]
                if not found:  # dropped from the pool during the episode
                    continue
                self.rating, found[0].rating = elo_update(
                    self.rating, found[0].rating, score, K_FACTOR
                )
            self.results.append((opponent, score))

    def record_batch(self, batch: TensorDictBase, gather: Callable[[Any], list[Any]]) -> None:
        """:meth:`record` the episodes that ended in a ``batch`` of :class:`LeaguePolicy`,
        of every process (``gather``: every process's value in rank order)."""
        opponents, scores = zip(*gather(episode_results(batch)), strict=True)
        self.record(np.concatenate(opponents), np.concatenate(scores))

    def metrics(self) -> dict[str, float]:
        """Ratings and the learner's mean score per opponent kind since the last call."""
        out = {
            "league/elo": self.rating,
            "league/elo_scripted": self.built_in_ratings[SCRIPTED_ID],
            "league/elo_random": self.built_in_ratings[RANDOM_ID],
            "league/pool_size": float(len(self.pool)),
        }
        if self.pool:
            out["league/elo_pool_mean"] = float(np.mean([s.rating for s in self.pool]))
        names = {SCRIPTED_ID: "scripted", RANDOM_ID: "random"}
        by_kind: dict[str, list[float]] = {}
        for opponent, score in self.results:
            by_kind.setdefault(names.get(opponent, "snapshot"), []).append(score)
        for kind, scores in by_kind.items():
            out[f"league/score_vs_{kind}"] = float(np.mean(scores))
            out[f"league/episodes_vs_{kind}"] = float(len(scores))
        self.results.clear()
        return out

    # --- checkpoints -------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        return {
            "pool": [(s.id, s.actors, s.rating) for s in self.pool],
            "next_id": self.next_id,
            "rating": self.rating,
            "built_in_ratings": dict(self.built_in_ratings),
            "opponent": self.opponent.copy(),
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        self.pool = [Snapshot(i, actors, rating) for i, actors, rating in state["pool"]]
        self.next_id = int(state["next_id"])
        self.rating = float(state["rating"])
        self.built_in_ratings = {int(k): float(v) for k, v in state["built_in_ratings"].items()}
        if len(state["opponent"]) == len(self.opponent):
            self.opponent = np.asarray(state["opponent"]).copy()
        self.rng.bit_generator.state = state["rng"]


def episode_results(batch: TensorDictBase) -> tuple[np.ndarray, np.ndarray]:
    """``(opponent ids, learner scores)`` of the episodes that ended in a ``batch`` of
    :class:`LeaguePolicy`, self-play worlds included; 1 a win, 0.5 a draw, 0 a loss."""
    done = batch[NEXT, DONE].squeeze(-1)
    opponent = batch[OPPONENT].squeeze(-1)[done].cpu().numpy()
    learner_team = batch[LEARNER_TEAM].squeeze(-1)[done].cpu().numpy()
    scoring = batch[NEXT, SCORING_TEAM].squeeze(-1)[done].cpu().numpy()
    scores = np.where(scoring < 0, 0.5, (scoring == learner_team).astype(float))
    return opponent, scores


class LeaguePolicy(TensorDictModuleBase):
    """The collection policy: the learner everywhere, opponents where the league says.

    Runs the learner on every agent, then in each league world overwrites the opponent
    team's actions with its opponent's, and writes ``(g, "learner")`` (``bool [N, n_g, 1]``:
    the learner chose this action), :data:`OPPONENT` and :data:`LEARNER_TEAM` (``[N, 1]``).

    Args:
        learner: the learning policy (all groups).
        league: the league of this env.
        env: the training env (the scripted team reads its game).
        make_actor: builds an empty actor of a group (to load snapshot weights into).

    Raises:
        TypeError: ``env`` is not over a :class:`~rlhc.envs.torchrl_adapter.BatchedGameEnv`.
    """

    def __init__(
        self,
        learner: TensorDictModuleBase,
        league: League,
        env: EnvBase,
        make_actor: Callable[[str], TensorDictModuleBase],
    ) -> None:
        super().__init__()
        game_env = batched_game_env(env)
        if game_env is None:
            raise TypeError(
                f"a league needs the batched game env of rlhc.envs.make_env (the scripted "
                f"team reads its game), got {type(env).__name__}"
            )
        self.learner = learner
        self.league = league
        self.game_env: BatchedGameEnv = game_env
        self.groups = game_env.group_names
        self.in_keys = list(learner.in_keys) + [(g, TEAM) for g in self.groups] + [STEP_COUNT]
        self.out_keys = (
            list(learner.out_keys) + [(g, LEARNER) for g in self.groups] + [OPPONENT, LEARNER_TEAM]
        )
        self.scripted: TeamPolicy = ScriptedPolicy(game_env)
        self.random: TeamPolicy = RandomPolicy(game_env)
        self.frozen = {g: make_actor(g).requires_grad_(False).eval() for g in self.groups}
        self._parts = {g: actor_parts(actor) for g, actor in self.frozen.items()}
        self._loaded: dict[str, int] = {}

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        league = self.league
        starting = tensordict[STEP_COUNT].view(-1).cpu().numpy() == 0
        league.draw(np.flatnonzero(starting & (league.kinds == KINDS.index("snapshot"))))
        tensordict = self.learner(tensordict)
        n = len(league.opponent)
        device = tensordict.device
        opponent = torch.as_tensor(league.opponent, dtype=torch.int64, device=device)
        learner_team = torch.as_tensor(league.learner_team, dtype=torch.int64, device=device)
        actions = self._opponent_actions(tensordict, opponent)
        for group in self.groups:
            team = tensordict[group, TEAM]  # [N, n_g, 1]
            # The learner chose the action unless an opponent plays this agent's team.
            is_opponent = (opponent != SELF_ID).view(n, 1, 1) & (team != learner_team.view(n, 1, 1))
            if group in actions:
                action = tensordict[group, ACTION]
                mask = is_opponent.view(*is_opponent.shape[:2], *([1] * (action.dim() - 2)))
                replaced = torch.where(mask, actions[group].to(action.dtype), action)
                tensordict.set((group, ACTION), replaced)
            tensordict.set((group, LEARNER), ~is_opponent)
        tensordict.set(OPPONENT, opponent.view(n, 1))
        tensordict.set(LEARNER_TEAM, learner_team.view(n, 1))
        return tensordict

    def _opponent_actions(
        self, tensordict: TensorDictBase, opponent: torch.Tensor
    ) -> dict[str, torch.Tensor]:
        """Actions of every agent under each opponent present, merged per world."""
        present = sorted(set(opponent.tolist()) - {SELF_ID})
        if not present:
            return {}
        merged = {g: tensordict[g, ACTION].clone() for g in self.groups}
        with torch.no_grad():
            for opponent_id in present:
                if opponent_id == SCRIPTED_ID:
                    actions = self.scripted(self._raw(tensordict))
                elif opponent_id == RANDOM_ID:
                    actions = self.random(tensordict)
                else:
                    actions = self._snapshot_actions(tensordict, opponent_id)
                worlds = opponent == opponent_id
                for group, action in actions.items():
                    # The built-in teams act on the game's device (CPU).
                    merged[group][worlds] = action.to(merged[group])[worlds]
        return merged

    def _raw(self, tensordict: TensorDictBase) -> TensorDictBase:
        """The game's current, unnormalised observations (what the scripted team reads)."""
        raw = tensordict.empty()
        for group, observation in self.game_env.worker_observations().items():
            raw.set((group, OBSERVATION), observation)
        return raw

    def _snapshot_actions(
        self, tensordict: TensorDictBase, snapshot_id: int
    ) -> dict[str, torch.Tensor]:
        snapshot = next(s for s in self.league.pool if s.id == snapshot_id)
        out = {}
        for group, actor in self.frozen.items():
            if self._loaded.get(group) != snapshot_id:
                actor.load_state_dict(snapshot.actors[group])
                self._loaded[group] = snapshot_id
            if exploration_type() is ExplorationType.RANDOM:  # as the actor draws, on tensors
                drawn = draw_action(self._parts[group], tensordict, log_prob=False)
                out[group] = drawn[group, ACTION]
            else:
                inputs = tensordict.select(*actor.in_keys).clone(recurse=False)
                out[group] = actor(inputs)[group, ACTION]
        return out
