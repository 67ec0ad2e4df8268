"""Training: the loop (:class:`~rlhc.training.trainer.Trainer`) and its parts: one process or
several, metrics and progress, checkpoint contents, the league, stopping on a signal."""
