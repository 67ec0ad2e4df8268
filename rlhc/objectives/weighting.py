"""PPO under the learner weight: the experiences of a league world's opponents add nothing.

In a league world (:mod:`rlhc.training.league`) one team plays the learning policy and
the other an opponent; both teams' experiences are collected, but only the learner's
may train it. Each experience weighs 1 where the learning policy chose the action
(``(g, "learner")``; all ones without a league) and 0 elsewhere. TorchRL's
``reduction`` and ``normalize_advantage`` average every sample alike, so
:func:`learner_weighted_loss` takes a loss's per-sample terms and reduces them itself.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torch import Tensor

from rlhc.objectives.ppo import LOSS_KEYS, HierarchicalPPOLoss, LossTerms

#: Sums a tensor over the processes sharing a minibatch (data-parallel training).
Reduce = Callable[[Tensor], Tensor]

#: Loss-output diagnostics reported per group (those the loss writes).
DIAGNOSTICS: tuple[str, ...] = (
    "loss_objective",
    "loss_critic",
    "loss_worker_critic",
    "loss_manager_critic",
    "loss_entropy",
    "entropy",
    "kl_approx",
    "clip_fraction",
    "explained_variance",
    "explained_variance_worker",
    "explained_variance_manager",
)


def learner_weight(data: TensorDictBase, learner_key: NestedKey, like: Tensor) -> Tensor:
    """``float [B, n_g]``: 1 where the learning policy chose the action, else 0; all
    ones where ``data`` has no ``learner_key``. ``like`` is a per-agent entry
    ``[*B, n_g, ...]``, for the shape.

    Examples:
        >>> from tensordict import TensorDict
        >>> data = TensorDict({"g": {"learner": torch.tensor([[[True], [False]]])}}, [1])
        >>> learner_weight(data, ("g", "learner"), torch.zeros(1, 2, 1))
        tensor([[1., 0.]])
    """
    learner = data.get(learner_key, None)
    if learner is None:
        return torch.ones(like.shape[: data.ndim + 1], device=like.device)
    return learner.reshape(*learner.shape[: data.ndim + 1]).float()


def weighted_mean(value: Tensor, weight: Tensor, total: Tensor | None = None) -> Tensor:
    """The mean of a per-sample ``value`` (``weight.numel()`` elements) under ``weight``;
    a scalar ``value`` is returned as it is. ``total`` replaces ``weight.sum()`` as the
    denominator: the whole minibatch's weight when this process holds only its share.

    Examples:
        >>> weighted_mean(torch.tensor([[1.0, 5.0], [3.0, 7.0]]), torch.tensor([[1.0, 0.0], [1.0, 0.0]]))
        tensor(2.)
    """
    if value.dim() == 0:
        return value
    denominator = weight.sum() if total is None else total
    return (value.reshape(weight.shape) * weight).sum() / denominator.clamp_min(1.0)


def standardise_advantage(
    data: TensorDictBase, advantage_key: NestedKey, weight: Tensor, reduce: Reduce | None = None
) -> None:
    """Standardise the advantage ``[B, n_g, 1]`` of a minibatch in place, per agent slot
    (as TorchRL's MAPPO), over the experiences of weight 1 only; ``reduce`` sums the
    statistics over the processes holding the rest of the minibatch."""
    reduce = reduce or (lambda tensor: tensor)
    advantage = data[advantage_key]
    shaped = advantage.reshape(weight.shape)
    sums = reduce(torch.stack([weight.sum(dim=0), (shaped * weight).sum(dim=0)]))
    count = sums[0].clamp_min(1.0)
    mean = sums[1] / count
    var = reduce((((shaped - mean) ** 2) * weight).sum(dim=0)) / count
    standard = (shaped - mean) / (var.sqrt() + 1e-8)
    data.set(advantage_key, standard.reshape(advantage.shape))


class WeightedLoss(NamedTuple):
    """The sum of the :data:`~rlhc.objectives.ppo.LOSS_KEYS` terms (with gradient), and
    the :data:`DIAGNOSTICS` the loss wrote, each averaged under the learner weight of
    this process's share: detached scalars, so that nothing waits on the device."""

    total: Tensor
    diagnostics: dict[str, Tensor]


def learner_weighted_loss(
    loss: HierarchicalPPOLoss,
    minibatch: TensorDictBase,
    *,
    normalize_advantage: bool,
    reduce: Reduce | None = None,
) -> WeightedLoss:
    """One group's PPO loss on a minibatch, every term averaged under the learner weight.

    Args:
        loss: the group's loss, built for per-sample terms (``reduction="none"``,
            ``normalize_advantage=False``).
        minibatch: a flat minibatch ``[B]`` holding the advantage and value target.
        normalize_advantage: standardise the advantage in place, per agent slot, over
            the learner's experiences (:func:`standardise_advantage`).
        reduce: sums over the processes sharing the minibatch (data-parallel): each term
            is then a mean over the whole minibatch, and the gradients summed over the
            processes are those of one process; ``None`` for one process.

    Raises:
        ValueError: the loss reduces or standardises on its own.
    """
    if loss.reduction != "none" or loss.normalize_advantage:
        raise ValueError(
            "learner_weighted_loss needs per-sample terms: build the loss with "
            "reduction='none' and normalize_advantage=False (got reduction="
            f"{loss.reduction!r}, normalize_advantage={loss.normalize_advantage})"
        )
    keys = loss.tensor_keys
    weight = learner_weight(minibatch, keys.learner, minibatch[keys.advantage])
    total_weight = reduce(weight.sum()) if reduce is not None else None
    if normalize_advantage:
        standardise_advantage(minibatch, keys.advantage, weight, reduce)
    terms = loss.terms(minibatch)
    out = terms.values
    total = sum(weighted_mean(out[term], weight, total_weight) for term in LOSS_KEYS)
    diagnostics = {
        key: weighted_mean(out[key].detach().float(), weight) for key in DIAGNOSTICS if key in out
    }
    if minibatch.get(keys.learner, None) is not None:
        # TorchRL averages these over every experience, the opponents' included.
        diagnostics.update(policy_diagnostics(loss, terms, weight))
    return WeightedLoss(total, diagnostics)  # type: ignore[arg-type]


def policy_diagnostics(
    loss: HierarchicalPPOLoss, terms: LossTerms, weight: Tensor
) -> dict[str, Tensor]:
    """``kl_approx``, ``clip_fraction`` and ``entropy`` of the current policy on a
    minibatch, each averaged under ``weight``.

    ``ClipPPOLoss`` averages these over every experience, and in a league world half of
    them were chosen by an opponent, whose log-probabilities make the ratio meaningless.
    Per experience as ``ClipPPOLoss`` computes them (from :meth:`~rlhc.objectives.ppo.
    HierarchicalPPOLoss.terms`): ``kl_approx = log pi_old(a) - log pi(a)``, clipped where
    the ratio leaves ``[1 - eps, 1 + eps]``, the entropy.
    """
    log_weight = terms.log_weight
    clipped = log_weight.clamp(*loss.log_ratio_bounds()) != log_weight
    return {
        "kl_approx": weighted_mean(-log_weight, weight),
        "clip_fraction": weighted_mean(clipped.float(), weight),
        "entropy": weighted_mean(terms.entropy, weight),
    }
