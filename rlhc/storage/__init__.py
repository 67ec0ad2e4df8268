"""What a run keeps on disk and reads back: checkpoints and the final team.

| module | holds |
|---|---|
| :mod:`rlhc.storage.checkpoint` | checkpoint files: written atomically, ordered newest first, loaded weights only (skipping broken ones); the run directory a resume continues in; the random states |
| :mod:`rlhc.storage.final_team` | ``final_team.pt``: the policy part of a finished run's last checkpoint, what matches load |
| :mod:`rlhc.storage.run_lock` | ``run.lock``: one training process per run directory |

Plain dicts and files only: nothing here builds a network or reads a schema, so the
evaluation and the trainer above both read and write through it. What the trainer
puts into a checkpoint, and how it puts it back, is :mod:`rlhc.training.training_state`.
"""
