"""The TensorDict keys of the package, defined once (the lowest layer, so every layer can import them).

The env (:mod:`rlhc.envs.torchrl_adapter`) writes the per-group leaves under each group,
e.g. ``("racket", OBSERVATION)``, and the per-world ones at the root; the networks
(:mod:`rlhc.modules`) and the learning core (:mod:`rlhc.objectives`) add theirs under
the group too. A renamed key is a one-line change here, and the env, the networks and
the estimator can never disagree.

Examples:
    >>> from rlhc.envs import make_env
    >>> td = make_env("tennis", num_envs=2, seed=0).reset()
    >>> td["racket", OBSERVATION].shape, td[STEP_COUNT].shape
    (torch.Size([2, 4, 8]), torch.Size([2, 1]))
"""

from __future__ import annotations

# --- written by the env, per group ``[N, n_g, ...]`` ------------------------------------
#: Worker observation ``[*B, n_g, d_w]``: read by the actor and the worker critic.
OBSERVATION = "observation"
#: The team manager's view of each agent ``[*B, n_g, d_m]``: read by the manager critic.
MANAGER_OBSERVATION = "manager_observation"
#: The agent's team, 0 or 1 ``[*B, n_g, 1]`` (also a PettingZoo ``infos`` entry).
TEAM = "team"
#: The agent's action (continuous ``[*B, n_g, size]`` or discrete ``[*B, n_g]``).
ACTION = "action"
REWARD = "reward"
#: Episode-end flags, per group and at the root (TorchRL's names).
DONE = "done"
TERMINATED = "terminated"
TRUNCATED = "truncated"
DONE_KEYS = (DONE, TERMINATED, TRUNCATED)

# --- written by the env, per world ``[N, ...]`` -----------------------------------------
#: Steps taken in the episode before this observation ``[*B, 1]`` (0 at reset).
STEP_COUNT = "step_count"
#: The team that won the point or goal on the step that led here, -1 if none ``[*B, 1]``.
SCORING_TEAM = "scoring_team"
#: Sub-dict of the game's published events (e.g. ``("info", "hits_over_net")``).
INFO = "info"
#: Prefix of a published event saying how a point ended (tennis: ``ended_serve_missed``,
#: ``ended_missed``, ...; 1 on the decision that ended the point that way).
ENDED_PREFIX = "ended_"

# --- written by the training transforms, per group ---------------------------------------
#: The return of the episode so far ``[*B, n_g, 1]`` (TorchRL's ``RewardSum``, in
#: :func:`rlhc.building.builders.with_training_transforms`): the logged cumulative reward.
EPISODE_REWARD = "episode_reward"

# --- TorchRL's own -----------------------------------------------------------------------
#: The sub-dict of a step's result (``env.step``) holding the next observation.
NEXT = "next"
#: The per-world partial-reset mask read by ``env.reset(tensordict)``.
RESET = "_reset"

# --- written by the networks, per group --------------------------------------------------
#: Log-probability of the sampled action, written by ``ProbabilisticActor``
#: (``<action leaf>_log_prob`` in TorchRL 0.14 when log-probs are not aggregated).
ACTION_LOG_PROB = "action_log_prob"
#: ``model.action_dist=tanh_normal``: the pre-tanh sample an action was squashed
#: from, stored next to it so that the loss scores exactly what was drawn; its
#: log-probability is ``action_pretanh_log_prob``.
PRE_TANH_ACTION = "action_pretanh"
#: Gaussian parameters and logits: intermediate actor outputs.
LOC = "loc"
SCALE = "scale"
LOGITS = "logits"
#: ``V_w(o_w)``: the worker critic's value ``[*B, n_g, 1]``.
WORKER_VALUE = "worker_value"
#: ``V_m(o_m)``: the manager critic's value ``[*B, n_g, 1]``.
MANAGER_VALUE = "manager_value"

# --- written by the learning core, per group ----------------------------------------------
#: The fused value ``V_hat`` that GAE uses (TorchRL's default ``value`` leaf).
STATE_VALUE = "state_value"
#: Share of the fused value that came from the manager critic ``[*B, n_g, 1]``.
MANAGER_SELECTED = "manager_selected"
ADVANTAGE = "advantage"
VALUE_TARGET = "value_target"
#: ``bool [*B, n_g, 1]``: the learning policy chose this agent's action (written by the
#: league's collection policy; an opponent's agents in a league world are ``False``).
#: PPO's terms weigh each experience by it (:mod:`rlhc.objectives.weighting`).
LEARNER = "learner"

# --- names of the built-in teams ------------------------------------------------------------
#: The game's scripted team (a player of ``rlhc.evaluate``, an opponent of the league).
SCRIPTED = "scripted"
#: Uniform random actions.
RANDOM = "random"

__all__ = [
    "ACTION",
    "ACTION_LOG_PROB",
    "ADVANTAGE",
    "DONE",
    "DONE_KEYS",
    "EPISODE_REWARD",
    "INFO",
    "LEARNER",
    "LOC",
    "LOGITS",
    "MANAGER_OBSERVATION",
    "MANAGER_SELECTED",
    "MANAGER_VALUE",
    "NEXT",
    "OBSERVATION",
    "PRE_TANH_ACTION",
    "RANDOM",
    "RESET",
    "REWARD",
    "SCALE",
    "SCORING_TEAM",
    "SCRIPTED",
    "STATE_VALUE",
    "STEP_COUNT",
    "TEAM",
    "TERMINATED",
    "TRUNCATED",
    "VALUE_TARGET",
    "WORKER_VALUE",
]
