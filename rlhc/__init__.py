"""rlhc: Reinforcement Learning from Hierarchical Critics on TorchRL.

Floors, each importing only itself and the ones before it (``docs/guide/architecture.md``;
``tests/test_layering.py`` checks it): ``rlhc.errors`` → ``rlhc.envs`` (games) →
``rlhc.modules`` (networks) → ``rlhc.objectives`` (hierarchical value estimation +
PPO) → ``rlhc.config`` (settings) → ``rlhc.storage`` (checkpoint files) →
``rlhc.building`` (config → objects) → ``rlhc.evaluation`` (matches, Elo) →
``rlhc.training`` (the loop) → ``rlhc.analysis`` (curves, figures) → ``rlhc.cli`` →
the entry points ``rlhc.run``, ``rlhc.evaluate``, ``rlhc.plot``.
"""

__version__ = "0.1.0"
