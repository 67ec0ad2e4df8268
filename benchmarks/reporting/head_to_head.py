"""Matches of the final teams: RLHC against PPO (seed k vs seed k), each against scripted.

Matches are played by :mod:`rlhc.evaluation.matches` (sides swapped every match,
deterministic actions); this module pools their outcomes over seeds, words the
pooled record, and tabulates both kinds of series with 95% Wilson intervals
(:func:`rlhc.evaluation.stats.wilson_interval`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rlhc.evaluation.stats import wilson_interval

from .formatting import fmt, table
from .runs import StudyRun, complete_runs
from .study import PAIRS, STUDIES, study_env


@dataclass(frozen=True)
class Record:
    """Wins, draws and losses of one side over a number of matches."""

    wins: int
    draws: int
    losses: int

    @property
    def matches(self) -> int:
        """Matches played."""
        return self.wins + self.draws + self.losses

    @property
    def score(self) -> float:
        """Wins plus half the draws, per match (0.5: even)."""
        return (self.wins + 0.5 * self.draws) / self.matches if self.matches else math.nan

    def rate(self, count: float) -> str:
        """``rate [low, high]`` with the 95% Wilson interval."""
        if not self.matches:
            return "—"
        low, high = wilson_interval(count, self.matches)
        return f"{count / self.matches:.1%} [{low:.1%}, {high:.1%}]"

    def __add__(self, other: Record) -> Record:
        return Record(self.wins + other.wins, self.draws + other.draws, self.losses + other.losses)


def record_of(summary: Mapping[str, Any]) -> Record:
    """From :meth:`rlhc.evaluation.matches.MatchResult.summary` (the home side's view)."""
    return Record(int(summary["wins"]), int(summary["draws"]), int(summary["losses"]))


def pooled(records: Iterable[Record]) -> Record:
    """The records of several series added up."""
    return sum(records, Record(0, 0, 0))


def match_verdict(label: str, record: Record) -> str:
    """A neutral sentence on a pooled head-to-head record of RLHC."""
    if not record.matches:
        return f"{label}: no matches played yet."
    low, high = wilson_interval(record.wins + 0.5 * record.draws, record.matches)
    if low > 0.5:
        how = "RLHC scores higher than PPO"
    elif high < 0.5:
        how = "RLHC scores lower than PPO"
    else:
        how = "RLHC's score is not distinguishable from an even 0.5"
    return (
        f"{label}: {how} in head-to-head play (score {record.score:.3f}, 95% Wilson "
        f"[{low:.3f}, {high:.3f}] over {record.matches} matches; wins {record.rate(record.wins)}, "
        f"draws {record.rate(record.draws)}, losses {record.rate(record.losses)})."
    )


def play_series(env_name: str, home: str, away: str, matches: int, seed: int) -> Record:
    """``matches`` matches of ``home`` against ``away`` (sides swapped every match).

    Args:
        env_name: the game.
        home: a checkpoint path; ``away`` likewise, or ``"scripted"``.
        matches: how many matches (half with ``home`` on each side).
        seed: seeds python, numpy, torch and the game.

    Returns:
        The record of ``home``.
    """
    # Imported here: torch and the games are only needed when matches are played.
    from rlhc.evaluation.matches import evaluate_against, make_match_env
    from rlhc.evaluation.opponents import make_team_policy
    from rlhc.trainer import seed_everything

    seed_everything(seed)
    # The env takes the options the checkpoints were trained with (e.g. extended_obs).
    env = make_match_env(env_name, min(32, matches), seed, [home, away])
    summary = evaluate_against(make_team_policy(home, env), away, env, matches)
    env.close()
    return record_of(summary)


def require_checkpoints(runs: Sequence[StudyRun]) -> None:
    """Matches play the runs' final checkpoints, which the committed study does not keep.

    Raises:
        FileNotFoundError: a run keeps no checkpoint (the first such run is named).
    """
    from rlhc.checkpoint import CHECKPOINT_DIR, LATEST

    for run in runs:
        if not (run.path / CHECKPOINT_DIR / LATEST).exists():
            raise FileNotFoundError(
                f"{run.path} keeps no {CHECKPOINT_DIR}/{LATEST}: matches need the runs' "
                "checkpoints (not committed); train them, or pass --matches 0 to keep the "
                "previous report's matches"
            )


def matches_section(
    runs: Sequence[StudyRun], studies: Sequence[str], matches: int
) -> tuple[list[str], list[str]]:
    """Head-to-head and against-scripted tables; also the head-to-head verdicts."""
    if matches <= 0:
        return ["Not played (`--matches 0`)."], []
    require_checkpoints([r for r in runs if r.complete and r.study in studies])
    lines: list[str] = []
    verdicts: list[str] = []
    head_rows, pair_rows = [], []
    for study in studies:
        for rlhc, ppo in PAIRS.get(study, []):
            a = {r.seed: r for r in complete_runs(runs, f"{study}/{rlhc}")}
            b = {r.seed: r for r in complete_runs(runs, f"{study}/{ppo}")}
            records = []
            for seed in sorted(set(a) & set(b)):
                record = play_series(
                    study_env(study), str(a[seed].path), str(b[seed].path), matches, seed
                )
                records.append(record)
                pair_rows.append(
                    [
                        f"`{study}/{rlhc}` vs `{study}/{ppo}`",
                        str(seed),
                        f"{record.wins}/{record.draws}/{record.losses}",
                        record.rate(record.wins),
                        record.rate(record.draws),
                        record.rate(record.losses),
                    ]
                )
            total = pooled(records)
            label = f"`{study}/{rlhc}` vs `{study}/{ppo}`"
            head_rows.append(
                [
                    label,
                    str(len(records)),
                    str(total.matches),
                    total.rate(total.wins),
                    total.rate(total.draws),
                    total.rate(total.losses),
                    fmt(total.score, 3),
                ]
            )
            verdicts.append(match_verdict(label, total))
    rate_header = ["RLHC wins", "draws", "RLHC losses"]
    lines += [
        f"Final RLHC team vs final PPO team of the same seed, {matches} matches per seed pair, "
        "sides swapped every match, deterministic (mode) actions; rates with 95% Wilson "
        "intervals. The pooled interval treats every match as an independent trial, so it "
        "does not include the spread between seeds.",
        "",
        *table(["pairing", "seed pairs", "matches", *rate_header, "score"], head_rows),
        "",
        "Per seed pair (wins/draws/losses of RLHC):",
        "",
        *table(["pairing", "seed", "W/D/L", *rate_header], pair_rows),
        "",
    ]
    scripted_rows = []
    for study in studies:
        for config in STUDIES[study].configs:
            members = complete_runs(runs, f"{study}/{config}")
            records = [
                play_series(study_env(study), str(r.path), "scripted", matches, r.seed)
                for r in members
            ]
            if not records:
                continue
            total = pooled(records)
            scripted_rows.append(
                [
                    f"`{study}/{config}`",
                    str(len(records)),
                    ", ".join(f"{r.wins / r.matches:.0%}" for r in records),
                    total.rate(total.wins),
                    total.rate(total.draws),
                    total.rate(total.losses),
                ]
            )
    lines += [
        f"Every final team against the scripted team ({matches} matches per run, sides "
        "swapped every match):",
        "",
        *table(
            ["config", "runs", "win rate per seed", "wins (pooled)", "draws", "losses"],
            scripted_rows,
        ),
    ]
    return lines, verdicts
