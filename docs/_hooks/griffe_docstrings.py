"""A griffe extension for the API reference (mkdocs.yml): lodkit's docstrings are plain
text written to read in ``help()``; this turns the three conventions that do not read as
Markdown into Markdown, leaving the source untouched.

- ``>>>`` examples become ``python`` code blocks;
- option tables (``name : what it does`` with aligned continuation lines) become ``text``
  code blocks, so their alignment survives;
- Sphinx roles (``:func:`x```, ``:class:`x```, ...) become code spans.
"""
from __future__ import annotations

import re

import griffe

_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|exc|obj|ref):`~?([^`]+)`")
_OPTION = re.compile(r"^\s*[\w\[\]\"'*.,=() -]+?\s+: \S")


def markdown(text: str) -> str:
    lines = _ROLE.sub(r"`\1`", text).split("\n")
    out, i = [], 0
    while i < len(lines):
        line = lines[i]
        kind = "python" if line.lstrip().startswith(">>>") else "text" if _OPTION.match(line) else None
        if kind is None:
            out.append(line)
            i += 1
            continue
        j = i + 1
        while j < len(lines) and lines[j].strip() and (
                kind == "python" and (lines[j].lstrip().startswith(("...", ">>>")) or lines[j].startswith("    "))
                or kind == "text" and (_OPTION.match(lines[j]) or lines[j][:1].isspace())):
            j += 1
        indent = len(line) - len(line.lstrip())
        block = [ln[indent:] if not ln[:indent].strip() else ln.lstrip() for ln in lines[i:j]]
        if kind == "text":                   # no Markdown inside a code block: drop the backticks
            block = [re.sub(r"``?([^`]+)``?", r"\1", ln) for ln in block]
        if out and out[-1].strip():
            out.append("")
        out += [f"```{kind}", *block, "```", ""]
        i = j
    return "\n".join(out)


class MarkdownDocstrings(griffe.Extension):
    """Rewrite every docstring with :func:`markdown` as it is loaded."""

    def on_object(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown(obj.docstring.value)
