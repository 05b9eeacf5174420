"""MkDocs hooks (mkdocs.yml `hooks:`): the README as the site's home page, links out of docs/ kept working.

The Markdown files link as GitHub shows them: the README (repository root) to `docs/*.md`, the pages
in docs/ back to `../README.md` and to files elsewhere in the repository (`../examples/study.yaml`).
On the site the README becomes `index.md`; a link to a page or figure under docs/ becomes one
relative to docs/, a link to the README one to `index.md`, and a link to any other file of the
repository one to that file on `repo_url`.
"""

from __future__ import annotations

import posixpath
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

README = "README.md"
DOCS = "docs"
HOME = "index.md"

# The target of [text](target), [text](target "title") and ![alt](target).
_LINK = re.compile(r"(\]\()([^)\s]+)((?:\s+\"[^\"]*\")?\))")
_FENCE = re.compile(r"^(```|~~~)")


def _outside_code(markdown: str, rewrite: Callable[[str], str]) -> str:
    """Applies `rewrite` to the lines outside fenced code blocks and lines indented as code (a link
    in a list item's indented continuation is left alone too, and strict mode reports it)."""
    out, fenced = [], False
    for line in markdown.splitlines(keepends=True):
        if _FENCE.match(line.lstrip()):
            fenced = not fenced
        out.append(line if fenced or line.startswith("    ") else rewrite(line))
    return "".join(out)


def _rewrite_links(markdown: str, source: str, site: str, repo_url: str) -> str:
    """The links of a Markdown file in the repository folder `source`, published from the folder
    `site` (both repository-relative; "" is the root), as the site needs them."""

    def target(match: re.Match[str]) -> str:
        link = match.group(2)
        if re.match(r"^[a-z][a-z0-9+.-]*:", link, re.IGNORECASE) or link.startswith(("#", "/")):
            return match.group(0)  # a URL, an anchor on the same page, or a site-absolute path
        path, hash_, anchor = link.partition("#")
        resolved = posixpath.normpath(posixpath.join(source, path))
        if resolved == README:
            new = posixpath.relpath(posixpath.join(DOCS, HOME), site)
        elif resolved == DOCS or resolved.startswith(DOCS + "/"):
            new = posixpath.relpath(resolved, site)
        else:
            new = f"{repo_url.rstrip('/')}/blob/main/{resolved}"
        return f"{match.group(1)}{new}{hash_}{anchor}{match.group(3)}"

    return _outside_code(markdown, lambda line: _LINK.sub(target, line))


def on_files(files: Files, config: Any) -> Files:
    """Adds the README as the home page."""
    if files.get_file_from_path(HOME) is not None:
        raise PluginError(f"docs/{HOME} exists, but the home page is the README (scripts/mkdocs_hooks.py)")
    readme = Path(config["docs_dir"]).parent / README
    content = _rewrite_links(readme.read_text(encoding="utf-8"), "", DOCS, config["repo_url"])
    files.append(File.generated(config, HOME, content=content))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    """Links of the pages under docs/ that leave docs/ (the README, examples, test data)."""
    if page.file.src_uri == HOME:
        return markdown
    folder = posixpath.join(DOCS, posixpath.dirname(page.file.src_uri)).rstrip("/")
    return _rewrite_links(markdown, folder, folder, config["repo_url"])
