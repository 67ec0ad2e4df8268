"""Benchmarks and the RLHC-vs-PPO reproduction study.

A package so that its scripts import each other and :mod:`benchmarks.reporting`
without touching ``sys.path``: run the ones that do as modules from the repository root,
e.g. ``python -m benchmarks.reproduce``, ``python -m benchmarks.report`` and
``python -m benchmarks.policy_summary``.
"""
