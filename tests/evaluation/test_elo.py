"""Elo maths pinned on hand-computed numbers; ratings move the right way."""

from __future__ import annotations

import pytest

from rlhc.evaluation.elo import EloTable, elo_update, expected_score, round_robin


def test_expected_score_hand_computed() -> None:
    # 400 points apart: 10:1 odds, E = 1 / (1 + 10^-1) = 10/11.
    assert expected_score(1600, 1200) == pytest.approx(10 / 11)
    assert expected_score(1200, 1600) == pytest.approx(1 / 11)
    assert expected_score(1500, 1500) == 0.5


def test_update_hand_computed() -> None:
    # 200 apart: E = 1 / (1 + 10^-0.5) = 0.759746927...; the favourite loses, K = 32:
    # change = 32 * (0 - 0.759746927) = -24.31190166.
    favourite, underdog = elo_update(1200.0, 1000.0, 0.0, k=32.0)
    assert favourite == pytest.approx(1175.68809834, abs=1e-6)
    assert underdog == pytest.approx(1024.31190166, abs=1e-6)
    # A draw between equals changes nothing; a win between equals moves K/2 each way.
    assert elo_update(1200.0, 1200.0, 0.5, k=20.0) == (1200.0, 1200.0)
    assert elo_update(1200.0, 1200.0, 1.0, k=20.0) == (1210.0, 1190.0)


def test_update_conserves_total_and_rejects_bad_scores() -> None:
    a, b = elo_update(1337.0, 1111.0, 0.25, k=24.0)
    assert a + b == pytest.approx(1337.0 + 1111.0)
    with pytest.raises(ValueError, match="score"):
        elo_update(1200.0, 1200.0, 1.5)


def test_table_sequence_hand_computed() -> None:
    table = EloTable(k=32.0, initial=1200.0)
    table.record("a", "b", 1.0)  # equals: +16 / -16
    assert table.ratings == {"a": 1216.0, "b": 1184.0}
    table.record("a", "b", 1.0)  # E_a = 1 / (1 + 10^(-32/400))
    e = 1.0 / (1.0 + 10.0 ** (-32.0 / 400.0))
    assert table.ratings["a"] == pytest.approx(1216.0 + 32.0 * (1.0 - e))
    assert table.games == {"a": 2, "b": 2}


def test_clearly_stronger_player_rises() -> None:
    table = EloTable(k=32.0)
    table.record_pairings(
        {
            ("strong", "weak"): [1.0] * 20,
            ("strong", "middle"): [1.0, 0.5] * 10,
            ("middle", "weak"): [1.0, 0.0, 1.0] * 5,
        }
    )
    standings = [player for player, _, _ in table.standings()]
    assert standings == ["strong", "middle", "weak"]
    assert table.ratings["strong"] > 1200.0 > table.ratings["weak"]
    assert sum(table.ratings.values()) == pytest.approx(3 * 1200.0)
    assert "strong" in table.format().splitlines()[1]


def test_round_robin_pairs_each_once() -> None:
    assert round_robin(["a", "b", "c", "a"]) == [("a", "b"), ("a", "c"), ("b", "c")]
    with pytest.raises(ValueError, match="itself"):
        EloTable().record("a", "a", 1.0)
