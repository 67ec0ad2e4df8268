"""Training: the loop and what it is built from.

| module | holds |
|---|---|
| :mod:`rlhc.training.trainer` | :class:`~rlhc.training.trainer.Trainer`, the loop: collect, estimate, update, log, save |
| :mod:`rlhc.training.strategies` | one process, data-parallel or pipeline: where batches come from, what is combined across processes |
| :mod:`rlhc.training.distributed` | the collectives of a ``torchrun`` run |
| :mod:`rlhc.training.summaries` | the rows of ``metrics.csv``, the progress bar and lines, the periodic matches against the scripted team |
| :mod:`rlhc.training.loggers` | ``metrics.csv``, TensorBoard, wandb; the progress lines |
| :mod:`rlhc.training.training_state` | what a checkpoint of a training run holds, and resuming it |
| :mod:`rlhc.training.league` | who the learning team plays in each world (beyond the paper) |
| :mod:`rlhc.training.interrupt` | stopping on SIGINT / SIGTERM with a checkpoint |

Training sits above the evaluation: the periodic matches and the league's scripted,
random and Elo-rated opponents are :mod:`rlhc.evaluation`'s.
"""
