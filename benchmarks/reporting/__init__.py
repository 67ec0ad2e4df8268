"""The RLHC-vs-PPO reproduction report (``docs/RESULTS.md``), one idea per module.

``python -m benchmarks.report`` is the command line, ``python -m benchmarks.reproduce``
trains the plan; this package holds what they share and what the report does.

| module | holds |
|---|---|
| :mod:`~benchmarks.reporting.plan` | the study's plan: studies, configs, seeds, budgets |
| :mod:`~benchmarks.reporting.summary` | a run's ``summary.json``: frames, budget, code version |
| :mod:`~benchmarks.reporting.study` | groups, RLHC-vs-PPO pairs, smoothing and windows |
| :mod:`~benchmarks.reporting.runs` | run directories, their summaries and configs |
| :mod:`~benchmarks.reporting.statistics` | smoothed finals, thresholds, steps to reach them, Welch's test |
| :mod:`~benchmarks.reporting.head_to_head` | matches of final teams against each other and the scripted team |
| :mod:`~benchmarks.reporting.formatting` | numbers, intervals and Markdown tables as text |
| :mod:`~benchmarks.reporting.markdown` | the sections on runs, settings, config drift and finals |
| :mod:`~benchmarks.reporting.figures` | the figures (drawing only) |
| :mod:`~benchmarks.reporting.environment` | package versions and the machine the report ran on |
| :mod:`~benchmarks.reporting.blocks` | the named generated and hand-written blocks of the document |
| :mod:`~benchmarks.reporting.document` | the whole ``RESULTS.md`` from the sections |
| :mod:`~benchmarks.reporting.learning` | ``benchmarks/learning.py``'s means over seeds, curves and table |
"""
