"""A study's final teams in a round robin: entrants, the stored series, playing them.

**Entrants and versions.** An :class:`Entrant` is a run directory (its committed
``final_team.pt``, else its newest checkpoint that loads: :func:`rlhc.storage.final_team.load_team`)
or a built-in team (``scripted``, ``random``). Its *version* names what plays: for a run,
the file's frames, name and the first 12 hex digits of its SHA-256 (a run retrained into
the same directory gets a new version even with the same file names); for a built-in,
its name.

**The store** (``round_robin.json``, one per study) holds one series per unordered pair
of entrant names: who was home, both versions, the match count, the seed, the home
side's wins, draws and losses, the points each side won, and the code version that
played it.
:func:`play_round_robin` plays only the pairings whose stored series has other
versions, match count or seed (or is absent), and rewrites the store after each one
(a temporary file renamed over it), so a kill loses at most the pairing in progress.
The code version is provenance only: a new commit does not replay the study.

The statistics of the series are :mod:`reporting.ratings`'s.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import secrets
import time
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rlhc.evaluation.elo import round_robin

STORE_FORMAT = 2
#: Worlds simulated at once in a series (as :func:`.head_to_head.play_series`).
MAX_WORLDS = 32


@dataclass(frozen=True)
class Record:
    """Wins, draws and losses of one side over a number of matches, and the points
    (tennis points, soccer goals) it won and lost in them.

    Examples:
        >>> Record(3, 2, 1).score, Record(3, 2, 1, 9, 4).flipped()
        (0.6666666666666666, Record(wins=1, draws=2, losses=3, points_won=4, points_lost=9))
    """

    wins: int
    draws: int
    losses: int
    points_won: int = 0
    points_lost: int = 0

    @property
    def matches(self) -> int:
        """Matches played."""
        return self.wins + self.draws + self.losses

    @property
    def score(self) -> float:
        """Wins plus half the draws, per match (0.5: even; ``nan`` without matches)."""
        return (self.wins + 0.5 * self.draws) / self.matches if self.matches else math.nan

    @property
    def points_share(self) -> float:
        """Share of the points played that this side won (``nan``: no point scored)."""
        played = self.points_won + self.points_lost
        return self.points_won / played if played else math.nan

    def flipped(self) -> Record:
        """The same matches from the other side."""
        return Record(self.losses, self.draws, self.wins, self.points_lost, self.points_won)

    def __add__(self, other: Record) -> Record:
        return Record(
            *(
                a + b
                for a, b in zip(dataclasses.astuple(self), dataclasses.astuple(other), strict=True)
            )
        )


@dataclass(frozen=True)
class Entrant:
    """A team of the round robin.

    Attributes:
        name: its name in the tables, e.g. ``"ppo/seed_0"`` or ``"scripted"``.
        spec: a run directory or checkpoint file, or a built-in team's name.
    """

    name: str
    spec: str


@dataclass(frozen=True)
class LoadedEntrant:
    """An entrant with its checkpoint read once: what plays and how it is named.

    Attributes:
        name: the entrant's name; ``spec`` likewise.
        version: see the module docstring.
        options: the observation options of its game (empty for a built-in).
        state: the file's :data:`rlhc.storage.final_team.TEAM_KEYS` and ``path``; ``None`` for
            a built-in.
    """

    name: str
    spec: str
    version: str
    options: Mapping[str, Any]
    state: Mapping[str, Any] | None


@dataclass(frozen=True)
class Series:
    """Matches of ``home`` against ``away``; wins, draws and losses are home's, and
    ``home_points`` / ``away_points`` the points (soccer: goals) each side won in them.

    Raises:
        ValueError: a count is negative, they do not add up to ``matches``, or a team
            plays itself.
    """

    home: str
    away: str
    home_version: str
    away_version: str
    matches: int
    seed: int
    wins: int
    draws: int
    losses: int
    code_version: str
    home_points: int = 0
    away_points: int = 0

    def __post_init__(self) -> None:
        counts = (self.wins, self.draws, self.losses)
        if min(counts) < 0 or sum(counts) != self.matches or self.matches < 1:
            raise ValueError(
                f"series {self.home!r} vs {self.away!r}: wins/draws/losses {counts} must be "
                f">= 0 and add up to matches={self.matches} (>= 1)"
            )
        if self.home == self.away:
            raise ValueError(f"series of {self.home!r} against itself; allowed: two teams")

    def record_of(self, name: str) -> Record:
        """The record from ``name``'s side (home or away)."""
        if name not in (self.home, self.away):
            raise ValueError(f"{name!r} did not play the series {self.home!r} vs {self.away!r}")
        record = Record(self.wins, self.draws, self.losses, self.home_points, self.away_points)
        return record if name == self.home else record.flipped()


# --- entrants and the store ----------------------------------------------------------
def load_entrant(entrant: Entrant, env_name: str) -> LoadedEntrant:
    """Read ``entrant``'s team file once: its version, options and policy weights.

    Raises:
        FileNotFoundError: the spec is neither a built-in team nor a final team or
            checkpoint.
        ValueError: the file was trained on another game (both named).
    """
    from rlhc.evaluation.opponents import is_built_in
    from rlhc.evaluation.policies import observation_options
    from rlhc.storage.final_team import TEAM_KEYS, load_team

    if is_built_in(entrant.spec):
        return LoadedEntrant(entrant.name, entrant.spec, entrant.spec, {}, None)
    state = load_team(entrant.spec)
    if state["env"] != env_name:
        raise ValueError(
            f"entrant {entrant.name!r} ({state['path']}) was trained on {state['env']!r}; "
            f"this round robin plays {env_name!r}"
        )
    path = Path(state["path"])
    digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    version = f"{state['frames']} frames, {path.name}, sha256 {digest}"
    kept = {key: state[key] for key in (*TEAM_KEYS, "path") if key in state}
    return LoadedEntrant(entrant.name, entrant.spec, version, observation_options(state), kept)


def shared_options(entrants: Sequence[LoadedEntrant]) -> dict[str, Any]:
    """The observation options every checkpoint entrant was trained with.

    Raises:
        ValueError: two checkpoint entrants differ (both and the keys are named): a
            study is one configuration of the game.
    """
    trained = [e for e in entrants if e.state is not None]
    for entrant in trained[1:]:
        if dict(entrant.options) != dict(trained[0].options):
            keys = sorted(
                k
                for k in {*entrant.options, *trained[0].options}
                if entrant.options.get(k) != trained[0].options.get(k)
            )
            raise ValueError(
                f"entrants {trained[0].name!r} and {entrant.name!r} were trained with "
                f"different observation options ({', '.join(keys)}: "
                f"{[trained[0].options.get(k) for k in keys]} vs "
                f"{[entrant.options.get(k) for k in keys]}); one round robin is one game setting"
            )
    return dict(trained[0].options) if trained else {}


def play_pairing(
    env_name: str, home: LoadedEntrant, away: LoadedEntrant, matches: int, seed: int
) -> Record:
    """``matches`` matches of ``home`` against ``away``: home's record.

    As :func:`.head_to_head.play_series` (same seeding, worlds and rules; sides swapped
    every match; deterministic actions), but from the weights read by
    :func:`load_entrant`, so what plays is what the version names even if a training
    process writes a newer checkpoint meanwhile.
    """
    # Imported here: torch and the games are only needed when matches are played.
    from rlhc.evaluation.matches import default_rules, make_match_env, play_matches
    from rlhc.evaluation.opponents import make_team_policy
    from rlhc.evaluation.policies import restore_policy
    from rlhc.storage.checkpoint import seed_everything

    seed_everything(seed)
    # The options come from the checkpoints already read (shared_options), not re-read.
    options = shared_options([home, away])
    env = make_match_env(env_name, min(MAX_WORLDS, matches), seed, [], options)
    try:
        home_policy, away_policy = (
            make_team_policy(e.spec, env) if e.state is None else restore_policy(e.state, env)
            for e in (home, away)
        )
        rules = default_rules(env_name, env.game.max_cycles)
        result = play_matches(
            env, home_policy, away_policy, matches, rules, names=(home.name, away.name)
        )
    finally:
        env.close()
    outcomes = result.outcomes
    return Record(
        int((outcomes > 0).sum()),
        int((outcomes == 0).sum()),
        int((outcomes < 0).sum()),
        int(result.home_points.sum()),
        int(result.away_points.sum()),
    )


def load_series(store: str | os.PathLike[str]) -> list[Series]:
    """The series of a store, in stored order (to build the report without playing).

    Raises:
        FileNotFoundError: there is no store (named).
        ValueError: it is not a store of this format, or a series is malformed (named).
    """
    path = Path(store)
    if not path.is_file():
        raise FileNotFoundError(f"no round-robin store {str(path)!r}; play_round_robin writes it")
    return _read_store(path)[1]


def _read_store(path: Path) -> tuple[str | None, list[Series]]:
    """``(game, series)`` of a store; ``(None, [])`` if there is none yet."""
    if not path.is_file():
        return None, []
    data = json.loads(path.read_text())
    if not isinstance(data, dict) or data.get("format") != STORE_FORMAT:
        raise ValueError(f"{str(path)!r} is not a round-robin store of format {STORE_FORMAT}")
    fields = [f.name for f in dataclasses.fields(Series)]
    series = []
    for index, item in enumerate(data["series"]):
        if sorted(item) != sorted(fields):
            raise ValueError(f"{str(path)!r} series {index}: fields {sorted(item)}; need {fields}")
        series.append(Series(**item))
    return data["env"], series


def _write_store(path: Path, env_name: str, series: Sequence[Series]) -> None:
    """Write the store atomically: a temporary file in its directory, renamed over it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {
        "format": STORE_FORMAT,
        "env": env_name,
        "series": [dataclasses.asdict(s) for s in series],
    }
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        with tmp.open("x") as f:
            f.write(json.dumps(data, indent=1) + "\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _is_current(
    stored: Series, home: LoadedEntrant, away: LoadedEntrant, matches: int, seed: int
) -> bool:
    """Whether ``stored`` is the series these two entrants would play now (either side home)."""
    versions = {stored.home: stored.home_version, stored.away: stored.away_version}
    return (
        {stored.home, stored.away} == {home.name, away.name}
        and versions == {home.name: home.version, away.name: away.version}
        and (stored.matches, stored.seed) == (matches, seed)
    )


def play_round_robin(
    env_name: str,
    entrants: Sequence[Entrant],
    matches: int,
    seed: int,
    store: str | os.PathLike[str],
    involving: Collection[str] | None = None,
) -> list[Series]:
    """Play every pairing of ``entrants`` the store does not hold as it would be played now.

    Args:
        env_name: the game; every checkpoint must be of it, with the same observation
            options.
        entrants: the teams, each name once; the first of a pairing is home.
        matches: matches per pairing (half with each team on each side).
        seed: seeds every series (python, numpy, torch and the game).
        store: the study's ``round_robin.json`` (created if absent).
        involving: only the pairings with at least one of these entrants (e.g. a study's
            own teams, when other entrants are another study's, already matched there);
            ``None``: every pairing.

    Returns:
        The series of those pairings, in round-robin order.

    Raises:
        ValueError: fewer than 2 entrants, a repeated name, ``matches < 1``, entrants
            of another game or of differing options, a store of another game, or a name
            in ``involving`` that is not an entrant.
    """
    from .summary import code_version

    names = [e.name for e in entrants]
    if len(set(names)) != len(names) or len(names) < 2:
        raise ValueError(f"entrants {names}: need at least 2, each name once")
    if matches < 1:
        raise ValueError(f"matches={matches}; allowed: an integer >= 1")
    unknown = sorted(set(involving or ()) - set(names))
    if unknown:
        raise ValueError(f"involving={unknown}: not among the entrants {names}")
    path = Path(store)
    stored_env, stored = _read_store(path)
    if stored_env not in (None, env_name):
        raise ValueError(f"store {str(path)!r} holds {stored_env!r} series, not {env_name!r}")
    loaded = {e.name: load_entrant(e, env_name) for e in entrants}
    shared_options(list(loaded.values()))  # fail before the first match, not mid-way
    pairings = [
        (a, b) for a, b in round_robin(names) if involving is None or {a, b} & set(involving)
    ]
    todo = [
        (a, b)
        for a, b in pairings
        if not any(_is_current(s, loaded[a], loaded[b], matches, seed) for s in stored)
    ]
    print(f"round robin of {len(names)} teams: {len(pairings) - len(todo)} of "
          f"{len(pairings)} pairings stored in {path}, {len(todo)} to play", flush=True)  # fmt: skip
    version = code_version() if todo else ""
    for index, (a, b) in enumerate(todo, start=1):
        start = time.perf_counter()
        record = play_pairing(env_name, loaded[a], loaded[b], matches, seed)
        played = Series(
            a, b, loaded[a].version, loaded[b].version, matches, seed,
            record.wins, record.draws, record.losses, version,
            record.points_won, record.points_lost,
        )  # fmt: skip
        stored = [s for s in stored if {s.home, s.away} != {a, b}] + [played]
        _write_store(path, env_name, stored)
        print(f"pairing {index} of {len(todo)}: {a} vs {b}: {record.wins}-{record.draws}-"
              f"{record.losses} in {time.perf_counter() - start:.1f} s", flush=True)  # fmt: skip
    return [
        next(s for s in stored if _is_current(s, loaded[a], loaded[b], matches, seed))
        for a, b in pairings
    ]
