"""``docs/RESULTS.md`` is rebuilt from the committed study data, without training or matches.

The report's generated blocks depend only on committed files (each run's
``summary.json``, ``metrics.csv`` and ``.hydra/config.yaml``; each study's
``round_robin.json``) and must equal the committed document's, character for character.
Not compared: the environment (the machine) and the footer (the report's duration).
On a checkout whose study directories hold runs that are not committed (runs still
training), the comparison is skipped: those runs are not in the committed document.
"""

from __future__ import annotations

import subprocess

import pytest

from benchmarks import report as report_cli
from benchmarks.reporting.blocks import HAND_WRITTEN, blocks_of
from benchmarks.reporting.document import build_report
from benchmarks.reporting.plan import studies
from benchmarks.reporting.summary import SUMMARY_FILE
from rlhc.analysis.curves import METRICS_FILE

ROOT = report_cli.ROOT
COMMITTED = ROOT / "docs" / "RESULTS.md"
#: Generated blocks that describe this invocation or this machine.
NOT_REBUILT = {"environment", "footer"}


def run_dirs_on_disk() -> set[str]:
    """Every run directory (one holding ``metrics.csv``) under the studies' roots."""
    return {
        str(path.parent.relative_to(ROOT))
        for study in studies().values()
        for path in study.root.glob(f"*/seed_*/{METRICS_FILE}")
    }


def committed_files() -> list[str]:
    """The files git tracks under the studies' roots."""
    roots = [str(study.root.relative_to(ROOT)) for study in studies().values()]
    return subprocess.run(
        ["git", "ls-files", "--", *roots], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()


def committed_run_dirs() -> set[str]:
    """Run directories whose ``metrics.csv`` git tracks."""
    return {p.rsplit("/", 1)[0] for p in committed_files() if p.endswith(f"/{METRICS_FILE}")}


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory: pytest.TempPathFactory) -> str:
    """The report from the committed data: no matches, no figures, output elsewhere."""
    uncommitted = run_dirs_on_disk() - committed_run_dirs()
    if uncommitted:
        pytest.skip(f"runs not committed yet (still training?): {sorted(uncommitted)}")
    out = tmp_path_factory.mktemp("docs") / "RESULTS.md"
    return build_report(
        report_cli.parse_args(["--matches", "0", "--no-figures", "--out", str(out)])
    )


def test_every_committed_run_has_a_summary() -> None:
    missing = [d for d in committed_run_dirs() if not (ROOT / d / SUMMARY_FILE).is_file()]
    assert not missing, f"committed runs without {SUMMARY_FILE}: {sorted(missing)}"


def test_committed_results_rebuild_from_committed_data(rebuilt: str) -> None:
    committed = blocks_of(COMMITTED.read_text())
    generated = blocks_of(rebuilt)
    assert list(committed) == list(generated), "the document's blocks or their order changed"
    compared = [name for name in generated if name not in NOT_REBUILT]
    assert {"status", "plan", "runs", "matches", "aggregates", "claims"} <= set(compared)
    assert [n for n in compared if n.startswith("study ")] == [f"study {s}" for s in studies()]
    for name in compared:
        assert generated[name] == committed[name], f"block {name!r} differs"
    assert blocks_of(COMMITTED.read_text(), HAND_WRITTEN), "the interpretation block is gone"


def test_committed_data_keeps_no_hydra_internals_or_empty_logs() -> None:
    files = committed_files()
    assert not [p for p in files if p.endswith("/hydra.yaml")]
    assert not [p for p in files if p.endswith(".log") and not (ROOT / p).stat().st_size]
    assert any(p.endswith("/.hydra/config.yaml") for p in files)
