"""The README: a few screens, its Quick start works as written, its numbers are the report's.

:data:`REDUCED` holds, for each command of the Quick start, what the test appends (or
swaps) to keep it to seconds; the fast test fails when the README gains, loses or
changes a command, so the table and the README move together. The slow test runs
them all in order, in a fresh directory, as a shell would (``python`` is this
interpreter; ``<time>``, ``<job>`` and ``<run dir or .pt>`` are the directories the
earlier commands created). The headline results must be numbers of ``docs/RESULTS.md``,
and the docs site's configuration page must render the generated settings table
(``docs/hooks.py``; ``make docs`` builds the site itself).
"""

from __future__ import annotations

import importlib.util
import re
import shlex
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest
from cli_runs import ROOT, only_child, steps, subprocess_env

from rlhc.storage.checkpoint import load_checkpoint

README = ROOT / "README.md"
RESULTS = ROOT / "docs" / "RESULTS.md"
CONFIGURATION_PAGE = ROOT / "docs" / "guide" / "configuration.md"
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
    "python -m rlhc.run env=vmas env.scenario=navigation critic=hierarchical": (TINY, {}),
    "python -m rlhc.run env=pettingzoo env.factory=mpe2.simple_spread_v3:parallel_env 'env.kwargs={N: 3}'": (
        [*TINY, "algo.buffer_size=192", "algo.batch_size=96"],  # multiples of its 3 agents
        {},
    ),
    "python -m rlhc.evaluation.returns outputs/vmas/hierarchical/<time> --episodes 100 --video episode.gif": (
        ["--worlds", "2", "--max-frames", "5"],
        {"100": "2"},
    ),
}  # fmt: skip


def section(text: str, heading: str) -> str:
    """The ``## heading`` section of a markdown text, up to the next ``## `` heading."""
    start = text.index(f"\n## {heading}\n")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else len(text)]


def quick_start() -> str:
    return section(README.read_text(), "Quick start")


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

    # Environments of other libraries (the envs extra).
    run(next(names))
    vmas = only_child(tmp_path / "outputs" / "vmas" / "hierarchical")
    assert (vmas / "metrics.csv").is_file()
    run(next(names))
    pettingzoo = only_child(tmp_path / "outputs" / "pettingzoo" / "hierarchical")
    assert (pettingzoo / "metrics.csv").is_file()
    judged = run(next(names), time=vmas.name)
    assert "agents [1]: agents" in judged.stdout
    assert (tmp_path / "episode.gif").stat().st_size > 0


def test_the_readme_is_a_few_screens() -> None:
    assert len(README.read_text().splitlines()) <= 300


def test_the_readme_links_resolve() -> None:
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README.read_text())
    local = [t for t in targets if "://" not in t]
    assert local
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, f"README links to missing files: {missing}"


def test_the_headline_results_are_the_reports() -> None:
    """Every ``value [low, high]`` of README's Results is one of docs/RESULTS.md's."""
    headline = section(README.read_text(), "Results")
    numbers = re.findall(r"-?\d+\.\d+ \[-?\d+\.\d+, -?\d+\.\d+\]", headline)
    assert len(numbers) >= 6
    report = RESULTS.read_text()
    stale = [n for n in numbers if n not in report]
    assert not stale, f"README's results are not docs/RESULTS.md's (rebuilt since?): {stale}"
    command = "python -m benchmarks.report --matches 0"
    assert command in headline and command in report


def docs_hooks() -> ModuleType:
    """``docs/hooks.py``, the MkDocs hooks (not a package module)."""
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_configuration_page_renders_the_generated_table() -> None:
    """The docs site's table is what ``python -m rlhc.config.table`` prints (no drift)."""
    from rlhc.config.table import table

    hooks = docs_hooks()
    page = CONFIGURATION_PAGE.read_text()
    assert page.count(hooks.CONFIG_TABLE) == 1
    rendered = hooks.render_config_table(page)
    assert hooks.CONFIG_TABLE not in rendered
    assert table() in rendered


def test_the_api_pages_show_docstring_roles_as_code() -> None:
    hooks = docs_hooks()
    html = ":class:<code>~rlhc.envs.base.BatchedGame</code>, :func:<code>rlhc.envs.make_env</code>"
    assert hooks.roles_as_code(html) == "<code>BatchedGame</code>, <code>rlhc.envs.make_env</code>"


def test_every_setting_has_a_meaning_in_the_table() -> None:
    from rlhc.config.table import table

    rows = [line for line in table().splitlines()[2:]]
    assert len(rows) > 40
    for row in rows:
        meaning = row.rstrip(" |").rsplit("|", 1)[-1].strip()
        assert meaning, f"no Attributes entry documents {row.split('|')[1].strip()}"
