"""Matches of a study's final teams: a round robin, ratings, head-to-head with seed spread.

Per study, every final team (one per complete run) plays every other and the built-in
``scripted`` and ``random`` teams (:mod:`reporting.tournament`); the series are kept in
the study's ``round_robin.json`` (committed), so the report rebuilds without
checkpoints; each finished run keeps its ``final_team.pt`` (:mod:`rlhc.storage.final_team`,
committed), so a later run can still meet it. From that file:

* an Elo-scale rating of every team (Bradley-Terry fit, bootstrap interval);
* each configuration's score against the built-in teams, one value per seed, averaged
  with a 95% t interval (the per-run scores also feed the aggregates,
  :mod:`reporting.aggregates`);
* head-to-head between the compared configurations: the score of one over all seed
  pairs, with an interval that resamples seeds on both sides (so it includes the
  spread between seeds), and the score of every seed pair.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from statistics import NormalDist

from .formatting import fmt_interval, share_interval, table
from .plan import Study
from .ratings import cross_score, pair_records, ratings
from .runs import StudyRun, complete_runs
from .study import ALPHA, BORROWED, POWER, comparisons_of
from .tournament import Entrant, Record, Series, load_series, play_round_robin

#: The study's series, next to its runs.
STORE = "round_robin.json"
#: Built-in teams every final team meets.
BUILT_IN = ("scripted", "random")
#: What the head-to-head scores mean when some seed pairs never met.
PLAYED_ONLY = " The scores above average the pairs played; their bootstrap resamples only those."


def store_of(study: Study) -> Path:
    """The study's ``round_robin.json``."""
    return study.root / STORE


def team_name(run: StudyRun) -> str:
    """``<config>/seed_<k>``: a final team's name in the round robin."""
    return f"{run.config}/seed_{run.seed}"


def playable(study: Study, runs: Sequence[StudyRun]) -> tuple[list[StudyRun], list[StudyRun]]:
    """The study's complete runs that can play (a final team or a checkpoint on disk),
    and those that cannot (trained before final teams were kept, checkpoints gone):
    their stored series still count, but they meet no team trained after them."""
    from rlhc.storage.final_team import has_team

    found: tuple[list[StudyRun], list[StudyRun]] = ([], [])
    for run in (r for r in runs if r.study == study.name and r.complete):
        found[0 if has_team(run.path) else 1].append(run)
    return found


def guests(study: Study, runs: Sequence[StudyRun]) -> list[Entrant]:
    """The playable final teams of the configs a study borrows from another
    (:data:`reporting.study.BORROWED`), named ``<study>/<config>/seed_<k>``: they come
    to this study's round robin to meet its own teams."""
    from rlhc.storage.final_team import has_team

    return [Entrant(guest_name(r), str(r.path)) for r in invited(study, runs) if has_team(r.path)]


def invited(study: Study, runs: Sequence[StudyRun]) -> list[StudyRun]:
    """The complete runs of the configs a study borrows, weights kept or not."""
    return [r for name in BORROWED.get(study.name, ()) for r in complete_runs(runs, name)]


def guest_name(run: StudyRun) -> str:
    """``<study>/<config>/seed_<k>``: another study's team in this study's round robin."""
    return f"{run.study}/{team_name(run)}"


def play(study: Study, runs: Sequence[StudyRun], matches: int, seed: int) -> None:
    """Play the study's missing pairings among its playable teams into its store.

    Guests meet the study's own teams only (their other pairings are their own study's).
    A complete run without weights on disk (:func:`playable`) is named and skipped: its
    stored series stay in the store.
    """
    lost = playable(study, runs)[1]
    if lost:
        print(f"{study.name}: no final team or checkpoint, so no new pairing, for "
              f"{', '.join(team_name(r) for r in lost)}", flush=True)  # fmt: skip
    own = [Entrant(team_name(r), str(r.path)) for r in playable(study, runs)[0]]
    visiting = guests(study, runs)
    teams = [*own, *visiting, *(Entrant(name, name) for name in BUILT_IN)]
    involving = {e.name for e in own} if visiting else None  # guests meet only own teams
    play_round_robin(study.env, teams, matches, seed, store_of(study), involving)


@dataclass(frozen=True)
class BuiltInScores:
    """Per-seed records of one configuration against one built-in team."""

    config: str
    opponent: str
    seeds: tuple[int, ...]
    records: tuple[Record, ...]

    @property
    def scores(self) -> tuple[float, ...]:
        """Match score per seed (wins + draws / 2, per match)."""
        return tuple(r.score for r in self.records)

    @property
    def points_shares(self) -> tuple[float, ...]:
        """Share of the points won per seed (seeds whose matches scored none left out)."""
        return tuple(s for r in self.records if math.isfinite(s := r.points_share))


def built_in_scores(
    series: Sequence[Series], runs: Sequence[StudyRun], name: str, opponent: str
) -> BuiltInScores:
    """The score of each complete run of ``study/config`` ``name`` against ``opponent``.

    A run whose series against ``opponent`` is not in the store is left out.
    """
    seeds, records = [], []
    for run in complete_runs(runs, name):
        record = record_against(series, team_name(run), opponent)
        if record is not None:
            seeds.append(run.seed)
            records.append(record)
    return BuiltInScores(name, opponent, tuple(seeds), tuple(records))


def record_against(series: Sequence[Series], team: str, opponent: str) -> Record | None:
    """``team``'s record against ``opponent`` (``None``: they have not played)."""
    for s in series:
        if {s.home, s.away} == {team, opponent}:
            return s.record_of(team)
    return None


def shown_config(name: str, study: str) -> str:
    """``config`` of this study's ``study/config``; another study's keeps its study."""
    owner, _, config = name.partition("/")
    return config if owner == study else name


def study_matches(study: Study, runs: Sequence[StudyRun]) -> tuple[list[str], list[str]]:
    """A study's match section and its head-to-head verdicts (from the store only)."""
    series = load_series(store_of(study)) if store_of(study).is_file() else []
    heading = [f"### `{study.name}` ({study.env})", ""]
    own = {team_name(r) for r in runs if r.study == study.name and r.complete}
    # The guests that came (:func:`guests`); those whose weights are lost never could.
    asked = {guest_name(r) for r in invited(study, runs)}
    came = {name for s in series for name in (s.home, s.away)} & asked
    series = [s for s in series if {s.home, s.away} <= own | came | set(BUILT_IN)]
    if not series:
        return [*heading, "No series played yet."], []
    per_pairing = sorted({s.matches for s in series})
    lines = [
        *heading,
        f"{len(series)} series, {sum(s.matches for s in series):,} matches "
        f"({', '.join(map(str, per_pairing))} per pairing; sides swapped every match, "
        "deterministic actions).",
        "",
        *ratings_table(series),
    ]
    if came:
        absent = ", ".join(f"`{t}`" for t in sorted(asked - came)) or "none"
        lines += [
            "",
            "Teams named `<study>/<config>/seed_<k>` are another study's, here to meet this "
            "study's teams only (their other series are in their own study's round robin); "
            f"those whose weights are lost could not come: {absent}.",
        ]
    lines += ["", *built_in_table(study, series, runs)]

    def members(name: str) -> list[str]:
        """The teams of ``study/config`` in this round robin."""
        owner, _, config = name.partition("/")
        if owner == study.name:
            return sorted(t for t in own if t.startswith(f"{config}/"))
        return sorted(t for t in came if t.startswith(f"{name}/"))

    compared = [
        (shown_config(first, study.name), shown_config(second, study.name), a_names, b_names)
        for first, second in comparisons_of(study)
        if (a_names := members(first)) and (b_names := members(second))
    ]
    section, verdicts, unplayed = head_to_head(study.name, series, compared)
    lost = [f"`{team_name(r)}`" for r in playable(study, runs)[1]]
    if unplayed and lost:
        section += [
            "",
            "Teams whose weights are lost (trained before runs kept their `final_team.pt`) "
            f"keep their series but meet no team trained after them: {', '.join(lost)}.",
        ]
    return [*lines, *([""] if section else []), *section], verdicts


def head_to_head(
    study: str,
    series: Sequence[Series],
    compared: Sequence[tuple[str, str, Sequence[str], Sequence[str]]],
) -> tuple[list[str], list[str], int]:
    """The head-to-head tables of ``(first, second, first's teams, second's teams)``
    comparisons (nothing if none), a verdict for each with a seed spread on both sides,
    and the number of pairs not played."""
    verdicts: list[str] = []
    rows: list[list[str]] = []
    grids: list[str] = []
    unplayed = 0
    for a, b, a_names, b_names in compared:
        label, pairs = f"`{a}` vs `{b}`", len(a_names) * len(b_names)
        records = pair_records(series, a_names, b_names, allow_missing=True)
        missing = sum(r is None for row in records for r in row)
        unplayed += missing
        teams = f"{len(a_names)} x {len(b_names)}"
        if missing == pairs:
            rows.append([label, teams, "no pair played", "—", "—"])
            continue
        estimate = cross_score(series, a_names, b_names, allow_missing=True)
        cell = f"{estimate.value:.3f} [{estimate.low:.3f}, {estimate.high:.3f}]"
        half = (estimate.high - estimate.low) / 2
        if min(len(a_names), len(b_names)) < 2:  # no seed spread to resample on that side
            cell += " (one seed on a side: no seed spread in the interval, no verdict)"
        else:
            verdicts.append(head_to_head_verdict(f"{study}: {label}", estimate))
        if missing:
            teams += f" ({pairs - missing} of {pairs} pairs played)"
        rows.append([label, teams, cell, f"{half:.3f}", f"{detectable_edge(half):.3f}"])
        grids += ["", *pair_grid(a, b, a_names, b_names, records)]
    if not rows:
        return [], verdicts, unplayed
    lines = [
        "Head-to-head, first configuration's score against the second over every pair of "
        "their seeds; the 95% interval resamples the seeds of both sides and the matches "
        "within each pair (two-level bootstrap), so it includes the spread between seeds. "
        f"*Detectable*: the smallest edge over an even 0.5 these seeds would find with power "
        f"{POWER} at alpha {ALPHA}, from the interval's half-width (normal approximation); "
        "half-widths shrink about as one over the square root of the seeds a side (four "
        "times the seeds, half the width):",
        "",
        *table(["first vs second", "teams", "score [95% CI]", "half-width", "detectable"], rows),
        "",
        "Every seed pair: the row team's score against the column team (wins + draws / 2 "
        f"per match, over the pair's matches; — not played).{PLAYED_ONLY if unplayed else ''}",
        *grids,
    ]
    return lines, verdicts, unplayed


def detectable_edge(half_width: float, alpha: float = ALPHA, power: float = POWER) -> float:
    """The smallest edge over an even 0.5 that a score whose ``1 - alpha`` interval has
    ``half_width`` would show with ``power``: ``half_width · (z_{1-alpha/2} + z_power) /
    z_{1-alpha/2}`` (a normal sampling distribution, its spread read off the interval).

    Examples:
        >>> round(detectable_edge(0.1), 3)
        0.143
    """
    z = NormalDist().inv_cdf
    return half_width * (z(1 - alpha / 2) + z(power)) / z(1 - alpha / 2)


def pair_grid(
    a: str,
    b: str,
    a_names: Sequence[str],
    b_names: Sequence[str],
    records: Sequence[Sequence[Record | None]],
) -> list[str]:
    """A table of ``a``'s teams (rows) against ``b``'s (columns): each pair's score."""
    rows = [
        [f"`{name.rsplit('/', 1)[-1]}`", *("—" if r is None else f"{r.score:.3f}" for r in row)]
        for name, row in zip(a_names, records, strict=True)
    ]
    header = [f"`{a}` (rows) vs `{b}`", *(f"`{name.rsplit('/', 1)[-1]}`" for name in b_names)]
    return table(header, rows)


def ratings_table(series: Sequence[Series]) -> list[str]:
    """Every team's Elo-scale rating, ``random`` anchored at 0."""
    rows = [
        [
            f"`{row.name}`",
            f"{row.rating:,.0f} [{row.low:,.0f}, {row.high:,.0f}]",
            str(row.matches),
            f"{row.score:.3f}",
        ]
        for row in ratings(series)
    ]
    return [
        "Ratings: a Bradley-Terry fit of every series on the Elo scale (a 400-point gap: "
        "10 to 1 odds; draws count half), `random` anchored at 0, 95% parametric bootstrap "
        "interval:",
        "",
        *table(["team", "rating [95% CI]", "matches", "score"], rows),
    ]


def built_in_table(study: Study, series: Sequence[Series], runs: Sequence[StudyRun]) -> list[str]:
    """Each configuration's per-seed scores against the built-in teams."""
    rows = []
    for config in study.configs:
        cells = [f"`{config}`"]
        for opponent in BUILT_IN:
            found = built_in_scores(series, runs, f"{study.name}/{config}", opponent)
            per_seed = ", ".join(f"{s:.2f}" for s in found.scores) or "—"
            cells += [
                fmt_interval(share_interval(found.scores), 3),
                per_seed,
                fmt_interval(share_interval(found.points_shares), 3),
            ]
        rows.append(cells)
    header = ["config"]
    for opponent in BUILT_IN:
        header += [f"score vs {opponent}", "per seed", f"points won vs {opponent}"]
    return [
        "Against the built-in teams, one value per seed, mean [95% t, clipped to [0, 1]] over "
        "seeds: the match score (wins + draws / 2 per match) and the share of the points "
        "(soccer: goals) won:",
        "",
        *table(header, rows),
    ]


def head_to_head_verdict(label: str, estimate: object) -> str:
    """A neutral sentence on a head-to-head score and its seed-spread interval."""
    value, low, high = (float(getattr(estimate, k)) for k in ("value", "low", "high"))
    detail = f"score {value:.3f}, 95% CI [{low:.3f}, {high:.3f}]"
    if low > 0.5:
        how = "the first scores higher than the second"
    elif high < 0.5:
        how = "the first scores lower than the second"
    else:
        how = "not distinguishable from an even 0.5"
        edge = detectable_edge((high - low) / 2)
        detail += f"; detectable at power {POWER}: an edge of {edge:.3f}"
    return f"{label} head-to-head: {how} ({detail})."
