"""Head-to-head matches between two team policies, many at once in one batched env.

**Sides.** Match ``i`` puts the *home* policy on team ``i % 2`` (with ``swap_sides``), so
over an even number of matches any asymmetry of the game (serve order, solver order)
cancels. Each world plays its matches one after another; an agent takes the home action
where its ``(g, "team")`` equals its world's ``home_side`` (no Python loop over worlds).

**Scoring.** Every step the env reports ``("next", "scoring_team")`` (``-1``: none). The
first team to ``points_to_win`` points wins; a match still undecided after ``max_steps``
steps is a draw (:func:`default_rules`: soccer, one goal within one episode; tennis,
first to 5 points within 5 rallies of ``max_cycles`` steps).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type, step_mdp

from rlhc.envs import make_env
from rlhc.envs.keys import (
    ACTION,
    DONE,
    ENDED_PREFIX,
    INFO,
    NEXT,
    RESET,
    SCORING_TEAM,
    TEAM,
)
from rlhc.envs.registry import game_spec
from rlhc.envs.torchrl_adapter import BatchedGameEnv
from rlhc.evaluation.opponents import make_team_policy, player_options
from rlhc.evaluation.stats import wilson_interval
from rlhc.evaluation.teams import TeamPolicy

#: Called after the first reset and after every step with the env's current TensorDict,
#: the points ``[K, 2]`` of the running matches (by team) and their steps ``[K]``
#: (used to record videos).
StepCallback = Callable[[TensorDictBase, np.ndarray, np.ndarray], None]


@dataclass(frozen=True)
class MatchRules:
    """When a match ends.

    Attributes:
        points_to_win: the first team to this many points wins.
        max_steps: a match still undecided after this many steps is a draw.
    """

    points_to_win: int
    max_steps: int


def default_rules(
    env_name: str, max_cycles: int, points_to_win: int | None = None, max_steps: int | None = None
) -> MatchRules:
    """The game's match rules (its registry's ``points_to_win``), with optional overrides.

    ``max_steps`` is ``points_to_win × max_cycles`` (the game's episode length) unless given.

    Raises:
        ValueError: an unknown game (the registered ones are listed), or a rule below 1.

    Examples:
        >>> default_rules("tennis", max_cycles=400)
        MatchRules(points_to_win=5, max_steps=2000)
        >>> default_rules("soccer", max_cycles=600)
        MatchRules(points_to_win=1, max_steps=600)
    """
    default = game_spec(env_name).points_to_win
    points = points_to_win if points_to_win is not None else default
    budget = max_steps if max_steps is not None else max_cycles * points
    if points < 1 or budget < 1:
        raise ValueError(f"points_to_win and max_steps must be >= 1, got {points}, {budget}")
    return MatchRules(points, budget)


@dataclass
class MatchResult:
    """Per-match records of a series, from the home policy's point of view.

    :meth:`summary` gives wins, draws and losses with Wilson intervals, the share of points
    won, mean points and length, and the game's per-team events per point (e.g.
    ``hits_over_net_by_team``; ``lost_<how>``: the share of points each side lost that way).

    Attributes:
        home: the home player's name; ``away`` likewise.
        home_side: ``[M]`` the team (0/1) the home policy played in each match.
        home_points: ``[M]`` points of the home side; ``away_points`` likewise.
        steps: ``[M]`` match length in env steps.
        events: per-team event counts of the game, each ``[M, 2]``: home, away.
    """

    home: str
    away: str
    home_side: np.ndarray
    home_points: np.ndarray
    away_points: np.ndarray
    steps: np.ndarray
    events: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def outcomes(self) -> np.ndarray:
        """``[M]``: +1 home win, 0 draw, -1 home loss."""
        return np.sign(self.home_points - self.away_points).astype(np.int64)

    @property
    def scores(self) -> np.ndarray:
        """``[M]`` the home player's Elo score per match: 1, 0.5 or 0."""
        return (self.outcomes + 1) / 2.0

    def summary(self, confidence: float = 0.95) -> dict[str, Any]:
        """Counts, rates with Wilson intervals, mean points and length (JSON-ready)."""
        n = len(self.outcomes)
        wins, draws = int((self.outcomes > 0).sum()), int((self.outcomes == 0).sum())
        losses = n - wins - draws
        summary: dict[str, Any] = {"home": self.home, "away": self.away, "matches": n}
        for name, count in (("wins", wins), ("draws", draws), ("losses", losses)):
            low, high = wilson_interval(count, n, confidence)
            rate = name[:-1] if name != "losses" else "loss"
            summary[name] = count
            summary[f"{rate}_rate"] = count / n if n else math.nan
            summary[f"{rate}_rate_ci"] = [low, high]
        summary["score"] = float(self.scores.mean()) if n else math.nan
        won, played = int(self.home_points.sum()), int((self.home_points + self.away_points).sum())
        summary["points_won_rate"] = won / played if played else math.nan
        summary["points_won_rate_ci"] = list(wilson_interval(won, played, confidence))
        for key, counts in self.events.items():
            summary[f"{key}_per_point"] = {
                side: float(counts[:, column].sum() / played) if played else math.nan
                for column, side in enumerate(("home", "away"))
            }
        summary["home_points_mean"] = float(self.home_points.mean()) if n else math.nan
        summary["away_points_mean"] = float(self.away_points.mean()) if n else math.nan
        summary["length_mean"] = float(self.steps.mean()) if n else math.nan
        summary["confidence"] = confidence
        return summary

    def rows(self) -> list[dict[str, int]]:
        """One CSV row per match."""
        return [
            {
                "match": i,
                "home_side": int(self.home_side[i]),
                "home_points": int(self.home_points[i]),
                "away_points": int(self.away_points[i]),
                "outcome": int(self.outcomes[i]),
                "steps": int(self.steps[i]),
            }
            for i in range(len(self.steps))
        ]


def route_actions(
    tensordict: TensorDictBase,
    home: dict[str, torch.Tensor],
    away: dict[str, torch.Tensor],
    home_side: torch.Tensor,
) -> None:
    """Write each agent's action, in place, from the policy that controls its team.

    Args:
        tensordict: the env's current TensorDict ``[K]`` (its ``(g, "team")`` is read).
        home: the home policy's actions of every agent, ``{group: [K, n_g, ...]}``.
        away: the away policy's, likewise.
        home_side: ``int [K]``, the team (0 or 1) the home policy plays in each world.

    Examples:
        >>> from tensordict import TensorDict
        >>> td = TensorDict({("g", "team"): torch.tensor([[[0], [1]]])}, [1])
        >>> home, away = {"g": torch.tensor([[5, 5]])}, {"g": torch.tensor([[7, 7]])}
        >>> route_actions(td, home, away, torch.tensor([1]))
        >>> td["g", "action"].tolist()
        [[7, 5]]
    """
    for group, home_action in home.items():
        team = tensordict[group, TEAM].squeeze(-1)  # [K, n_g]
        is_home = team == home_side.view(-1, 1)
        mask = is_home.view(*is_home.shape, *([1] * (home_action.dim() - is_home.dim())))
        tensordict.set((group, ACTION), torch.where(mask, home_action, away[group]))


def play_matches(
    env: BatchedGameEnv,
    home: TeamPolicy,
    away: TeamPolicy,
    matches: int,
    rules: MatchRules,
    *,
    deterministic: bool = True,
    swap_sides: bool = True,
    first_side: int = 0,
    names: tuple[str, str] = ("home", "away"),
    on_step: StepCallback | None = None,
) -> MatchResult:
    """Play ``matches`` matches of ``home`` against ``away`` in the batched ``env``.

    Args:
        env: the match env; its ``K = batch_size[0]`` worlds play matches in parallel.
        home: the home team policy; ``away`` likewise.
        matches: how many matches (``M >= 1``).
        rules: when a match ends.
        deterministic: the policies' mode action (``True``) or a sample.
        swap_sides: alternate home's team from match to match (else always ``first_side``).
        first_side: home's team (0 or 1) in match 0.
        names: the two players' names, recorded in the result.
        on_step: called after every step (see :data:`StepCallback`).

    Returns:
        Per-match records, in match order.
    """
    if matches < 1:
        raise ValueError(f"matches must be >= 1, got {matches}")
    k = int(env.batch_size[0])
    match_of_world = np.arange(k)  # the match each world is playing; >= matches: idle
    points = np.zeros((k, 2), dtype=np.int64)
    match_steps = np.zeros(k, dtype=np.int64)
    if first_side not in (0, 1):
        raise ValueError(f"first_side must be 0 or 1, got {first_side}")
    home_side = np.full(matches, first_side, dtype=np.int64)
    if swap_sides:
        home_side[1::2] = 1 - first_side
    record_home = np.zeros(matches, dtype=np.int64)
    record_away = np.zeros(matches, dtype=np.int64)
    record_steps = np.zeros(matches, dtype=np.int64)
    # Per-team events of the game (e.g. tennis hits over the net), by team while
    # playing and by side (home, away) once recorded.
    team_events = [key for key, shape in env.game.published_info.items() if shape == (2,)]
    # How points ended (the game's ``ended_<how>`` flags), charged to the side that lost.
    endings = {
        key: f"lost_{key.removeprefix(ENDED_PREFIX)}"
        for key, shape in env.game.published_info.items()
        if key.startswith(ENDED_PREFIX) and shape == ()
    }
    event_counts = {key: np.zeros((k, 2)) for key in [*team_events, *endings.values()]}
    record_events = {key: np.zeros((matches, 2)) for key in event_counts}
    next_match = k
    exploration = ExplorationType.DETERMINISTIC if deterministic else ExplorationType.RANDOM
    tensordict = env.reset()
    if on_step is not None:
        on_step(tensordict, points, match_steps)
    with torch.no_grad(), set_exploration_type(exploration):
        while (match_of_world < matches).any():
            side = torch.from_numpy(home_side[np.minimum(match_of_world, matches - 1)])
            route_actions(tensordict, home(tensordict), away(tensordict), side)
            tensordict = env.step(tensordict)
            scoring = tensordict[NEXT, SCORING_TEAM].view(k).numpy()
            done = tensordict[NEXT, DONE].view(k).numpy()
            for key in team_events:
                event_counts[key] += tensordict[NEXT, INFO, key].view(k, 2).numpy()
            decided = np.flatnonzero(scoring >= 0)
            for key, lost in endings.items():
                ended = tensordict[NEXT, INFO, key].view(k).numpy()[decided]
                event_counts[lost][decided, 1 - scoring[decided]] += ended
            tensordict = step_mdp(tensordict)
            for team in (0, 1):
                points[:, team] += scoring == team
            match_steps += 1
            over = (points.max(axis=1) >= rules.points_to_win) | (match_steps >= rules.max_steps)
            finished = over & (match_of_world < matches)
            if finished.any():
                index = match_of_world[finished]
                sides = home_side[index]
                record_home[index] = points[finished, sides]
                record_away[index] = points[finished, 1 - sides]
                record_steps[index] = match_steps[finished]
                for key, counts in event_counts.items():
                    record_events[key][index, 0] = counts[finished, sides]
                    record_events[key][index, 1] = counts[finished, 1 - sides]
                # Finished worlds take the next unplayed matches, in world order.
                worlds = np.flatnonzero(finished)
                match_of_world[worlds] = next_match + np.arange(len(worlds))
                next_match += len(worlds)
            if on_step is not None:
                on_step(tensordict, points, match_steps)
            points[over] = 0
            match_steps[over] = 0
            for counts in event_counts.values():
                counts[over] = 0
            reset = done | over
            if reset.any():
                tensordict.set(RESET, torch.from_numpy(reset).view(k, 1))
                tensordict = env.reset(tensordict)
    return MatchResult(
        names[0], names[1], home_side, record_home, record_away, record_steps, record_events
    )


def make_match_env(
    env_name: str,
    num_envs: int,
    seed: int,
    players: list[str],
    env_options: dict[str, Any] | None = None,
) -> BatchedGameEnv:
    """The batched env of a match between ``players``: ``env_options``, except those the
    checkpoint players were trained with, which win (an override is reported on stdout)."""
    options = dict(env_options or {})
    for key, value in player_options(players, env_name).items():
        if key in options and options[key] != value:
            print(f"note: env.{key}={options[key]!r} replaced by the checkpoints' {value!r}")
        options[key] = value
    env = make_env(env_name, num_envs=num_envs, seed=seed, **options)
    assert isinstance(env, BatchedGameEnv)
    return env


def evaluate_against(
    policy: TeamPolicy, opponent: str, env: EnvBase, matches: int, *, max_steps: int | None = None
) -> dict[str, Any]:
    """Win rate of ``policy`` against ``opponent`` in the match ``env`` (periodic evaluation).

    Args:
        policy: ``tensordict -> {group: actions}`` on raw env observations.
        opponent: ``"scripted"``, ``"random"`` or a checkpoint path.
        env: a match env from :func:`rlhc.envs.make_env`.
        matches: matches to play with mode actions (half on each side).
        max_steps: override of :func:`default_rules`.

    Returns:
        :meth:`MatchResult.summary`: ``win_rate``, ``win_rate_ci``, ``draw_rate``, …

    Examples:
        >>> from rlhc.envs import make_env
        >>> from rlhc.evaluation.opponents import make_team_policy
        >>> env = make_env("soccer", num_envs=4, seed=0, max_cycles=50)
        >>> result = evaluate_against(make_team_policy("random", env), "scripted", env, 4)
        >>> result["matches"]
        4
    """
    assert isinstance(env, BatchedGameEnv)
    rules = default_rules(env.game.name, env.game.max_cycles, max_steps=max_steps)
    opponent_policy = make_team_policy(opponent, env)
    result = play_matches(env, policy, opponent_policy, matches, rules, names=("policy", opponent))
    return result.summary()
