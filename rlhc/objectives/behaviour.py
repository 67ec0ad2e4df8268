"""The behaviour policy's log-probabilities, scored the way the loss scores them.

PPO's ratio divides the current policy's log-probability of each stored action by the
behaviour policy's, stored at sampling time. A ``TanhNormal`` stores the log-probability
of the pre-tanh sample it drew, but the loss can only rescore the stored (squashed)
action, through ``atanh``: where the pre-tanh value is large (actions within ~1e-3 of a
bound, float32) the two disagree (pre-tanh 6: up to 0.2 nats; 7: over 1; 8: hundreds). The ratio is then wrong
before any update: a trained tennis policy (``long_bounded``, 10 M court-decisions)
rescored on its own batch gives a KL of 0.053 at unchanged weights and 1.4 % of its
experiences outside the clip range. :func:`rescore_log_prob`, run before the first
epoch, replaces the stored value with the loss's own scoring under the same weights:
ratios start at exactly 1 and the errors cancel in the ratio. Exact only while the
weights are the behaviour policy's (one process, or data-parallel; not the pipeline,
whose batches were collected one update earlier).
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from rlhc.objectives.ppo import HierarchicalPPOLoss


def rescore_log_prob(loss: HierarchicalPPOLoss, batch: TensorDictBase) -> None:
    """Overwrite the batch's stored log-probabilities of the learner's actions with the
    loss's actor's scoring of those actions (in place, without gradient).

    Experiences that a league opponent chose (``(g, "learner")`` false) keep their stored
    value: they weigh nothing in the loss, and a built-in team's action may sit on the
    bound, where ``atanh`` is infinite.

    Args:
        loss: the group's loss (its actor and keys).
        batch: collected experiences of any batch shape, weights unchanged since.

    Examples:
        What the stored value and a rescoring disagree by, at a pre-tanh mean of 7:

        >>> from torchrl.modules.distributions import TanhNormal
        >>> _ = torch.manual_seed(0)
        >>> tanh = TanhNormal(torch.full((1000, 1), 7.0), torch.full((1000, 1), 0.02))
        >>> action, stored = tanh.sample_and_log_prob()
        >>> round(float((tanh.log_prob(action) - stored).abs().max()), 1)  # nats
        1.3
    """
    keys = loss.tensor_keys
    with torch.no_grad():
        dist = loss.actor_network.get_dist(batch)
        stored = batch.get(keys.sample_log_prob)
        scored = dist.log_prob(batch.get(keys.action)).reshape(stored.shape)
        learner = batch.get(keys.learner, None)
        if learner is not None:
            scored = torch.where(learner.reshape(stored.shape), scored, stored)
    batch.set(keys.sample_log_prob, scored)
