"""A validated config turned into objects, the same way for training and for evaluation.

| module | holds |
|---|---|
| :mod:`rlhc.building.builders` | the training env and its transforms, each group's actor, critics and PPO loss, the layout of an update |
| :mod:`rlhc.building.shaping` | potential-based reward shaping, a transform of the training env (beyond the paper) |
| :mod:`rlhc.building.flops` | the arithmetic of the built networks: FLOP per world-decision |

A checkpoint's config rebuilds exactly the networks that were trained, because the
trainer (:mod:`rlhc.training.trainer`) and the evaluation (:mod:`rlhc.evaluation`)
both build through here.
"""
