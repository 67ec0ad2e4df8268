"""Finished runs read back: their learning curves, the figures of them, a team's showcase.

| module | holds |
|---|---|
| :mod:`rlhc.analysis.curves` | finding runs, reading ``metrics.csv`` and configs, grouping seeds by configuration, smoothing, final values |
| :mod:`rlhc.analysis.drawing` | the figures: the paper's four metrics, a line per configuration (``python -m rlhc.plot``) |
| :mod:`rlhc.analysis.showcase` | does a trained team play: its headline numbers, a point on video, its curves (``python -m rlhc.evaluate mode=showcase``) |
"""
