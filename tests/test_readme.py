"""The README's Quick start works as written: every command, with a tiny budget.

:data:`REDUCED` holds, for each command of the section, what the test appends (or
swaps) to keep it to seconds; the fast test fails when the README gains, loses or
changes a command, so the table and the README move together. The slow test runs
them all in order, in a fresh directory, as a shell would (``python`` is this
interpreter; ``<time>``, ``<job>`` and ``<run dir or .pt>`` are the directories the
earlier commands created).
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from cli_runs import ROOT, only_child, steps, subprocess_env

from rlhc.storage.checkpoint import load_checkpoint

README = ROOT / "README.md"
TINY = ["experiment=smoke", "algo.max_steps=128"]
MATCHES = ["matches=2", "max_match_steps=60"]

#: README command -> (appended arguments, replaced arguments {old: new}).
REDUCED: dict[str, tuple[list[str], dict[str, str]]] = {
    "source .venv/bin/activate": ([], {}),
    "python -m rlhc.run env=soccer critic=hierarchical": (TINY, {}),
    "python -m rlhc.run env=tennis critic=ppo env.extended_obs=true seed=1": (TINY, {}),
    "python -m rlhc.run env=soccer experiment=smoke": ([], {}),  # as written: seconds
    "tensorboard --logdir outputs": (["--inspect"], {}),  # prints what a browser would show
    "python -m rlhc.run -m env=tennis critic=ppo,hierarchical env.extended_obs=false,true seed=0,1,2": (
        ["experiment=smoke", "algo.max_steps=64"],
        {"seed=0,1,2": "seed=1"},  # 4 jobs, not 12
    ),
    "python -m rlhc.run -m hydra/launcher=joblib hydra.launcher.n_jobs=2 critic=ppo,hierarchical": (
        ["experiment=smoke", "algo.max_steps=64"],
        {},
    ),
    "python -m rlhc.run env=soccer critic=hierarchical resume=outputs/soccer/hierarchical/<time>": (
        ["experiment=smoke", "algo.max_steps=256"],
        {},
    ),
    "python -m rlhc.run env=tennis critic=ppo env.extended_obs=true seed=1 resume=multirun/<time>/<job>": (
        ["experiment=smoke", "algo.max_steps=128"],
        {},
    ),
    "python -m rlhc.evaluate env=soccer home=outputs/soccer/hierarchical/<time> away=scripted matches=100": (
        ["max_match_steps=60"],
        {"matches=100": "matches=2"},
    ),
    "python -m rlhc.evaluate env=tennis home=<run dir or .pt> away=<run dir or .pt> video.enabled=true": (
        [*MATCHES, "video.max_frames=10"],
        {},
    ),
    "python -m rlhc.evaluate mode=elo env=soccer 'players=[scripted,random,outputs/soccer/hierarchical/<time>]'": (
        MATCHES,
        {},
    ),
    "python -m rlhc.plot multirun/<time>/* --out curves.png": ([], {}),
}  # fmt: skip


def quick_start() -> str:
    text = README.read_text()
    return text[text.index("## Quick start") : text.index("## Outputs")]


def commands(section: str, language: str = "bash") -> list[str]:
    """The command lines of the section's ``language`` code blocks (comments dropped)."""
    blocks = re.findall(rf"```{language}\n(.*?)```", section, flags=re.DOTALL)
    lines = [line.split("  #")[0].strip() for block in blocks for line in block.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def test_every_quick_start_command_has_its_reduced_form() -> None:
    assert commands(quick_start()) == list(REDUCED)


def test_the_quick_start_python_snippet_runs() -> None:
    (snippet,) = re.findall(r"```python\n(.*?)```", quick_start(), flags=re.DOTALL)
    scope: dict[str, object] = {}
    exec(compile(snippet, str(README), "exec"), scope)
    assert tuple(scope["td"]["racket", "observation"].shape) == (64, 100, 4, 8)  # type: ignore[index]


def newest(directory: Path) -> Path:
    return max(directory.iterdir(), key=lambda p: p.stat().st_mtime_ns)


@pytest.mark.slow
def test_the_quick_start_commands_run_as_written(tmp_path: Path) -> None:
    assert (Path(sys.prefix) / "bin" / "activate").is_file()  # `source` needs a venv

    def run(command: str, **placeholders: str | list[str]) -> subprocess.CompletedProcess[str]:
        """Run a README command, its placeholders filled in order of appearance."""
        appended, replaced = REDUCED[command]
        line = command
        for name, values in placeholders.items():
            for value in [values] if isinstance(values, str) else values:
                line = line.replace(f"<{name}>", value, 1)
        words = [replaced.get(word, word) for word in shlex.split(line)] + appended
        if words[0] == "python":
            words[0] = sys.executable
        elif words[0] == "tensorboard":
            words[0] = str(Path(sys.executable).with_name("tensorboard"))
        shell = "*" in line  # a glob: the shell expands it
        script = " ".join(w if "*" in w else shlex.quote(w) for w in words)
        result = subprocess.run(
            script if shell else words,
            shell=shell,
            cwd=tmp_path,
            env=subprocess_env(),
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert result.returncode == 0, (command, result.stdout[-2000:], result.stderr[-2000:])
        return result

    names = iter(REDUCED)
    next(names)  # source .venv/bin/activate
    run(next(names))
    soccer = only_child(tmp_path / "outputs" / "soccer" / "hierarchical")
    run(next(names))
    tennis = only_child(tmp_path / "outputs" / "tennis" / "ppo")
    smoke = run(next(names))
    assert "results in outputs/soccer/hierarchical/" in smoke.stdout.splitlines()[-1]

    watched = run(next(names))
    assert "Found event files in:" in watched.stdout

    run(next(names))
    sweep = only_child(tmp_path / "multirun")
    jobs = sorted(p for p in sweep.iterdir() if p.is_dir())
    assert len(jobs) == 4
    run(next(names))
    parallel = newest(tmp_path / "multirun")
    assert parallel != sweep
    assert len([p for p in parallel.iterdir() if (p / "metrics.csv").is_file()]) == 2

    # Both resumes continue in the directories they name.
    resumed = run(next(names), time=soccer.name)
    assert str(soccer.relative_to(tmp_path)) in resumed.stdout.splitlines()[-1]
    assert steps(soccer) == [128, 256]
    (job,) = [p for p in jobs if "critic-ppo" in p.name and "extended_obs-True" in p.name]
    assert "seed-1" in job.name
    run(next(names), time=sweep.name, job=job.name)
    assert load_checkpoint(job)["frames"] == 128

    match = run(next(names), time=soccer.name)
    assert "win" in match.stdout.lower()
    home, away = tennis.relative_to(tmp_path), tennis.relative_to(tmp_path) / "checkpoints" / "latest.pt"  # fmt: skip
    run(next(names), **{"run dir or .pt": [str(home), str(away)]})
    assert list((tmp_path / "outputs" / "evaluate" / "tennis").rglob("match.gif"))
    run(next(names), time=soccer.name)
    assert list((tmp_path / "outputs" / "evaluate" / "soccer").rglob("elo.csv"))
    run(next(names), time=sweep.name)
    assert (tmp_path / "curves.png").stat().st_size > 0


def test_the_configuration_table_is_the_generated_one() -> None:
    """README's table is what ``python -m rlhc.config.table`` prints (no drift)."""
    from rlhc.config.table import README, readme_copy, table

    assert readme_copy(README.read_text()) == table(), (
        "README.md's configuration table is stale: run python -m rlhc.config.table --write"
    )


def test_every_setting_has_a_meaning_in_the_table() -> None:
    from rlhc.config.table import table

    rows = [line for line in table().splitlines()[2:]]
    assert len(rows) > 40
    for row in rows:
        meaning = row.rstrip(" |").rsplit("|", 1)[-1].strip()
        assert meaning, f"no Attributes entry documents {row.split('|')[1].strip()}"
