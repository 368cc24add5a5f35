"""An mkdocs hook (mkdocs.yml ``hooks:``): links from a page to files of the repository
outside docs/ (``../plugins/lodkit-max-edge/``, ``../bench/pictures.py``) work on a code
host but not on the site. On the site such a link becomes the path in a code span; a link
to a path that does not exist stops a strict build. Links inside docs/ are left to
mkdocs' own checks (``validation:`` in mkdocs.yml).
"""
from __future__ import annotations

import logging
import re
from pathlib import Path

log = logging.getLogger("mkdocs.plugins.lodkit_repo_links")

_FENCE = re.compile(r"^(```|~~~)")
_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")


def on_page_markdown(markdown, page, config, files, **kwargs):
    docs = Path(config["docs_dir"]).resolve()
    repo = docs.parent
    here = (docs / page.file.src_path).parent
    out, fenced = [], False

    def fix(m):
        bang, text, target = m.groups()
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith(("#", "/")):
            return m.group(0)
        path = target.split("#", 1)[0]
        resolved = (here / path).resolve()
        try:
            resolved.relative_to(docs)
            return m.group(0)                    # a page or picture of the site: mkdocs checks it
        except ValueError:
            pass
        try:
            rel = resolved.relative_to(repo)
        except ValueError:
            log.error("%s: link %s points outside the repository", page.file.src_path, target)
            return m.group(0)
        if not resolved.exists():
            log.error("%s: link %s: no such file in the repository (%s)", page.file.src_path, target, rel)
            return m.group(0)
        shown = rel.as_posix() + ("/" if resolved.is_dir() else "")
        return f"{text} (`{shown}`)" if text and text.strip("`") != shown.rstrip("/") else f"`{shown}`"

    for line in markdown.split("\n"):
        if _FENCE.match(line.lstrip()):
            fenced = not fenced
        out.append(line if fenced else _LINK.sub(fix, line))
    return "\n".join(out)
