"""Trajectories cut at the time horizon, as ML-Agents 0.5 cuts them before its estimate."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from tensordict import TensorDictBase

from rlhc.envs.keys import DONE, NEXT


def cut_trajectories(batch: TensorDictBase, groups: Sequence[str], horizon: int) -> None:
    """Cut every world's trajectory each ``horizon`` decisions of ``batch`` ``[N, T]``.

    ML-Agents cuts an agent's trajectory every ``time_horizon`` decisions and bootstraps
    there. A cut is a ``done`` that is not ``terminated`` (set in place on each group's
    ``("next", g, "done")``): GAE stops accumulating at it and bootstraps from the next
    observation's value. Nothing changes when ``T <= horizon``: the end of a batch is a
    cut anyway.

    Args:
        batch: collected data of batch size ``[N, T]`` (worlds, decisions).
        groups: the agent groups whose done flags are cut.
        horizon: decisions between two cuts (``algo.time_horizon``).

    Examples:
        >>> from tensordict import TensorDict
        >>> batch = TensorDict({"next": {"g": {"done": torch.zeros(1, 5, 2, 1, dtype=torch.bool)}}}, [1, 5])
        >>> cut_trajectories(batch, ["g"], 2)
        >>> batch["next", "g", "done"][0, :, 0, 0].tolist()
        [False, True, False, True, False]
    """
    steps = batch.shape[-1]
    if steps <= horizon:
        return
    cut = torch.zeros(steps, dtype=torch.bool, device=batch.device)
    cut[horizon - 1 :: horizon] = True
    for group in groups:
        done = batch[NEXT, group, DONE]
        shape = (1, steps) + (1,) * (done.dim() - 2)
        batch[NEXT, group, DONE] = done | cut.view(shape)
