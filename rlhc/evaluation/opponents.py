"""Team policies by name: what plays one side of a match.

A *team policy* (:class:`~rlhc.evaluation.teams.TeamPolicy`) maps the env's current
TensorDict to an action for every agent of every group; a *player spec* names one:

| spec | policy |
|---|---|
| ``random`` | uniform over each agent's action space (:class:`~rlhc.evaluation.teams.RandomPolicy`) |
| ``scripted`` | the game's scripted team of the registry (:class:`~rlhc.evaluation.teams.ScriptedPolicy`) |
| a path | a checkpoint or final-team file, or a run directory (its ``final_team.pt``, else its newest checkpoint: :func:`rlhc.storage.final_team.load_team`) |
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rlhc.envs.keys import RANDOM, SCRIPTED
from rlhc.envs.torchrl_adapter import BatchedGameEnv
from rlhc.errors import ConfigError
from rlhc.evaluation.policies import observation_options, restore_policy
from rlhc.evaluation.teams import RandomPolicy, ScriptedPolicy, TeamPolicy
from rlhc.storage.final_team import load_team

#: The player specs of the built-in teams.
BUILT_IN = (RANDOM, SCRIPTED)


def load_policy_checkpoint(spec: str, env_name: str) -> dict[str, Any]:
    """Load what plays for ``spec`` (:func:`~rlhc.storage.final_team.load_team`) and check it was
    trained on ``env_name``.

    Raises:
        FileNotFoundError: the path does not exist or holds no checkpoint (named).
        ValueError: the checkpoint is from another game (names the path and both games).
    """
    state = load_team(spec)
    if state["env"] != env_name:
        raise ValueError(
            f"checkpoint {spec!r} ({state['path']}) was trained on {state['env']!r}, "
            f"but this evaluation plays {env_name!r}"
        )
    return state


def is_built_in(spec: str) -> bool:
    """Whether ``spec`` names a built-in opponent rather than a checkpoint path."""
    return spec in BUILT_IN


def player_options(specs: list[str], env_name: str) -> dict[str, Any]:
    """The observation-affecting game options the checkpoint players agree on.

    Raises:
        ValueError: two checkpoints were trained with different options (named).
    """
    agreed: dict[str, Any] = {}
    source: dict[str, str] = {}
    for spec in specs:
        if is_built_in(spec):
            continue
        for key, value in observation_options(load_policy_checkpoint(spec, env_name)).items():
            if key in agreed and agreed[key] != value:
                raise ValueError(
                    f"checkpoints {source[key]!r} and {spec!r} disagree on env option "
                    f"{key}: {agreed[key]!r} vs {value!r}; they cannot play in one env"
                )
            agreed[key], source[key] = value, spec
    return agreed


def check_players(players: Mapping[str, str], env_name: str) -> None:
    """Refuse, before a match is played, a player that cannot play ``env_name``: a path
    that holds no checkpoint of this game, or checkpoints that disagree on the options
    that shape observations.

    ``players`` maps a setting to a player spec, e.g. ``{"home": "scripted", "away": path}``;
    the :class:`ConfigError` names the setting, its value and what is wrong.

    Examples:
        >>> check_players({"home": "scripted", "away": "random"}, "soccer")
        >>> check_players({"home": "scriptd"}, "soccer")
        Traceback (most recent call last):
        ...
        rlhc.errors.ConfigError: home='scriptd' is neither a built-in team (random, scripted) nor an existing checkpoint file or run directory
    """
    for setting, spec in players.items():
        if is_built_in(spec):
            continue
        if not Path(spec).expanduser().exists():
            raise ConfigError(
                f"{setting}={spec!r} is neither a built-in team ({', '.join(BUILT_IN)}) "
                "nor an existing checkpoint file or run directory"
            )
        try:
            load_policy_checkpoint(spec, env_name)
        except (FileNotFoundError, ValueError) as error:
            raise ConfigError(f"{setting}={spec!r}: {error}") from None
    try:
        player_options(list(players.values()), env_name)
    except ValueError as error:
        raise ConfigError(str(error)) from None


def make_team_policy(spec: str, env: BatchedGameEnv) -> TeamPolicy:
    """The team policy named ``spec`` (module table) in the match ``env``.

    Examples:
        >>> from rlhc.envs import make_env
        >>> env = make_env("tennis", num_envs=2, seed=0)
        >>> make_team_policy("scripted", env)(env.reset())["racket"].shape
        torch.Size([2, 4, 3])
    """
    if spec == RANDOM:
        return RandomPolicy(env)
    if spec == SCRIPTED:
        return ScriptedPolicy(env)
    if not Path(spec).expanduser().exists():
        raise FileNotFoundError(
            f"player {spec!r} is neither a built-in opponent ({', '.join(BUILT_IN)}) "
            "nor an existing checkpoint file or run directory"
        )
    return restore_policy(load_policy_checkpoint(spec, env.game.name), env)
