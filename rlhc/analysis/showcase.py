"""``mode=showcase``: does a trained team play? Its headline numbers, a point on video, its curves.

:func:`run_showcase` plays ``home`` (a run directory, a checkpoint or a built-in team)

| against | headline |
|---|---|
| itself | its game's play diagnostics (:func:`~rlhc.evaluation.diagnostics.diagnose`, as training's ``play/`` logs them): tennis, the hits over the net per point, sampled actions as in training and mode actions as in matches |
| the scripted team | the share of points it takes (Wilson interval) and of matches it wins |
| the random team | likewise |

and writes into the output directory ``showcase.json`` (the headlines, the two series'
:meth:`~rlhc.evaluation.matches.MatchResult.summary`, the play diagnostics), ``point.gif``
(one point of the team against itself; ``video.format=mp4`` for an MP4) and, when
``home`` belongs to a run directory, ``curves.png`` (the run's learning curves:
the paper's four, and where logged the self-play hits per point and the win rate
against the scripted team). ``make train`` ends with it.

Examples:
    python -m rlhc.evaluate mode=showcase env=tennis home=outputs/tennis/hierarchical/<time>
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from rlhc.analysis.curves import METRICS_FILE, PAPER_METRICS, group_runs, load_runs
from rlhc.analysis.drawing import plot_groups
from rlhc.config.evaluate_schema import EvaluateConfig
from rlhc.envs.keys import RANDOM, SCRIPTED
from rlhc.evaluation.diagnostics import DIAGNOSTICS, diagnose
from rlhc.evaluation.opponents import is_built_in, load_policy_checkpoint

SHOWCASE_FILE = "showcase.json"
CURVES_FILE = "curves.png"
#: The curves drawn: the paper's four, the team's play with itself and against the
#: scripted team (logged every ``play_freq`` / ``eval_freq`` frames).
CURVES = {
    **PAPER_METRICS,
    "hits_per_point": "hits over the net per point with itself",
    "win_rate": "matches won against the scripted team",
}
#: Play diagnostics shown as headlines: key -> what it counts.
PLAY_HEADLINES = {
    "hits_per_point": "hits over the net per point (sampled actions)",
    "hits_per_point_mode": "hits over the net per point (mode actions)",
}


def run_showcase(cfg: EvaluateConfig, out_dir: Path) -> dict[str, Any]:
    """Play ``cfg.home`` against itself (its play diagnostics), the scripted and the
    random team (``cfg.matches`` matches each), record one point against itself, draw
    its run's curves; print the headlines and where the files are, write ``showcase.json``.

    Returns:
        What ``showcase.json`` holds.
    """
    # Imported here: TorchRL loads only when a match is played (``rlhc.evaluation``).
    from rlhc.evaluation.commands import play_series, record_video

    out_dir.mkdir(parents=True, exist_ok=True)
    home, env_name = cfg.home, cfg.env.name
    state = None if is_built_in(home) else load_policy_checkpoint(home, env_name)
    play: dict[str, Any] = {}
    if state is not None and env_name in DIAGNOSTICS:
        play = diagnose(state, seed=cfg.seed)
    series = {team: play_series(cfg, home, team).summary() for team in (SCRIPTED, RANDOM)}
    headlines = {key: float(play[key]) for key in PLAY_HEADLINES if key in play}
    for team, summary in series.items():
        low, high = summary["points_won_rate_ci"]
        headlines[f"points_won_vs_{team}"] = summary["points_won_rate"]
        headlines[f"points_won_vs_{team}_low"] = low
        headlines[f"points_won_vs_{team}_high"] = high
        headlines[f"win_rate_vs_{team}"] = summary["win_rate"]
    point = replace(cfg, points_to_win=1)
    files = {"video": str(record_video(point, home, home, out_dir / f"point.{cfg.video.format}"))}
    run_dir = None if state is None else _run_dir(Path(state["path"]))
    if run_dir is not None:
        curves = plot_groups(
            group_runs(load_runs([run_dir])), out_dir / CURVES_FILE, metrics=CURVES
        )
        files["curves"] = str(curves)
    result = {"env": env_name, "home": home, "matches": cfg.matches, "headlines": headlines}
    result.update(series=series, play=play, files=files)
    (out_dir / SHOWCASE_FILE).write_text(json.dumps(result, indent=2) + "\n")
    print(format_headlines(home, cfg.matches, headlines))
    for name, path in files.items():
        print(f"  {name}: {path}")
    print(f"  results: {out_dir / SHOWCASE_FILE}")
    return result


def format_headlines(home: str, matches: int, headlines: dict[str, float]) -> str:
    """The headlines in a few lines.

    Examples:
        >>> print(format_headlines("run", 10, {"hits_per_point": 12.5,
        ...     "points_won_vs_random": 0.98, "points_won_vs_random_low": 0.9,
        ...     "points_won_vs_random_high": 1.0, "win_rate_vs_random": 1.0}))
        run:
          with itself: 12.50 hits over the net per point (sampled actions)
          vs random: 98.0% of the points [90.0%, 100.0%], 100.0% of 10 matches
    """
    lines = [f"{home}:"]
    for key, what in PLAY_HEADLINES.items():
        if key in headlines:
            lines.append(f"  with itself: {headlines[key]:.2f} {what}")
    for team in (SCRIPTED, RANDOM):
        if f"points_won_vs_{team}" in headlines:
            lines.append(
                f"  vs {team}: {headlines[f'points_won_vs_{team}']:.1%} of the points "
                f"[{headlines[f'points_won_vs_{team}_low']:.1%}, "
                f"{headlines[f'points_won_vs_{team}_high']:.1%}], "
                f"{headlines[f'win_rate_vs_{team}']:.1%} of {matches} matches"
            )
    return "\n".join(lines)


def _run_dir(checkpoint: Path) -> Path | None:
    """The run directory of a checkpoint file (the nearest one up holding ``metrics.csv``)."""
    path = checkpoint.resolve()
    for directory in (path, *path.parents)[:3]:
        if (directory / METRICS_FILE).is_file():
            return directory
    return None
