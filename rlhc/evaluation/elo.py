"""Elo ratings from match outcomes.

A match gives player A the score ``S = 1`` (win), ``0.5`` (draw) or ``0`` (loss).
Elo (1978) models the expected score of A against B as

    E_A = 1 / (1 + 10 ** ((R_B - R_A) / 400))

and after each match moves both ratings by the surprise, scaled by ``K``:

    R_A' = R_A + K (S - E_A),    R_B' = R_B - K (S - E_A)

so the total rating is conserved. A round robin interleaves the pairings (match 0 of
every pairing, then match 1, …) so that no pairing is rated before the others.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

INITIAL_RATING = 1200.0
K_FACTOR = 32.0


def expected_score(rating: float, opponent: float) -> float:
    """Expected score of a player rated ``rating`` against one rated ``opponent``.

    Examples:
        >>> expected_score(1200, 1200)
        0.5
        >>> round(expected_score(1600, 1200), 4)
        0.9091
    """
    return 1.0 / (1.0 + 10.0 ** ((opponent - rating) / 400.0))


def elo_update(
    rating: float, opponent: float, score: float, k: float = K_FACTOR
) -> tuple[float, float]:
    """``(rating, opponent)`` after one match in which the first player scored ``score``
    (1 win, 0.5 draw, 0 loss); ``k`` is the largest possible change.

    Examples:
        >>> [round(r, 2) for r in elo_update(1200, 1000, 0.0, k=32)]  # the favourite loses
        [1175.69, 1024.31]
    """
    if not 0.0 <= score <= 1.0:
        raise ValueError(f"score must lie in [0, 1], got {score}")
    change = k * (score - expected_score(rating, opponent))
    return rating + change, opponent - change


@dataclass
class EloTable:
    """Ratings of named players, updated match by match (``initial``: a newcomer's rating).

    Examples:
        >>> table = EloTable(k=32)
        >>> table.record("scripted", "random", 1.0)
        >>> table.ratings
        {'scripted': 1216.0, 'random': 1184.0}
    """

    k: float = K_FACTOR
    initial: float = INITIAL_RATING
    ratings: dict[str, float] = field(default_factory=dict)
    games: dict[str, int] = field(default_factory=dict)

    def add(self, player: str) -> None:
        """Enter ``player`` at the initial rating (no-op if already rated)."""
        self.ratings.setdefault(player, self.initial)
        self.games.setdefault(player, 0)

    def record(self, player: str, opponent: str, score: float) -> None:
        """Apply one match in which ``player`` scored ``score`` against ``opponent``."""
        if player == opponent:
            raise ValueError(f"a player cannot be rated against itself: {player!r}")
        self.add(player)
        self.add(opponent)
        self.ratings[player], self.ratings[opponent] = elo_update(
            self.ratings[player], self.ratings[opponent], score, self.k
        )
        self.games[player] += 1
        self.games[opponent] += 1

    def record_pairings(self, scores: Mapping[tuple[str, str], Sequence[float]]) -> None:
        """Apply ``(player, opponent) -> [score of player in match 0, 1, …]``, interleaved."""
        for player, opponent in scores:
            self.add(player)
            self.add(opponent)
        longest = max((len(s) for s in scores.values()), default=0)
        for index in range(longest):
            for (player, opponent), pairing in scores.items():
                if index < len(pairing):
                    self.record(player, opponent, pairing[index])

    def standings(self) -> list[tuple[str, float, int]]:
        """``(player, rating, games)``, best first."""
        return sorted(
            ((p, r, self.games[p]) for p, r in self.ratings.items()), key=lambda row: -row[1]
        )

    def format(self) -> str:
        """The standings as a fixed-width text table."""
        rows = self.standings()
        width = max([len("player"), *(len(p) for p, _, _ in rows)])
        lines = [f"{'player':<{width}}  {'elo':>7}  {'games':>5}"]
        lines += [f"{p:<{width}}  {r:7.1f}  {g:5d}" for p, r, g in rows]
        return "\n".join(lines)


def round_robin(players: Iterable[str]) -> list[tuple[str, str]]:
    """Every unordered pairing of distinct players once, in a stable order.

    Examples:
        >>> round_robin(["a", "b", "c"])
        [('a', 'b'), ('a', 'c'), ('b', 'c')]
    """
    names = list(dict.fromkeys(players))
    return [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
