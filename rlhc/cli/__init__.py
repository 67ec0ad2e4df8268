"""What the entry points (:mod:`rlhc.run`, :mod:`rlhc.evaluate`, :mod:`rlhc.plot`) share,
and their lifecycle around Hydra.

| module | holds |
|---|---|
| :mod:`rlhc.cli.report` | a user error in one line (``<program>: error: …``, exit 2), for every entry point; paths as shown to the user |
| :mod:`rlhc.cli.start` | the checks of a training run before it writes anything, and the checkpoint it resumes, loaded once |
| :mod:`rlhc.cli.hydra_hooks` | what ``conf/train.yaml`` and ``conf/evaluate.yaml`` name: the ``Preflight`` and ``EvaluatePreflight`` callbacks, the ``rlhc.run_dir`` and ``rlhc.output_subdir`` resolvers |
| :mod:`rlhc.cli.cleanup` | removing what a start that failed on a user error created (and nothing else) |
"""
