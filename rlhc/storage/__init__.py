"""What a run keeps on disk: checkpoints, the final team, the run lock; plain dicts and files
(what a training checkpoint holds is :mod:`rlhc.training.training_state`)."""
