"""MkDocs hooks of the docs site (``mkdocs.yml``: ``hooks``; not a page of the site).

* The configuration page's settings table is generated at build time by
  :func:`rlhc.config.table.table` from the schemas and ``conf/``, where the page holds
  :data:`CONFIG_TABLE`, so the published table cannot drift from the code.
* The API reference renders the package's docstrings, whose cross-references are
  reStructuredText roles (``:class:`~rlhc.envs.base.BatchedGame```): they are shown
  as inline code, the last component only where the role asks for it with ``~``.
"""

from __future__ import annotations

import re
from typing import Any

#: Where a page wants the generated settings table.
CONFIG_TABLE = "<!-- the generated configuration table -->"

#: ``:class:<code>~a.b.C</code>`` as the API pages' HTML carries a role.
ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|exc|obj|const):<code>(~?)([^<]+)</code>")


def render_config_table(markdown: str) -> str:
    """The page with :data:`CONFIG_TABLE` replaced by the generated table."""
    if CONFIG_TABLE not in markdown:
        return markdown
    from rlhc.config.table import table

    return markdown.replace(CONFIG_TABLE, table())


def roles_as_code(html: str) -> str:
    """reStructuredText roles of the rendered docstrings as plain inline code.

    Examples:
        >>> roles_as_code("see :class:<code>~rlhc.envs.base.BatchedGame</code>")
        'see <code>BatchedGame</code>'
    """

    def code(match: re.Match[str]) -> str:
        name = match.group(2)
        return f"<code>{name.rsplit('.', 1)[-1] if match.group(1) else name}</code>"

    return ROLE.sub(code, html)


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    return render_config_table(markdown)


def on_page_content(html: str, **kwargs: Any) -> str:
    return roles_as_code(html)
