"""Griffe extension for the API reference (``mkdocs.yml``, mkdocstrings ``extensions``).

The docstrings are numpydoc with Sphinx cross-reference roles (``:func:`~bayes_emt.api.fit```) and
reST literal-block markers (a paragraph ending in ``::``), which Markdown would show as typed.
Before rendering, each role becomes inline code of the name it shows (the last component after
``~``, the text before ``<target>``), and a ``::`` closing a line becomes ``:``; the docstrings in
the source are unchanged.
"""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|obj|exc|const):`([^`]+)`")
LITERAL = re.compile(r"(?<=\S)::[ \t]*$", re.M)


def _shown(target: str) -> str:
    target = target.strip()
    m = re.match(r"(.*?)\s*<([^>]+)>$", target)
    if m:
        return m.group(1)
    if target.startswith("~"):
        return target[1:].rsplit(".", 1)[-1]
    return target


def plain_markdown(text: str) -> str:
    """``text`` with Sphinx roles as inline code and reST ``::`` markers as ``:``."""
    text = ROLE.sub(lambda m: f"`{_shown(m.group(1))}`", text)
    text = LITERAL.sub(":", text)
    return re.sub(r"^[ \t]*::[ \t]*$", "", text, flags=re.M)


class RstRoles(griffe.Extension):
    """Rewrite every loaded object's docstring with :func:`plain_markdown`."""

    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = plain_markdown(obj.docstring.value)
