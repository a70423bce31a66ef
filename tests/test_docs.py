"""The README and docs/*.md: every relative link and image resolves.

A link is checked when it is relative (no scheme such as ``https:``): the file it names
must exist inside the repository, an image must be a non-empty picture, and a
``#fragment`` into a Markdown file must name one of its headings (as GitHub makes
anchors from headings). Links inside code blocks and code spans are not links.
"""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Pages linked before they exist: each is being written by another helper this session.
# Delete an entry once its page is merged (test_expected_later_pages_are_still_missing
# says when); a page not listed here must exist.
EXPECTED_LATER: set[str] = set()  # (robustness.md and recordings.md: merged)

IMAGE_SUFFIXES = {".png", ".svg", ".jpg", ".jpeg", ".gif", ".webp"}

_FENCE = re.compile(r"^( {0,3})(`{3,}|~{3,})[^\n]*\n.*?^\1\2[`~]*[ \t]*$", re.M | re.S)
_CODE_SPAN = re.compile(r"(`+)(?!`).+?(?<!`)\1(?!`)", re.S)
_COMMENT = re.compile(r"<!--.*?-->", re.S)
# [text](target "title") and ![alt](target); text may hold one level of brackets.
_INLINE = re.compile(
    r"(!?)\[((?:[^\[\]]|\[[^\[\]]*\])*)\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)"
)
_REFERENCE = re.compile(r"^ {0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$", re.M)
_HTML = re.compile(r"<(img|a)\b[^>]*?\b(src|href)\s*=\s*\"([^\"]+)\"", re.I)
_HEADING = re.compile(r"^ {0,3}#{1,6}[ \t]+(.+?)[ \t#]*$", re.M)
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


def doc_pages() -> list[Path]:
    """README.md and every Markdown page in docs/."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _prose(markdown: str) -> str:
    """The text with code blocks, code spans and HTML comments blanked out."""
    for pattern in (_FENCE, _COMMENT, _CODE_SPAN):
        markdown = pattern.sub(" ", markdown)
    return markdown


def links(markdown: str) -> list[tuple[bool, str]]:
    """(is_image, target) of every link and image in a Markdown text, in order.

    Inline links and images, reference definitions, and HTML ``<img src>`` / ``<a href>``.
    """
    text = _prose(markdown)
    found = [(bang == "!", target) for bang, _, target in _INLINE.findall(text)]
    found += [(False, target) for target in _REFERENCE.findall(text)]
    found += [(tag.lower() == "img", target) for tag, _, target in _HTML.findall(text)]
    return found


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: inline markup dropped, lower case, punctuation
    removed (letters, digits, ``-`` and ``_`` kept), spaces made ``-``."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link's text only
    text = re.sub(r"<[^>]+>", "", text)
    kept = "".join(
        ch for ch in text.lower() if ch in " -_" or unicodedata.category(ch)[0] in ("L", "N", "M")
    )
    return kept.replace(" ", "-")


def anchors(markdown: str) -> set[str]:
    """Every heading anchor of a Markdown text, with GitHub's -1, -2 for repeats."""
    seen: dict[str, int] = {}
    result = set()
    for heading in _HEADING.findall(_FENCE.sub(" ", markdown)):
        anchor = github_anchor(heading)
        count = seen.get(anchor, 0)
        seen[anchor] = count + 1
        result.add(anchor if count == 0 else f"{anchor}-{count}")
    return result


def broken_links(page: Path, root: Path = ROOT, expected_later=frozenset()) -> list[str]:
    """What is wrong with the relative links of one page: one message per broken link."""
    problems = []
    markdown = page.read_text(encoding="utf-8")
    for is_image, target in links(markdown):
        if _SCHEME.match(target) or target.startswith("//"):
            continue  # a web address: not checked offline
        path_part, _, fragment = target.partition("#")
        resolved = (page.parent / path_part).resolve() if path_part else page.resolve()
        where = f"{page.relative_to(root)}: {target!r}"
        try:
            relative = resolved.relative_to(root.resolve()).as_posix()
        except ValueError:
            problems.append(f"{where} points outside the repository")
            continue
        if not resolved.exists():
            if relative not in expected_later:
                problems.append(f"{where}: no such file {relative}")
            continue
        if is_image:
            if resolved.suffix.lower() not in IMAGE_SUFFIXES or resolved.stat().st_size == 0:
                problems.append(f"{where}: not a picture ({relative})")
            continue
        if fragment and resolved.suffix == ".md":
            if fragment not in anchors(resolved.read_text(encoding="utf-8")):
                problems.append(f"{where}: {relative} has no heading with anchor #{fragment}")
    return problems


@pytest.mark.parametrize("page", doc_pages(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_and_images_resolve(page: Path) -> None:
    assert broken_links(page, expected_later=EXPECTED_LATER) == []


def test_the_front_page_links_into_docs_and_shows_the_viewer() -> None:
    found = links((ROOT / "README.md").read_text(encoding="utf-8"))
    targets = {target for _, target in found}
    images = {target for is_image, target in found if is_image}
    assert "docs/img/viewer.png" in images
    for page in ("model", "paper-controller", "fuzzynav", "figures", "speed", "layout"):
        assert any(t.split("#")[0] == f"docs/{page}.md" for t in targets), page


def test_expected_later_pages_are_still_missing() -> None:
    """An allowance outlives its reason once the page exists: delete it from EXPECTED_LATER."""
    merged = sorted(name for name in EXPECTED_LATER if (ROOT / name).exists())
    assert merged == [], f"now merged, delete from EXPECTED_LATER in {__file__}: {merged}"


# The checker itself, on pages made for the purpose.


def test_links_found_and_code_ignored() -> None:
    markdown = (
        'See [a](a.md), [b [x]](b.md#part "title") and ![pic](img/p.png).\n'
        "[ref]: c.md\n"
        '<img src="d.png"> and [web](https://example.org).\n'
        "`[not](code.md)` and\n"
        "```\n[also not](fenced.md)\n```\n"
        "<!-- [nor](commented.md) -->\n"
    )
    assert links(markdown) == [
        (False, "a.md"),
        (False, "b.md#part"),
        (True, "img/p.png"),
        (False, "https://example.org"),
        (False, "c.md"),
        (True, "d.png"),
    ]


@pytest.mark.parametrize(
    ("heading", "anchor"),
    [
        ("Table 4, as now measured", "table-4-as-now-measured"),
        ("Near the paper's scenarios", "near-the-papers-scenarios"),
        (
            "fuzzynav's own navigator (`--controller fuzzynav`)",
            "fuzzynavs-own-navigator---controller-fuzzynav",
        ),
        ("Does it generalise?", "does-it-generalise"),
        ("Doubted inputs, measured (item 10)", "doubted-inputs-measured-item-10"),
    ],
)
def test_github_anchor(heading: str, anchor: str) -> None:
    assert github_anchor(heading) == anchor


def test_broken_links_are_named(tmp_path: Path) -> None:
    (tmp_path / "img").mkdir()
    (tmp_path / "img" / "ok.png").write_bytes(b"\x89PNG")
    (tmp_path / "img" / "empty.png").write_bytes(b"")
    (tmp_path / "other.md").write_text("# Part one\n\n## Part one\n", encoding="utf-8")
    page = tmp_path / "page.md"
    page.write_text(
        "![ok](img/ok.png) ![empty](img/empty.png) ![gone](img/gone.png)\n"
        "[fine](other.md#part-one) [repeat](other.md#part-one-1) [bad](other.md#part-two)\n"
        "[missing](missing.md) [later](later.md) [self](#nowhere) [out](../outside.md)\n",
        encoding="utf-8",
    )
    problems = broken_links(page, root=tmp_path, expected_later={"later.md"})
    assert len(problems) == 6, problems
    for expected in ("empty.png", "gone.png", "#part-two", "missing.md", "#nowhere", "outside"):
        assert any(expected in problem for problem in problems), expected
    assert not any("later.md" in problem for problem in problems)
