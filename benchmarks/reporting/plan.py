"""The reproduction's plan, read from the study configs ``conf/study/<name>.yaml``.

A study config is the single description of a study: the game (or another library's env
and its task, :class:`Task`) and its overrides, the critics compared and the seeds
(``hydra.sweeper.params``), where its runs live (``hydra.sweep.dir``), and, through
Hydra's composition, the budget. The same file runs the study as one Hydra multirun
(``python -m rlhc.run -m study=<name>``); ``python -m benchmarks.reproduce`` trains its
:func:`plan` one process per run, and ``python -m benchmarks.report`` compares what was
trained with it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import DictConfig, ListConfig, OmegaConf

ROOT = Path(__file__).resolve().parents[2]
STUDY_DIR = ROOT / "conf" / "study"
#: The swept keys of a study config: one configuration per critic, one run per seed.
CONFIG_KEY, SEED_KEY = "critic", "seed"
#: ``env=<source>`` of another library (:data:`rlhc.envs.SOURCES`) -> the env key naming its task.
TASK_KEYS = {"vmas": "scenario", "pettingzoo": "factory"}


@dataclass(frozen=True)
class Task:
    """What a study on another library's env trains on (a game needs none: its name says it).

    Attributes:
        key: the env key that names it (:data:`TASK_KEYS`: ``scenario``, ``factory``).
        name: its value: a VMAS scenario, or a PettingZoo ``<module>:<callable>``.
        kwargs: its options (``env.kwargs``), in the config's order.
        max_cycles: decisions per episode (``env.max_cycles``; ``None``: the env's own).
    """

    key: str
    name: str
    kwargs: tuple[tuple[str, Any], ...] = ()
    max_cycles: int | None = None


@dataclass(frozen=True)
class PlannedRun:
    """One training run of the study.

    Attributes:
        study: the study's name (a key of :data:`STUDIES`).
        config: the configuration's name within the study (its ``critic`` choice).
        seed: the run's seed.
        max_steps: the budget, in frames (one frame = one step of one world).
        root: the study's run root (``hydra.sweep.dir``), absolute.
    """

    study: str
    config: str
    seed: int
    max_steps: int
    root: Path

    @property
    def name(self) -> str:
        """``study/config``."""
        return f"{self.study}/{self.config}"

    @property
    def overrides(self) -> tuple[str, ...]:
        """The ``rlhc.run`` overrides of the run (the study config sets the rest)."""
        return (f"study={self.study}", f"{CONFIG_KEY}={self.config}", f"{SEED_KEY}={self.seed}")

    @property
    def run_dir(self) -> Path:
        """``<root>/<config>/seed_<k>``: where the study config puts the run."""
        return self.root / self.config / f"seed_{self.seed}"


@dataclass(frozen=True)
class Study:
    """Configurations trained on equal seeds and budget.

    Attributes:
        name: the study's name (its config file's stem).
        title: what it compares (the config file's opening comment).
        env: the game.
        configs: the critics compared, in the config's order.
        seeds: the seeds per configuration.
        max_steps: frames per run (composed: Table 3's budget unless the study sets one).
        root: where its runs live (``hydra.sweep.dir``), absolute.
        task: on another library's env, what it trains on; ``None``: a game, whose
            scripted team and play metric the report uses.
    """

    name: str
    title: str
    env: str
    configs: tuple[str, ...]
    seeds: tuple[int, ...]
    max_steps: int
    root: Path
    task: Task | None = None

    @property
    def environment(self) -> tuple[str, Task | None]:
        """The env with its task: studies with equal environments share a training rate."""
        return (self.env, self.task)

    @property
    def planned(self) -> int:
        """Runs in the full study (configurations x seeds)."""
        return len(self.configs) * len(self.seeds)

    @property
    def command(self) -> str:
        """The multirun that trains the whole study (resumable: re-run to continue)."""
        return f"python -m rlhc.run -m study={self.name}"

    def runs(self, seeds: int | None = None) -> list[PlannedRun]:
        """Its runs, seed-major, so that a partial study compares configs on equal seeds.

        Args:
            seeds: how many of its seeds (default: all).
        """
        chosen = self.seeds if seeds is None else self.seeds[:seeds]
        return [
            PlannedRun(self.name, config, seed, self.max_steps, self.root)
            for seed in chosen
            for config in self.configs
        ]


def swept(config: DictConfig | ListConfig, key: str, path: Path) -> list[str]:
    """The values Hydra's basic sweeper expands ``hydra.sweeper.params.<key>`` to.

    Raises:
        ValueError: the study config does not sweep ``key``.
    """
    params = OmegaConf.select(config, "hydra.sweeper.params") or {}
    if key not in params:
        raise ValueError(f"{path}: hydra.sweeper.params must sweep {key!r}, found {list(params)}")
    (override,) = OverridesParser.create().parse_overrides([f"{key}={params[key]}"])
    return list(override.sweep_string_iterator())


def composed(name: str) -> DictConfig:
    """The training config of the study's first run, as ``python -m rlhc.run`` composes it."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from rlhc.config.train_schema import register_configs

    register_configs()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        return compose(config_name="train", overrides=[f"study={name}"])


def read_task(env: DictConfig) -> Task | None:
    """The task of a composed ``env`` config of another library's env (``None``: a game).

    Raises:
        ValueError: its ``env.kwargs`` is not a mapping.
    """
    key = TASK_KEYS.get(str(env.name))
    if key is None:
        return None
    kwargs = OmegaConf.to_container(env.kwargs) if env.kwargs else {}
    if not isinstance(kwargs, dict):
        raise ValueError(f"env.kwargs must be a mapping, got {kwargs!r}")
    max_cycles = None if env.max_cycles is None else int(env.max_cycles)
    options = tuple((str(name), value) for name, value in kwargs.items())
    return Task(key, str(env[key]), options, max_cycles)


def read_study(path: Path) -> Study:
    """The study a ``conf/study`` file describes (composed once for env, task and budget).

    Raises:
        ValueError: it sweeps no critics or seeds, or has no ``hydra.sweep.dir``.
    """
    raw = OmegaConf.load(path)
    root = OmegaConf.select(raw, "hydra.sweep.dir")
    if not root:
        raise ValueError(f"{path}: a study config must set hydra.sweep.dir (its runs' root)")
    title = []  # the opening comment, up to its first command line
    for line in path.read_text().splitlines():
        text = line.lstrip("# ").strip()
        if not line.startswith("#") or text.startswith("python"):
            break
        if "@package" not in text:
            title.append(text)
    config = composed(path.stem)
    return Study(
        name=path.stem,
        title=" ".join(title) or path.stem,
        env=str(config.env.name),
        configs=tuple(swept(raw, CONFIG_KEY, path)),
        seeds=tuple(int(seed) for seed in swept(raw, SEED_KEY, path)),
        max_steps=int(config.algo.max_steps),
        root=(ROOT / str(root)).resolve(),
        task=read_task(config.env),
    )


#: The order of the report: the paper's studies, those beyond it, then other libraries'
#: envs (the peer check's tasks, in its order).
ORDER = (
    "tennis_paper",
    "tennis_extended",
    "soccer_paper",
    "tennis_extensions",
    "soccer_best",
    "tennis_best",
    "vmas_navigation",
    "vmas_balance",
    "pettingzoo_simple_spread",
    "pettingzoo_simple_tag",
)


def _order(path: Path) -> tuple[int, str]:
    return (ORDER.index(path.stem) if path.stem in ORDER else len(ORDER), path.stem)


def study_names() -> list[str]:
    """The studies' names in report order, without composing them (command-line choices)."""
    return [path.stem for path in sorted(STUDY_DIR.glob("*.yaml"), key=_order)]


@cache
def studies() -> dict[str, Study]:
    """Every study config, in :data:`ORDER` (others after it, by name)."""
    return {name: read_study(STUDY_DIR / f"{name}.yaml") for name in study_names()}


def plan(names: Iterable[str], seeds: int | None = None) -> list[PlannedRun]:
    """The runs of the named studies in order, each study seed-major.

    Args:
        names: study names (``conf/study`` stems).
        seeds: seeds per configuration (default: each study's).

    Raises:
        KeyError: a name is not a study (the known ones are named).
    """
    known = studies()
    unknown = [name for name in names if name not in known]
    if unknown:
        raise KeyError(f"unknown studies {unknown}; conf/study has {list(known)}")
    return [run for name in names for run in known[name].runs(seeds)]
