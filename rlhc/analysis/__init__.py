"""Finished runs read back: their learning curves and the figures of them.

| module | holds |
|---|---|
| :mod:`rlhc.analysis.curves` | finding runs, reading ``metrics.csv`` and configs, grouping seeds by configuration, smoothing, final values |
| :mod:`rlhc.analysis.drawing` | the figures: the paper's four metrics, a line per configuration (``python -m rlhc.plot``) |
"""
