"""The reproduction study's plan: which configurations, how many seeds, what budget.

:data:`STUDIES` is the single description of the study. ``benchmarks/reproduce.py``
trains its :func:`plan`; ``benchmarks/report.py`` compares what was trained with it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

#: Where ``benchmarks/reproduce.py`` writes the study: ``<study>/<config>/seed_<k>/``.
RESULTS = Path(__file__).resolve().parents[1] / "results" / "reproduce"


@dataclass(frozen=True)
class PlannedRun:
    """One training run of the study.

    Attributes:
        study: the study's name (a key of :data:`STUDIES`).
        config: the configuration's name within the study.
        seed: the run's seed.
        overrides: the configuration's Hydra overrides (without seed and budget).
        max_steps: the budget, in frames (one frame = one step of one world).
    """

    study: str
    config: str
    seed: int
    overrides: tuple[str, ...]
    max_steps: int

    @property
    def name(self) -> str:
        """``study/config``."""
        return f"{self.study}/{self.config}"

    def run_dir(self, results: Path = RESULTS) -> Path:
        """The run's directory under the study root ``results``."""
        return results / self.study / self.config / f"seed_{self.seed}"


@dataclass(frozen=True)
class Study:
    """Configurations trained on equal seeds and budget.

    Attributes:
        name: the study's name.
        configs: configuration name -> its Hydra overrides (one of them ``env=<game>``).
        seeds: seeds per configuration (``0 .. seeds - 1``).
        max_steps: frames per run (the paper's Table 3 budget).
    """

    name: str
    configs: Mapping[str, tuple[str, ...]]
    seeds: int
    max_steps: int

    @property
    def env(self) -> str:
        """The game, from the configurations' ``env=`` override.

        Raises:
            ValueError: a configuration names no game, or the configurations name several.
        """
        games = {
            next((o.split("=", 1)[1] for o in overrides if o.startswith("env=")), None)
            for overrides in self.configs.values()
        }
        if len(games) != 1 or None in games:
            raise ValueError(f"study {self.name!r}: configs must share one env= override")
        return str(games.pop())

    @property
    def planned(self) -> int:
        """Runs in the full study (configurations x seeds)."""
        return len(self.configs) * self.seeds

    def runs(self, seeds: int | None = None) -> list[PlannedRun]:
        """Its runs, seed-major, so that a partial study compares configs on equal seeds.

        Args:
            seeds: seeds per configuration (default: :attr:`seeds`).
        """
        return [
            PlannedRun(self.name, config, seed, overrides, self.max_steps)
            for seed in range(self.seeds if seeds is None else seeds)
            for config, overrides in self.configs.items()
        ]


def _studies(*studies: Study) -> dict[str, Study]:
    return {study.name: study for study in studies}


#: The study: tennis and soccer as in the paper, and critics beyond it on tennis.
STUDIES: dict[str, Study] = _studies(
    Study(
        "tennis",
        {
            "ppo": ("env=tennis", "critic=ppo", "env.extended_obs=false"),
            "hierarchical": ("env=tennis", "critic=hierarchical", "env.extended_obs=false"),
            "ppo_extended": ("env=tennis", "critic=ppo", "env.extended_obs=true"),
            "hierarchical_extended": ("env=tennis", "critic=hierarchical", "env.extended_obs=true"),
        },
        seeds=5,
        max_steps=200_000,
    ),
    Study(
        "soccer",
        {
            "ppo": ("env=soccer", "critic=ppo"),
            "hierarchical": ("env=soccer", "critic=hierarchical"),
        },
        seeds=5,
        max_steps=500_000,
    ),
    Study(
        "tennis_extensions",
        {
            "manager": ("env=tennis", "critic=manager"),
            "mean": ("env=tennis", "critic=mean"),
            "hierarchical_k5": ("env=tennis", "critic=hierarchical", "critic.manager_interval=5"),
        },
        seeds=3,
        max_steps=200_000,
    ),
)


def plan(studies: Iterable[str], seeds: int | None = None) -> list[PlannedRun]:
    """The runs of ``studies`` in order, each study seed-major.

    Args:
        studies: names of :data:`STUDIES`.
        seeds: seeds per configuration (default: each study's).

    Raises:
        KeyError: a name is not a study (the known ones are named).
    """
    unknown = [name for name in studies if name not in STUDIES]
    if unknown:
        raise KeyError(f"unknown studies {unknown}; the study has {list(STUDIES)}")
    return [run for name in studies for run in STUDIES[name].runs(seeds)]
