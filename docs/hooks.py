# SPDX-License-Identifier: Apache-2.0
"""MkDocs hook of the hapgate site (mkdocs.yml): the site is the repository's own Markdown.

Every file of the checkout (tracked, or new and not ignored) becomes a site file at its path in
the repository: README.md is the home page, rtl/interp/README.md stays rtl/interp/, and a link to
a source file (`../../rtl/regs/hapgate.rdl`) finds a copy of it. So a relative link that works on
GitHub works in the site, and `mkdocs build --strict` fails on one that works in neither.
Headings get GitHub's anchors, so `#fit-the-hx8k-at-75-` is checked as GitHub resolves it.
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parent.parent
SKIP_DIRS = {"build", ".venv", ".git", "__pycache__", "node_modules"}


def github_slug(value: str, separator: str = "-") -> str:
    """GitHub's heading anchor: lower case, punctuation dropped, each space a hyphen."""
    return re.sub(r"[^\w\- ]", "", value.strip().lower()).replace(" ", separator)


def repo_files() -> list[str]:
    """Tracked files and new files git does not ignore; without git, a walk of the tree."""
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                             cwd=ROOT, capture_output=True, text=True, check=True).stdout
        names = [n for n in out.splitlines() if n and (ROOT / n).is_file()]
    except (OSError, subprocess.CalledProcessError):
        names = []
        for d, dirs, files in os.walk(ROOT):
            dirs[:] = [x for x in dirs if x not in SKIP_DIRS and not x.startswith(".")]
            names += [str((Path(d) / f).relative_to(ROOT)) for f in files]
    return sorted(n for n in names if not any(p.startswith(".") for p in Path(n).parts))


def on_config(config, **_):
    config["mdx_configs"].setdefault("toc", {})["slugify"] = github_slug
    return config


def on_files(files: Files, config, **_) -> Files:
    site = Files([])
    for name in repo_files():
        site.append(File(name, str(ROOT), config["site_dir"], config["use_directory_urls"]))
    return site
