"""Named blocks of ``RESULTS.md``: generated ones, and the hand-written ones kept on rebuild.

Every part of the document sits between two HTML comments (invisible once rendered)::

    <!-- generated: runs -->
    ...
    <!-- end generated: runs -->

so that a test can compare what the committed data regenerates with the committed
document block by block, and a rebuild can keep what it cannot regenerate (the
hand-written interpretation; head-to-head matches when no checkpoint is at hand).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Literal

Kind = Literal["generated", "hand-written"]
GENERATED: Kind = "generated"
HAND_WRITTEN: Kind = "hand-written"

_BLOCK = re.compile(
    r"^<!-- (?P<kind>generated|hand-written): (?P<name>[^>]+?) -->\n"
    r"(?P<body>.*?)"
    r"^<!-- end (?P=kind): (?P=name) -->$",
    re.MULTILINE | re.DOTALL,
)


def block(name: str, lines: Sequence[str], kind: Kind = GENERATED) -> list[str]:
    """``lines`` between the markers of block ``name``, then an empty line."""
    return [f"<!-- {kind}: {name} -->", *lines, f"<!-- end {kind}: {name} -->", ""]


def blocks_of(text: str, kind: Kind = GENERATED) -> dict[str, str]:
    """The bodies of a document's blocks of ``kind``, by name, in document order.

    Raises:
        ValueError: a block name occurs twice.
    """
    found: dict[str, str] = {}
    for match in _BLOCK.finditer(text):
        if match["kind"] != kind:
            continue
        if match["name"] in found:
            raise ValueError(f"block {match['name']!r} occurs twice")
        found[match["name"]] = match["body"]
    return found


def body_lines(body: str) -> list[str]:
    """A block's body (as :func:`blocks_of` returns it) as the lines :func:`block` takes."""
    return body.removesuffix("\n").split("\n") if body else []
