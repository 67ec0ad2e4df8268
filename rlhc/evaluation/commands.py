"""The two evaluation commands behind ``python -m rlhc.evaluate``, writing their files.

| mode | plays | writes (into the run directory) |
|---|---|---|
| ``match`` | ``home`` vs ``away``, ``matches`` times | ``results.json`` (summary), ``matches.csv`` (one row per match), optionally ``match.gif``/``.mp4`` |
| ``elo`` | every pair of ``players``, ``matches`` times each | ``elo.json``, ``elo.csv`` (standings), ``pairings.csv`` (one row per pairing), optionally ``videos/<i>_<home>_vs_<away>.gif``/``.mp4`` (one match per pairing) |
| ``showcase`` | ``home`` against itself, the scripted and the random team, ``matches`` times each | ``showcase.json`` (headlines and summaries), ``point.gif``/``.mp4``, ``curves.png`` (:mod:`rlhc.analysis.showcase`) |
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

from rlhc.config.evaluate_schema import EvaluateConfig
from rlhc.config.validation import validate_evaluate
from rlhc.evaluation.elo import EloTable, round_robin
from rlhc.evaluation.matches import (
    MatchResult,
    default_rules,
    make_match_env,
    play_matches,
)
from rlhc.evaluation.opponents import check_players, make_team_policy, player_options
from rlhc.evaluation.video import file_label, record_match

RESULTS_FILE = "results.json"
MATCHES_FILE = "matches.csv"
ELO_FILE = "elo.json"
STANDINGS_FILE = "elo.csv"
PAIRINGS_FILE = "pairings.csv"
VIDEO_DIR = "videos"


def player_settings(cfg: EvaluateConfig) -> dict[str, str]:
    """``setting -> player`` of the players ``cfg.mode`` plays.

    Examples:
        >>> player_settings(EvaluateConfig(home="scripted", away="random"))
        {'home': 'scripted', 'away': 'random'}
        >>> player_settings(EvaluateConfig(mode="elo", players=["scripted", "random"]))
        {'players[0]': 'scripted', 'players[1]': 'random'}
    """
    if cfg.mode == "elo":
        return {f"players[{i}]": player for i, player in enumerate(cfg.players)}
    if cfg.mode == "showcase":
        return {"home": cfg.home}
    return {"home": cfg.home, "away": cfg.away}


def check_evaluation(cfg: EvaluateConfig) -> None:
    """Check an evaluation before a match is played: its values
    (:func:`rlhc.config.validation.validate_evaluate`), then its players
    (:func:`rlhc.evaluation.opponents.check_players`); :class:`ConfigError` if wrong.
    """
    validate_evaluate(cfg)
    check_players(player_settings(cfg), cfg.env.name)


def play_series(cfg: EvaluateConfig, home: str, away: str) -> MatchResult:
    """``cfg.matches`` matches of ``home`` against ``away`` in one batched env."""
    env = make_match_env(
        cfg.env.name, cfg.num_envs(), cfg.seed, [home, away], cfg.env.game_options()
    )
    rules = default_rules(cfg.env.name, env.game.max_cycles, cfg.points_to_win, cfg.max_match_steps)
    return play_matches(
        env,
        make_team_policy(home, env),
        make_team_policy(away, env),
        cfg.matches,
        rules,
        deterministic=cfg.deterministic,
        swap_sides=cfg.swap_sides,
        names=(home, away),
    )


def format_summary(summary: dict[str, Any]) -> str:
    """A few human-readable lines of :meth:`MatchResult.summary`."""
    level = f"{summary['confidence']:.0%}"
    lines = [f"{summary['home']} (home) vs {summary['away']} (away): {summary['matches']} matches"]
    for name, rate in (("wins", "win"), ("draws", "draw"), ("losses", "loss")):
        low, high = summary[f"{rate}_rate_ci"]
        lines.append(
            f"  {name:<6} {summary[name]:>5}  {summary[f'{rate}_rate']:6.1%}  "
            f"[{low:.1%}, {high:.1%}] ({level} Wilson)"
        )
    lines.append(
        f"  points {summary['home_points_mean']:.2f} : {summary['away_points_mean']:.2f}"
        f"   mean length {summary['length_mean']:.1f} steps"
    )
    if "points_won_rate" in summary:
        low, high = summary["points_won_rate_ci"]
        lines.append(
            f"  points won by home {summary['points_won_rate']:.1%} [{low:.1%}, {high:.1%}]"
        )
    for key, sides in summary.items():
        if key.endswith("_per_point") and isinstance(sides, dict):
            lines.append(f"  {key}: home {sides['home']:.2f}, away {sides['away']:.2f}")
    return "\n".join(lines)


def record_video(cfg: EvaluateConfig, home: str, away: str, path: Path) -> Path:
    """One match of ``home`` (team 0) against ``away`` written to ``path`` (``cfg.video``)."""
    written, _, frames = record_match(
        cfg.env.name,
        home,
        away,
        path,
        max_frames=cfg.video.max_frames,
        fps=cfg.video.fps,
        seed=cfg.seed,
        deterministic=cfg.deterministic,
        points_to_win=cfg.points_to_win,
        env_options=cfg.env.game_options(),
    )
    print(f"  video: {written} ({frames} frames)")
    return written


def run_match(cfg: EvaluateConfig, out_dir: Path) -> dict[str, Any]:
    """``mode=match``: play, print, write ``results.json`` and ``matches.csv``."""
    result = play_series(cfg, cfg.home, cfg.away)
    summary = {"env": cfg.env.name, "deterministic": cfg.deterministic, **result.summary()}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / RESULTS_FILE).write_text(json.dumps(summary, indent=2) + "\n")
    _write_csv(out_dir / MATCHES_FILE, result.rows())
    print(format_summary(summary))
    if cfg.video.enabled:
        path = record_video(cfg, cfg.home, cfg.away, out_dir / f"match.{cfg.video.format}")
        summary["video"] = str(path)
    print(f"  results: {out_dir / RESULTS_FILE}")
    return summary


def run_elo(cfg: EvaluateConfig, out_dir: Path) -> EloTable:
    """``mode=elo``: a round robin of ``cfg.players``; print and write the standings (and
    with ``cfg.video.enabled`` one video per pairing, named in its row)."""
    players = list(dict.fromkeys(cfg.players))
    player_options(players, cfg.env.name)  # fail before playing if two checkpoints disagree
    table = EloTable(k=cfg.k_factor, initial=cfg.initial_rating)
    scores: dict[tuple[str, str], list[float]] = {}
    pairings: list[dict[str, Any]] = []
    for index, (home, away) in enumerate(round_robin(players)):
        result = play_series(cfg, home, away)
        scores[(home, away)] = result.scores.tolist()
        summary = result.summary()
        pairing = {k: summary[k] for k in ("home", "away", "wins", "draws", "losses")}
        print(f"{home} vs {away}: {summary['wins']}-{summary['draws']}-{summary['losses']}")
        if cfg.video.enabled:
            name = f"{index}_{file_label(home)}_vs_{file_label(away)}.{cfg.video.format}"
            pairing["video"] = str(record_video(cfg, home, away, out_dir / VIDEO_DIR / name))
        pairings.append(pairing)
    table.record_pairings(scores)
    standings = [{"player": p, "elo": r, "games": g} for p, r, g in table.standings()]
    settings = {"env": cfg.env.name, "k": cfg.k_factor, "initial": cfg.initial_rating}
    elo = {**settings, "standings": standings, "pairings": pairings}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / ELO_FILE).write_text(json.dumps(elo, indent=2) + "\n")
    _write_csv(out_dir / STANDINGS_FILE, standings)
    _write_csv(out_dir / PAIRINGS_FILE, pairings)
    print(table.format())
    print(f"standings: {out_dir / STANDINGS_FILE}")
    return table


def _write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]) if rows else [])
        writer.writeheader()
        writer.writerows(rows)
