"""Play diagnostics: what a trained team does, beyond who wins.

| module | game | measures |
|---|---|---|
| :mod:`~rlhc.evaluation.diagnostics.tennis` | tennis | hits per point, the policy's noise near the ball and elsewhere, saturated actions, moves toward the ball |
| :mod:`~rlhc.evaluation.diagnostics.soccer` | soccer | against the scripted team and in self-play: goals, shots and how they end, where the ball and players are, touches, action shares |

``python -m rlhc.evaluation.diagnostics <run dir or .pt>`` prints the diagnostics of a
team's game as JSON (:func:`diagnose` picks them by the team's game).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from rlhc.evaluation.diagnostics.soccer import soccer_diagnostics
from rlhc.evaluation.diagnostics.tennis import tennis_diagnostics

#: game name -> its diagnostics ``(state, *, worlds, decisions, seed) -> dict``.
DIAGNOSTICS: dict[str, Callable[..., dict[str, Any]]] = {
    "soccer": soccer_diagnostics,
    "tennis": tennis_diagnostics,
}


def diagnose(
    state: Mapping[str, Any], *, worlds: int = 32, decisions: int = 1000, seed: int = 0
) -> dict[str, Any]:
    """The play diagnostics of a loaded team (:func:`rlhc.storage.final_team.load_team`);
    :class:`ValueError` if there are none for its game."""
    game = state["env"]
    if game not in DIAGNOSTICS:
        raise ValueError(
            f"no play diagnostics for {game!r}; there are for: {', '.join(sorted(DIAGNOSTICS))}"
        )
    return DIAGNOSTICS[game](state, worlds=worlds, decisions=decisions, seed=seed)


__all__ = ["DIAGNOSTICS", "diagnose", "soccer_diagnostics", "tennis_diagnostics"]
