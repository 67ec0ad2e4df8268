"""The settings of both commands: their Hydra schemas, every check of them, the settings table.

| module | holds |
|---|---|
| :mod:`rlhc.config.train_schema` | the schemas of ``python -m rlhc.run`` (every section, the league's and the shaping's included), ``compose_config`` |
| :mod:`rlhc.config.evaluate_schema` | the schema of ``python -m rlhc.evaluate`` |
| :mod:`rlhc.config.validation` | every check of a setting that the schemas' types cannot make, one error type |
| :mod:`rlhc.config.table` | the settings table of the docs, generated (``python -m rlhc.config.table`` prints it) |
"""
