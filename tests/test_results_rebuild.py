"""``docs/RESULTS.md`` is rebuilt from the committed study data, without training or matches.

The report's generated blocks that depend only on committed files (each run's
``summary.json``, ``metrics.csv`` and ``.hydra/config.yaml``) must equal the committed
document's, character for character. Not compared: the commands and the footer (they
name this invocation), the environment (the machine), and the head-to-head matches
(they need the runs' checkpoints, which are not committed).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks import report as report_cli
from benchmarks.reporting.blocks import HAND_WRITTEN, blocks_of
from benchmarks.reporting.document import build_report
from benchmarks.reporting.plan import RESULTS, STUDIES, plan

COMMITTED = report_cli.ROOT / "docs" / "RESULTS.md"
#: Generated blocks that need more than the committed files, or describe this invocation.
NOT_REBUILT = {"commands", "environment", "footer", "matches", "match claims"}


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory: pytest.TempPathFactory) -> str:
    """The report from the committed data: no matches, no figures, output elsewhere."""
    out = tmp_path_factory.mktemp("docs") / "RESULTS.md"
    return build_report(
        report_cli.parse_args(["--matches", "0", "--no-figures", "--out", str(out)])
    )


def test_every_planned_run_has_a_complete_summary() -> None:
    missing = [
        r for r in plan(list(STUDIES)) if not (r.run_dir(RESULTS) / "summary.json").is_file()
    ]
    assert not missing, f"runs without summary.json: {[r.run_dir(RESULTS) for r in missing]}"


def test_committed_results_rebuild_from_committed_data(rebuilt: str) -> None:
    committed = blocks_of(COMMITTED.read_text())
    generated = blocks_of(rebuilt)
    assert list(committed) == list(generated), "the document's blocks or their order changed"
    compared = [name for name in generated if name not in NOT_REBUILT]
    assert {"status", "runs", "claims"} <= set(compared)
    assert [n for n in compared if n.startswith("study ")] == [f"study {s}" for s in STUDIES]
    for name in compared:
        assert generated[name] == committed[name], f"block {name!r} differs"
    assert "Status: complete." in generated["status"]
    assert blocks_of(COMMITTED.read_text(), HAND_WRITTEN), "the interpretation block is gone"


def test_committed_data_keeps_no_hydra_internals_or_empty_logs() -> None:
    assert not list(RESULTS.rglob("hydra.yaml"))
    assert not [p for p in RESULTS.rglob("*.log") if p.stat().st_size == 0]
    assert Path(RESULTS / "tennis" / "ppo" / "seed_0" / ".hydra" / "config.yaml").is_file()
