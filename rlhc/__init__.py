"""rlhc: Reinforcement Learning from Hierarchical Critics on TorchRL.

Layers, each importing only the ones before it:
``rlhc.envs`` (games) → ``rlhc.modules`` (networks) → ``rlhc.objectives``
(hierarchical value estimation + PPO) → trainer, evaluation, plots → ``rlhc.run``.
"""

__version__ = "0.1.0"
