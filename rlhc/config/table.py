"""The settings table of ``docs/guide/configuration.md``, generated from schemas and ``conf/``.

One row per setting of a training run: its key, its value in each game's paper preset,
its unit (a field's ``unit`` metadata) and meaning (the ``Attributes:`` entry of the
schema's docstring); a config group's row names the chosen option and the options. The
docs build renders it (``docs/hooks.py``); ``python -m rlhc.config.table`` prints it.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from rlhc.config.train_schema import TrainConfig, register_configs
from rlhc.envs.registry import game_spec

CONF = Path(__file__).resolve().parents[2] / "conf"
#: Composed configs are read for these games, one column each.
GAMES = ("tennis", "soccer")
ABSENT = "—"


def attribute_docs(cls: type) -> dict[str, str]:
    """``field -> description`` from the ``Attributes:`` sections of ``cls`` and its bases.

    Examples:
        >>> from rlhc.config.train_schema import CriticConfig
        >>> attribute_docs(CriticConfig)["manager_interval"].split(" (")[0]
        'the manager is consulted every ``k`` steps'
    """
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        text = inspect.getdoc(klass) or ""
        section = re.search(r"^Attributes:\n((?:    .*\n?|\n)*)", text, flags=re.M)
        if section is None:
            continue
        name = None
        for line in section.group(1).splitlines():
            entry = re.match(r"^    (\w+): (.*)$", line)
            if entry:
                name = entry.group(1)
                docs[name] = entry.group(2).strip()
            elif name and line.startswith("        "):
                docs[name] += " " + line.strip()
    return docs


def composed(game: str) -> tuple[dict[str, Any], dict[str, str]]:
    """The composed config of ``env=<game>`` (a plain dict) and its group choices."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf

    register_configs()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose(config_name="train", overrides=[f"env={game}"], return_hydra_config=True)
    choices = {str(k): str(v) for k, v in cfg.hydra.runtime.choices.items()}
    container: dict[str, Any] = OmegaConf.to_container(cfg, resolve=False)  # type: ignore[assignment]
    container.pop("hydra")
    return container, choices


def shown(value: Any) -> str:
    """A value as the table shows it.

    Examples:
        >>> [shown(v) for v in (3_600_000, 0.0003, True, None, "silu", ["csv", "tensorboard"])]
        ['3,600,000', '0.0003', 'true', 'null', '`silu`', '`[csv, tensorboard]`']
    """
    if value is None:
        return "null"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, list):
        return f"`[{', '.join(str(v) for v in value)}]`"
    return f"`{value}`"


def _value(config: Mapping[str, Any], key: str) -> str:
    node: Any = config
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return ABSENT
        node = node[part]
    return shown(node)


def rows(schema: type, prefix: str = "") -> Iterator[tuple[str, type, dataclasses.Field, bool]]:
    """``(key, owning schema, field, is a section)`` of every setting, in declaration order."""
    for item in dataclasses.fields(schema):
        key = f"{prefix}{item.name}"
        default = item.default_factory() if callable(item.default_factory) else None
        section = dataclasses.is_dataclass(default)
        yield key, schema, item, section
        if section:
            yield from rows(type(default), f"{key}.")


def env_fields() -> dict[str, tuple[type, dataclasses.Field]]:
    """``name -> (the first game schema that has it, field)`` of every game option."""
    fields: dict[str, tuple[type, dataclasses.Field]] = {}
    for game in GAMES:
        schema = game_spec(game).env_config
        for item in dataclasses.fields(schema):
            if item.name != "name":
                fields.setdefault(item.name, (schema, item))
    return fields


def table() -> str:
    """The markdown table (header, one row per setting)."""
    configs = {game: composed(game) for game in GAMES}
    lines = [
        f"| key | {' | '.join(GAMES)} | unit | meaning |",
        "|---|" + "---|" * len(GAMES) + "---|---|",
    ]

    def row(key: str, values: list[str], unit: str, meaning: str) -> None:
        meaning = markdown(meaning).replace("|", "\\|")
        lines.append(f"| `{key}` | {' | '.join(values)} | {unit} | {meaning} |")

    def values(key: str) -> list[str]:
        return [_value(configs[g][0], key) for g in GAMES]

    def choices(group: str) -> list[str]:
        return [f"`{configs[g][1][group]}`" for g in GAMES]

    for key, schema, item, section in rows(TrainConfig):
        doc = attribute_docs(schema).get(item.name, "")
        if key == "env":
            row(key, choices(key), "", doc)
            for name, (owner, field) in env_fields().items():
                unit = field.metadata.get("unit", "")
                row(f"env.{name}", values(f"env.{name}"), unit, attribute_docs(owner).get(name, ""))
        elif section:
            # A section no group chooses (shaping) has no row: its settings follow.
            if (CONF / key).is_dir():
                options = sorted(p.stem for p in (CONF / key).glob("*.yaml"))
                listed = ", ".join(f"`{option}`" for option in options)
                row(key, choices(key), "", f"{doc} Options: {listed}.")
        else:
            row(key, values(key), item.metadata.get("unit", ""), doc)
    return "\n".join(lines) + "\n"


def markdown(text: str) -> str:
    """A docstring's reStructuredText roles and literals as markdown.

    Examples:
        >>> markdown("see :func:`~rlhc.modules.make_actor` and ``None``")
        'see `make_actor` and `None`'
    """
    text = re.sub(
        r":\w+:`~?([\w.]+)`",
        lambda m: f"`{m.group(1).split('.')[-1] if '~' in m.group(0) else m.group(1)}`",
        text,
    )
    return text.replace("``", "`")


if __name__ == "__main__":
    print(table(), end="")
