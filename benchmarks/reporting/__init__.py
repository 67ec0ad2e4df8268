"""The RLHC-vs-PPO reproduction report (``docs/RESULTS.md``), one idea per module.

``benchmarks/report.py`` is the command line; this package holds what it does.

| module | holds |
|---|---|
| :mod:`~reporting.study` | the study's plan: groups, RLHC-vs-PPO pairs, smoothing and windows |
| :mod:`~reporting.runs` | run directories, which are complete, their configs and wall times |
| :mod:`~reporting.statistics` | smoothed finals, thresholds, steps to reach them, Welch's test |
| :mod:`~reporting.head_to_head` | matches of final teams against each other and the scripted team |
| :mod:`~reporting.formatting` | numbers, intervals and Markdown tables as text |
| :mod:`~reporting.markdown` | the sections on runs, settings, config drift and finals |
| :mod:`~reporting.environment` | package versions and the machine the report ran on |
| :mod:`~reporting.document` | the whole ``RESULTS.md`` from the sections |
| :mod:`~reporting.learning` | ``benchmarks/learning.py``'s means over seeds, curves and table |

The package lives in ``benchmarks/`` next to ``reproduce.py`` (a script, not a
package) and imports it as a top-level module: whatever makes ``reporting``
importable (``benchmarks/`` on ``sys.path``) makes ``reproduce`` importable too.
"""
