"""The RLHC-vs-PPO reproduction report (``docs/RESULTS.md``), one idea per module.

``python -m benchmarks.report`` is the command line, ``python -m benchmarks.reproduce``
trains the plan; this package holds what they share and what the report does.

| module | holds |
|---|---|
| :mod:`~benchmarks.reporting.plan` | the plan, read from ``conf/study``: studies, configs, seeds, budgets, run roots |
| :mod:`~benchmarks.reporting.summary` | a run's ``summary.json``: frames, budget, code version |
| :mod:`~benchmarks.reporting.study` | groups, compared pairs (RLHC, twin, PPO), play metrics, smoothing and windows |
| :mod:`~benchmarks.reporting.runs` | run directories, their summaries and configs |
| :mod:`~benchmarks.reporting.statistics` | smoothed finals, thresholds, steps to reach them, Welch's test |
| :mod:`~benchmarks.reporting.generic` | a study on another library's env: its task, its returns-only section |
| :mod:`~benchmarks.reporting.tournament` | a study's round robin: entrants, the stored series, playing them |
| :mod:`~benchmarks.reporting.ratings` | Bradley-Terry ratings, team-set scores with seed spread, seed pairs |
| :mod:`~benchmarks.reporting.standings` | the matches' section: ratings, scores against built-in teams, head-to-head |
| :mod:`~benchmarks.reporting.aggregates` | rliable-style IQM and probability of improvement over games |
| :mod:`~benchmarks.reporting.formatting` | numbers, intervals and Markdown tables as text |
| :mod:`~benchmarks.reporting.markdown` | the sections on runs, settings, config drift and finals |
| :mod:`~benchmarks.reporting.figures` | the figures (drawing only) |
| :mod:`~benchmarks.reporting.environment` | package versions and the machine the report ran on |
| :mod:`~benchmarks.reporting.blocks` | the named generated and hand-written blocks of the document |
| :mod:`~benchmarks.reporting.document` | the whole ``RESULTS.md`` from the sections |
"""
