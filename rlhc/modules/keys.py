"""TensorDict key leaves shared by the networks and the learning core.

Every key of the TensorDict contract (``/work/shared/DESIGN.md``) that this package
reads or writes lives under a group, e.g. ``("racket", OBSERVATION)``. The leaves are
defined once here so that a renamed key is a one-line change, and so that the
estimator (:mod:`rlhc.objectives`) and the networks can never disagree.
"""

from __future__ import annotations

from tensordict.utils import NestedKey

#: Worker observation ``[*B, n_g, d_w]``: read by the actor and the worker critic.
OBSERVATION = "observation"
#: The team manager's view of each agent ``[*B, n_g, d_m]``: read by the manager critic.
MANAGER_OBSERVATION = "manager_observation"
#: The agent's action (continuous ``[*B, n_g, size]`` or discrete ``[*B, n_g]``).
ACTION = "action"
#: Log-probability of the sampled action, written by ``ProbabilisticActor``
#: (``<action leaf>_log_prob`` in TorchRL 0.14 when log-probs are not aggregated).
ACTION_LOG_PROB = "action_log_prob"
#: Gaussian parameters and logits: intermediate actor outputs.
LOC = "loc"
SCALE = "scale"
LOGITS = "logits"
#: The shared trunk's features ``[*B, n_g, hidden_size]`` (``model.shared_trunk``):
#: written by the trunk, read by the policy head and the worker-value head.
HIDDEN = "hidden"
#: ``V_w(o_w)``: the worker critic's value ``[*B, n_g, 1]``.
WORKER_VALUE = "worker_value"
#: ``V_m(o_m)``: the manager critic's value ``[*B, n_g, 1]``.
MANAGER_VALUE = "manager_value"
#: The fused value ``V_hat`` that GAE uses (TorchRL's default ``value`` leaf).
STATE_VALUE = "state_value"
#: Share of the fused value that came from the manager critic ``[*B, n_g, 1]``.
MANAGER_SELECTED = "manager_selected"
ADVANTAGE = "advantage"
VALUE_TARGET = "value_target"
REWARD = "reward"
DONE = "done"
TERMINATED = "terminated"
TRUNCATED = "truncated"
#: Root key: steps taken in the episode before this observation (0 at reset).
STEP_COUNT = "step_count"


def group_key(group: str, leaf: str) -> NestedKey:
    """The nested key ``(group, leaf)``.

    Args:
        group: the agent group, e.g. ``"racket"``.
        leaf: one of the leaves above, e.g. :data:`OBSERVATION`.

    Returns:
        ``(group, leaf)``.

    Examples:
        >>> group_key("racket", OBSERVATION)
        ('racket', 'observation')
    """
    return (group, leaf)
