"""Every relative link and image in the repository's Markdown resolves to a tracked file (and
an anchor to a heading of it); every `docs/...` path named in tracked text exists; every
image under docs/img is shown by some page."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
DOC_PATH = re.compile(r"(?<![\w/.])docs/[\w./-]+\.(?:md|png|gif|py)")
TEXT_SUFFIXES = {".md", ".py", ".toml", ".txt", ".cfg", ".yml", ".yaml"}
# History may name what is gone; this file names missing paths on purpose.
NOT_CHECKED = {"CHANGELOG.md", "tests/docs/test_docs_links.py"}


def _tracked() -> set[str]:
    try:
        out = subprocess.run(
            ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: tracked files unknown")
    return {line for line in out.splitlines() if (ROOT / line).exists()}


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]|\[|\]|\([^)]*\)(?=$)", "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(markdown: str) -> set[str]:
    body = re.sub(r"```.*?```", "", markdown, flags=re.S)
    return {slug(h) for h in re.findall(r"^#{1,6} (.+)$", body, re.M)}


def broken_links(page: str, markdown: str, tracked: set[str]) -> list[str]:
    """The links of one page (a path relative to ROOT) that do not resolve."""
    body = re.sub(r"```.*?```", "", markdown, flags=re.S)
    bad = []
    for target in LINK.findall(body):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        if path:
            resolved = (ROOT / page).parent.joinpath(path).resolve()
            rel = resolved.relative_to(ROOT).as_posix() if resolved.is_relative_to(ROOT) else None
            if rel not in tracked:
                bad.append(f"{page}: {target} (no tracked file {rel or resolved})")
                continue
        else:
            rel = page
        if anchor and rel.endswith(".md"):
            if anchor not in anchors((ROOT / rel).read_text()):
                bad.append(f"{page}: {target} (no heading #{anchor} in {rel})")
    return bad


def test_every_markdown_link_and_image_resolves_to_a_tracked_file():
    tracked = _tracked()
    bad = [
        problem
        for page in sorted(p for p in tracked if p.endswith(".md"))
        for problem in broken_links(page, (ROOT / page).read_text(), tracked)
    ]
    assert not bad, "broken links:\n" + "\n".join(bad)


def test_every_docs_path_named_in_tracked_text_exists():
    tracked = _tracked()
    texts = [
        p
        for p in tracked
        if (Path(p).suffix in TEXT_SUFFIXES or Path(p).name == "Makefile") and p not in NOT_CHECKED
    ]
    bad = [
        f"{page}: {name}"
        for page in texts
        for name in DOC_PATH.findall((ROOT / page).read_text(errors="replace"))
        if name not in tracked
    ]
    assert not bad, "paths to missing docs:\n" + "\n".join(bad)


def test_every_image_under_docs_img_is_shown_by_a_page():
    tracked = _tracked()
    pages = "\n".join((ROOT / p).read_text() for p in tracked if p.endswith(".md"))
    images = [p for p in tracked if p.startswith("docs/img/") and p.endswith((".png", ".gif"))]
    unshown = [p for p in images if Path(p).name not in pages]
    assert not unshown, f"images no page shows: {unshown}"


def test_the_checker_finds_a_broken_link_an_untracked_image_and_a_missing_anchor():
    tracked = _tracked()
    page = "docs/model.md"
    assert broken_links(page, "[x](nowhere.md) ![y](img/none.png)", tracked) == [
        "docs/model.md: nowhere.md (no tracked file docs/nowhere.md)",
        "docs/model.md: img/none.png (no tracked file docs/img/none.png)",
    ]
    assert broken_links(page, "[x](scenes.md#no-such-heading)", tracked)
    assert broken_links(page, "[x](#constants) [y](https://example.org)", tracked) == []
