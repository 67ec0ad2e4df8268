"""Round robin of final teams: the store, Bradley–Terry ratings, critic-vs-critic scores.

The statistics are checked on synthetic series with known strengths; the store on
checkpoints holding no weights and a counting stand-in for the matches; one real
series (scripted against random, tennis) checks the wiring to the match code.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from benchmarks.reporting import tournament
from benchmarks.reporting.ratings import (
    Rating,
    cross_score,
    pair_records,
    ratings,
)
from benchmarks.reporting.tournament import (
    Entrant,
    LoadedEntrant,
    Record,
    Series,
    load_series,
    play_round_robin,
)
from rlhc.storage.checkpoint import save_checkpoint

BUILT_INS = [Entrant("scripted", "scripted"), Entrant("random", "random")]


def expected(rating: float, opponent: float) -> float:
    return 1.0 / (1.0 + 10.0 ** ((opponent - rating) / 400.0))


def exact_series(
    strengths: Mapping[str, float], matches: int, draw_rate: float = 0.0
) -> list[Series]:
    """Every pairing with its expected wins, draws and losses (a draw is half a win)."""
    names = list(strengths)
    series = []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            p = expected(strengths[a], strengths[b])
            draws = round(matches * draw_rate)
            wins = round(matches * (p - draw_rate / 2))
            series.append(
                Series(a, b, "v", "v", matches, 0, wins, draws, matches - wins - draws, "c")
            )
    return series


def swapped(series: Series) -> Series:
    """The same matches recorded with the other team at home."""
    return Series(
        series.away, series.home, series.away_version, series.home_version, series.matches,
        series.seed, series.losses, series.draws, series.wins, series.code_version,
    )  # fmt: skip


def by_name(rows: list[Rating]) -> dict[str, Rating]:
    return {row.name: row for row in rows}


STRENGTHS = {"random": 0.0, "scripted": 300.0, "a": 150.0, "b": -100.0}


# --- ratings ---------------------------------------------------------------------------
def test_fit_recovers_known_ratings_from_expected_outcomes() -> None:
    rows = by_name(ratings(exact_series(STRENGTHS, 100_000, draw_rate=0.1), resamples=0))
    for name, strength in STRENGTHS.items():
        assert rows[name].rating == pytest.approx(strength, abs=1.0)


def test_fit_recovers_known_ratings_from_sampled_matches() -> None:
    rng = np.random.default_rng(0)
    names, series = list(STRENGTHS), []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            wins = int(rng.binomial(2000, expected(STRENGTHS[a], STRENGTHS[b])))
            series.append(Series(a, b, "v", "v", 2000, 0, wins, 0, 2000 - wins, "c"))
    rows = by_name(ratings(series, resamples=200))
    for name, strength in STRENGTHS.items():
        assert rows[name].rating == pytest.approx(strength, abs=30.0)
        assert rows[name].low <= strength <= rows[name].high


def test_undefeated_team_has_a_finite_rating_above_the_others() -> None:
    # Alone against random, 20-0 is fitted as 20.5 of 21 points (one virtual draw).
    alone = ratings([Series("scripted", "random", "v", "v", 20, 0, 20, 0, 0, "c")], resamples=0)
    assert alone[0].rating == pytest.approx(400.0 * math.log10(20.5 / 0.5))
    series = exact_series(STRENGTHS, 100) + [
        Series("champion", name, "v", "v", 20, 0, 20, 0, 0, "c") for name in STRENGTHS
    ]
    rows = ratings(series, resamples=50)
    assert rows[0].name == "champion" and rows[0].score == 1.0
    assert all(math.isfinite(x) for x in (rows[0].rating, rows[0].low, rows[0].high))
    assert rows[0].rating > rows[1].rating + 100.0
    winless = exact_series(STRENGTHS, 100) + [
        Series(name, "loser", "v", "v", 20, 0, 20, 0, 0, "c") for name in STRENGTHS
    ]
    assert ratings(winless, resamples=0)[-1].name == "loser"
    assert math.isfinite(ratings(winless, resamples=0)[-1].rating)


def test_swapping_home_and_away_changes_nothing() -> None:
    series = exact_series(STRENGTHS, 50, draw_rate=0.2)
    original = by_name(ratings(series, resamples=0))
    flipped = by_name(ratings([swapped(s) for s in reversed(series)], resamples=0))
    for name in STRENGTHS:
        assert flipped[name].rating == pytest.approx(original[name].rating, abs=1e-6)
        assert (flipped[name].matches, flipped[name].score) == (
            original[name].matches,
            original[name].score,
        )
    score = cross_score(series, ["a", "scripted"], ["random", "b"], resamples=0).value
    assert cross_score([swapped(s) for s in series], ["a", "scripted"], ["random", "b"]).value == (
        pytest.approx(score)
    )


def test_anchor_sits_at_its_rating_and_only_shifts_the_others() -> None:
    series = exact_series(STRENGTHS, 200, draw_rate=0.1)
    at_random = by_name(ratings(series, resamples=20))
    at_scripted = by_name(ratings(series, anchor="scripted", anchor_rating=1500.0, resamples=20))
    anchor = at_scripted["scripted"]
    assert anchor.rating == anchor.low == anchor.high == 1500.0
    assert at_random["random"].rating == at_random["random"].low == 0.0
    shift = 1500.0 - at_random["scripted"].rating
    for name in STRENGTHS:
        assert at_scripted[name].rating == pytest.approx(at_random[name].rating + shift)


def test_interval_contains_the_rating_and_widens_with_fewer_matches() -> None:
    def widths(per_series: int) -> dict[str, float]:
        # The same rates (0.6, 0.1, 0.3 and its reverse), ``per_series`` matches each.
        k = per_series // 10
        series = [
            Series("a", "random", "v", "v", 10 * k, 0, 6 * k, k, 3 * k, "c"),
            Series("b", "random", "v", "v", 10 * k, 0, 3 * k, k, 6 * k, "c"),
            Series("a", "b", "v", "v", 10 * k, 0, 6 * k, k, 3 * k, "c"),
        ]
        rows = ratings(series, resamples=300)
        for row in rows:
            assert row.low <= row.rating <= row.high
        return {row.name: row.high - row.low for row in rows}

    few, many = widths(10), widths(200)
    for name in ("a", "b"):
        assert few[name] > 2.0 * many[name] > 0.0


def test_ratings_reject_a_missing_anchor_and_unconnected_teams() -> None:
    with pytest.raises(ValueError, match="anchor 'random' played no series"):
        ratings([Series("a", "b", "v", "v", 2, 0, 1, 0, 1, "c")])
    apart = [Series("a", "random", "v", "v", 2, 0, 1, 0, 1, "c"),
             Series("b", "c", "v", "v", 2, 0, 1, 0, 1, "c")]  # fmt: skip
    with pytest.raises(ValueError, match=r"\['b', 'c'\] share no chain of series"):
        ratings(apart)
    with pytest.raises(ValueError, match="virtual_draws=0"):
        ratings(apart, virtual_draws=0)


# --- one set of teams against another --------------------------------------------------
A = ["hierarchical/seed_0", "hierarchical/seed_1", "hierarchical/seed_2"]
B = ["ppo/seed_0", "ppo/seed_1", "ppo/seed_2"]


def grid(wins: list[int], matches: int = 100) -> list[Series]:
    """A_i against every B_j: A_i wins ``wins[i]`` of ``matches``, loses the rest."""
    return [
        Series(a, b, "v", "v", matches, 0, w, 0, matches - w, "c")
        for a, w in zip(A, wins, strict=True)
        for b in B
    ]


def test_cross_score_is_even_for_equal_teams_and_flips_when_sides_swap() -> None:
    even = [Series(a, b, "v", "v", 20, 0, 8, 4, 8, "c") for a in A for b in B]
    estimate = cross_score(even, A, B)
    assert estimate.value == 0.5 and estimate.low < 0.5 < estimate.high
    series = grid([70, 55, 40])
    forward, backward = cross_score(series, A, B), cross_score(series, B, A)
    assert forward.value == pytest.approx(0.55)
    assert backward.value == pytest.approx(1.0 - forward.value)
    assert backward.low == pytest.approx(1.0 - forward.high, abs=0.03)


def test_cross_score_interval_includes_the_spread_between_seeds() -> None:
    same, spread = cross_score(grid([60, 60, 60]), A, B), cross_score(grid([100, 40, 40]), A, B)
    assert same.value == pytest.approx(spread.value) == pytest.approx(0.6)
    assert same.low <= 0.6 <= same.high and spread.low <= 0.6 <= spread.high
    assert spread.high - spread.low > 2.0 * (same.high - same.low)


def test_a_missing_pairing_is_named() -> None:
    series = [s for s in grid([60, 60, 60]) if (s.home, s.away) != (A[1], B[2])]
    with pytest.raises(ValueError, match="hierarchical/seed_1 vs ppo/seed_2"):
        cross_score(series, A, B)
    with pytest.raises(ValueError, match="hierarchical/seed_1 vs ppo/seed_2"):
        pair_records(series, A, B)
    with pytest.raises(ValueError, match="disjoint"):
        cross_score(series, A, A)


def test_missing_pairs_are_left_out_when_allowed() -> None:
    # Two blocks, as when seeds 0-1 were trained in one session and seed 2 in another
    # whose teams could not meet the first block's: A_0, A_1 vs B_0, B_1 and A_2 vs B_2.
    played = {(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)}
    wins = {(0, 0): 80, (0, 1): 70, (1, 0): 60, (1, 1): 50, (2, 2): 30}
    series = [
        Series(A[i], B[j], "v", "v", 100, 0, wins[i, j], 0, 100 - wins[i, j], "c")
        for i, j in sorted(played)
    ]
    estimate = cross_score(series, A, B, allow_missing=True)
    assert estimate.value == pytest.approx(sum(wins.values()) / 100 / len(wins))
    assert estimate.low < estimate.value < estimate.high
    # The pairs that were not played change nothing, whatever they would have been.
    assert cross_score(series, A, B, resamples=0, allow_missing=True).value == estimate.value
    records = pair_records(series, A, B, allow_missing=True)
    assert {(i, j) for i in range(3) for j in range(3) if records[i][j] is None} == {
        (i, j) for i in range(3) for j in range(3) if (i, j) not in played
    }
    assert records[0][1] == Record(70, 0, 30)
    with pytest.raises(ValueError, match="no pair has played"):
        cross_score(series, A[:1], B[2:], allow_missing=True)


def test_pair_records_pool_both_sides_series_in_the_first_sides_view() -> None:
    series = [swapped(s) for s in grid([70, 55, 40], matches=20 * 5)]  # B recorded at home
    records = pair_records(series, A, ["ppo/seed_1", "ppo/seed_0"])
    assert records[0][1] == Record(70, 0, 30) and records[1][0] == Record(55, 0, 45)
    assert records[0][1].score == 0.7


def fake_run(root: Path, name: str, frames: int, env: str = "tennis", **options: object) -> Entrant:
    """A run directory whose checkpoint holds a config but no weights (nothing is played)."""
    config = {"env": {"name": env, "num_envs": 2, "extended_obs": False, **options}}
    state = {"env": env, "config": config, "frames": frames, "actors": {}}
    save_checkpoint(root / name / "checkpoints" / f"step_{frames:09d}.pt", state)
    return Entrant(name, str(root / name))


@pytest.fixture
def plays(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str]]:
    """The pairings played: a stand-in for the matches (home wins all but one)."""
    played: list[tuple[str, str]] = []

    def play(env: str, home: LoadedEntrant, away: LoadedEntrant, matches: int, seed: int) -> Record:
        played.append((home.name, away.name))
        return Record(matches - 1, 1, 0)

    monkeypatch.setattr(tournament, "play_pairing", play)
    return played


def test_store_round_trips_and_a_second_call_plays_nothing(
    tmp_path: Path, plays: list[tuple[str, str]]
) -> None:
    store = tmp_path / "study" / "round_robin.json"
    entrants = [fake_run(tmp_path, "ppo/seed_0", 100), fake_run(tmp_path, "hc/seed_0", 100)]
    first = play_round_robin("tennis", [*entrants, *BUILT_INS], 4, 7, store)
    assert len(plays) == len(first) == 6
    assert load_series(store) == first
    stored = json.loads(store.read_text())["series"][0]
    assert sorted(stored) == sorted(
        ["home", "away", "home_version", "away_version", "matches", "seed", "wins", "draws",
         "losses", "code_version", "home_points", "away_points"]
    )  # fmt: skip
    assert stored["home_version"].startswith("100 frames, step_000000100.pt, sha256 ")
    assert (stored["matches"], stored["seed"], stored["wins"], stored["draws"]) == (4, 7, 3, 1)
    # Same teams in another order (the stored home side is kept): nothing new.
    again = play_round_robin("tennis", [*BUILT_INS, *reversed(entrants)], 4, 7, store)
    assert len(plays) == 6 and sorted(map(str, again)) == sorted(map(str, first))
    assert [p.name for p in store.parent.iterdir()] == ["round_robin.json"]  # no temporaries


def test_involving_plays_only_the_pairings_of_those_teams(
    tmp_path: Path, plays: list[tuple[str, str]]
) -> None:
    # Another study's teams come to meet this study's: their own pairings (with each
    # other and the built-in teams) are that study's, not replayed here.
    own = [fake_run(tmp_path, "mean/seed_0", 100), fake_run(tmp_path, "manager/seed_0", 100)]
    guests = [
        fake_run(tmp_path, "paper/ppo/seed_3", 100),
        fake_run(tmp_path, "paper/hc/seed_3", 100),
    ]
    entrants = [*own, *guests, *BUILT_INS]
    series = play_round_robin("tennis", entrants, 2, 0, tmp_path / "s.json", {e.name for e in own})
    # 15 pairings of 6 entrants, less guest-guest (1), guest-built-in (4), built-in-built-in (1)
    assert len(plays) == len(series) == 9
    assert all({home, away} & {"mean/seed_0", "manager/seed_0"} for home, away in plays)
    with pytest.raises(ValueError, match=r"involving=\['nonesuch'\]: not among the entrants"):
        play_round_robin("tennis", entrants, 2, 0, tmp_path / "s.json", ["nonesuch"])


def test_a_new_checkpoint_or_match_count_replays_only_what_changed(
    tmp_path: Path, plays: list[tuple[str, str]]
) -> None:
    store = tmp_path / "round_robin.json"
    entrants = [fake_run(tmp_path, "ppo/seed_0", 100), fake_run(tmp_path, "hc/seed_0", 100)]
    play_round_robin("tennis", [*entrants, *BUILT_INS], 4, 0, store)
    plays.clear()
    fake_run(tmp_path, "hc/seed_0", 200)  # training went on
    series = play_round_robin("tennis", [*entrants, *BUILT_INS], 4, 0, store)
    assert sorted(plays) == [("hc/seed_0", "random"), ("hc/seed_0", "scripted"),
                             ("ppo/seed_0", "hc/seed_0")]  # fmt: skip
    assert len(load_series(store)) == 6  # replaced, not added
    assert all("200 frames" in s.away_version for s in series if s.away == "hc/seed_0")
    plays.clear()
    play_round_robin("tennis", BUILT_INS, 6, 0, store)
    assert plays == [("scripted", "random")]


def test_a_killed_round_robin_keeps_the_finished_pairings(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store, played = tmp_path / "round_robin.json", list[tuple[str, str]]()

    def killed_on_the_third(env: str, home: LoadedEntrant, away: LoadedEntrant, *_: int) -> Record:
        if len(played) == 2:
            raise KeyboardInterrupt
        played.append((home.name, away.name))
        return Record(1, 0, 1)

    monkeypatch.setattr(tournament, "play_pairing", killed_on_the_third)
    entrants = [*BUILT_INS, fake_run(tmp_path, "x", 1), fake_run(tmp_path, "y", 1)]
    with pytest.raises(KeyboardInterrupt):
        play_round_robin("tennis", entrants, 2, 0, store)
    assert [(s.home, s.away) for s in load_series(store)] == played


def test_entrants_of_another_setting_or_game_are_refused_before_any_match(
    tmp_path: Path, plays: list[tuple[str, str]]
) -> None:
    plain, extended = fake_run(tmp_path, "p", 1), fake_run(tmp_path, "e", 1, extended_obs=True)
    with pytest.raises(ValueError, match=r"'p' and 'e' .* \(extended_obs: \[False\] vs \[True\]\)"):
        play_round_robin("tennis", [*BUILT_INS, plain, extended], 2, 0, tmp_path / "s.json")
    with pytest.raises(ValueError, match="trained on 'soccer'; this round robin plays 'tennis'"):
        play_round_robin("tennis", [plain, fake_run(tmp_path, "s", 1, env="soccer")], 2, 0,
                         tmp_path / "s.json")  # fmt: skip
    with pytest.raises(ValueError, match="each name once"):
        play_round_robin("tennis", [plain, plain], 2, 0, tmp_path / "s.json")
    assert plays == []
    with pytest.raises(FileNotFoundError, match="no round-robin store"):
        load_series(tmp_path / "s.json")


def test_scripted_against_random_on_tennis(tmp_path: Path) -> None:
    store = tmp_path / "round_robin.json"
    (series,) = play_round_robin("tennis", BUILT_INS, 2, 0, store)
    assert (series.home, series.away, series.home_version, series.matches) == (
        "scripted", "random", "scripted", 2,
    )  # fmt: skip
    assert series.wins + series.draws + series.losses == 2 and series.code_version
    # Tennis matches end on points: both were counted, and the winner of the series
    # (scripted beats random) won more of them.
    assert series.home_points > series.away_points >= 0
    record = series.record_of("random")
    assert (record.points_won, record.points_lost) == (series.away_points, series.home_points)
    assert load_series(store) == [series]
