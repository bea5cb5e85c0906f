"""The project's Markdown holds together: README.md is a short front door, every relative link
and image in it and in docs/ resolves (file and heading), no page points outside the
repository, and every environment variable the server and the glider bridge read is documented.
Nor does any other tracked file (code comments, docstrings, TOML, scripts) cite what a clone lacks.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
SKIP_DIRS = {".venv", ".git", "node_modules", "build", "dist", "__pycache__"}

# What a page must not point at: files of the workspace around the repository, and shorthand
# that only those files explain (a section sign of a design page, a table of a thesis).
OUTSIDE = [
    re.compile(r"\.\./shared"),
    re.compile(r"\bDESIGN(\.md)?\s*§"),
    re.compile(r"\b(DESIGN|STYLE)\.md\b"),
    re.compile(r"\b(gsm-sms-at|mission-files)\.md\b"),
    re.compile(r"\.md,?\s*(§|Appendix)"),  # "level2.md §11": our pages have no numbered sections
    re.compile(r"\bthesis('s?)?\s+(§|Table|Listing|Figure|Part)", re.IGNORECASE),
]

FENCE = re.compile(r"^(```|~~~).*?^\1\s*$", re.MULTILINE | re.DOTALL)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REF_DEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)", re.MULTILINE)
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.MULTILINE)
EXTERNAL = re.compile(r"^[a-z][a-z0-9+.-]*:", re.IGNORECASE)  # http:, https:, mailto:, file:


def markdown_files() -> list[Path]:
    """Every Markdown file of the repository (not the virtualenv's, nor build output)."""
    found = []
    for path in ROOT.rglob("*.md"):
        parts = set(path.relative_to(ROOT).parts[:-1])
        if parts & SKIP_DIRS or any(p.endswith(".egg-info") for p in parts):
            continue
        found.append(path)
    return sorted(found)


def doc_pages() -> list[Path]:
    return [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]


def prose(text: str) -> str:
    """The text with code blocks and inline code removed: links are only read from prose."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link keeps its words
    text = text.replace("`", "").strip().lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    result = set()
    for heading in HEADING.findall(FENCE.sub("", path.read_text())):
        base = slug(heading)
        count = seen.get(base, 0)
        seen[base] = count + 1
        result.add(base if count == 0 else f"{base}-{count}")
    return result


def links(path: Path) -> list[str]:
    text = prose(path.read_text())
    return LINK.findall(text) + REF_DEF.findall(text)


def broken_links(path: Path, root: Path = ROOT) -> list[str]:
    root, problems = root.resolve(), []
    for target in links(path):
        if EXTERNAL.match(target):
            continue
        file_part, _, anchor = target.partition("#")
        resolved = (path.parent / file_part).resolve() if file_part else path
        where = f"{path.relative_to(root)}: {target}"
        if not resolved.is_relative_to(root):
            problems.append(f"{where} points outside the repository")
        elif not resolved.exists():
            problems.append(f"{where} does not exist")
        elif anchor and resolved.suffix == ".md" and anchor not in anchors(resolved):
            problems.append(f"{where}: no heading #{anchor} in {resolved.relative_to(root)}")
    return problems


def test_the_link_checker_finds_what_is_broken(tmp_path: Path) -> None:
    """The checker itself: a missing file, a missing heading and an escape are each caught."""
    (tmp_path / "README.md").write_text("# Front\n")
    (tmp_path / "docs").mkdir()
    page = tmp_path / "docs" / "probe.md"
    text = (
        "# Probe\n[ok](../README.md) [self](#probe) ![pic](screenshots/none.png)\n"
        "[gone](#nowhere) [up](../../outside.md) `[code](nope.md)`\n"
        "```\n[fenced](nope.md)\n```\n[ref]: missing.md\n"
    )
    page.write_text(text)
    problems = broken_links(page, root=tmp_path)
    assert len(problems) == 4, problems
    assert any("screenshots/none.png does not exist" in p for p in problems)
    assert any("no heading #nowhere" in p for p in problems)
    assert any("outside the repository" in p for p in problems)
    assert any("missing.md does not exist" in p for p in problems)


def test_slugs_follow_github() -> None:
    assert slug("How far a `move_to` may go") == "how-far-a-move_to-may-go"
    assert slug("Wave Glider bridge: `manage.py run_wg_bridge`") == (
        "wave-glider-bridge-managepy-run_wg_bridge"
    )
    assert slug("Boat API v1 (vessel keys)") == "boat-api-v1-vessel-keys"


@pytest.mark.parametrize("path", doc_pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(path: Path) -> None:
    assert broken_links(path) == []


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_markdown_points_outside_the_repository(path: Path) -> None:
    text = path.read_text()
    found = [f"line {text[: m.start()].count(chr(10)) + 1}: {m.group(0)!r}"
             for pattern in OUTSIDE for m in pattern.finditer(text)]  # fmt: skip
    assert found == []
    # Links out of the repository are caught with the other links for README and docs/;
    # the other Markdown (edge_client/README.md, test data notes) is held to the same.
    assert [p for p in broken_links(path) if "outside the repository" in p] == []


# Beyond Markdown (code comments, docstrings, data files, scripts), the same and a little more: a
# bare mention of the design page or of the thesis the first system was described in, and the
# thesis' numbering ("seed §4.3"). Words that merely contain it (hypothesis, schemathesis,
# DESIGN_WORDS) are fine.
OUTSIDE_ANYWHERE = [
    *OUTSIDE,
    re.compile(r"\bDESIGN\b"),
    re.compile(r"\bthesis\b", re.IGNORECASE),
    re.compile(r"\bseed\s*§"),
]
# This file names the patterns; fixture data under tests/**/data/ is upstream bytes kept as they
# are (its Markdown notes are ours and are checked with all Markdown above).
NOT_CHECKED = {"tests/fleet/test_docs.py"}
FIXTURE_DATA = re.compile(r"^tests/(?:.+/)?data/")


def outside_references(text: str) -> list[str]:
    """The lines of ``text`` that mention something outside the repository, as 'line N: match'
    (one entry per line, however many patterns match it)."""
    found: dict[int, str] = {}
    for pattern in OUTSIDE_ANYWHERE:
        for m in pattern.finditer(text):
            found.setdefault(text[: m.start()].count("\n") + 1, m.group(0))
    return [f"line {n}: {match!r}" for n, match in sorted(found.items())]


def tracked_text_files() -> list[str]:
    """Every file git tracks that is UTF-8 text, minus fixture data and this file."""
    listing = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=False)
    if listing.returncode != 0:
        pytest.skip("not a git checkout: the tracked files are unknown")
    paths = []
    for name in listing.stdout.decode().split("\0"):
        if not name or name in NOT_CHECKED:
            continue
        if FIXTURE_DATA.match(name) and not name.endswith(".md"):
            continue
        data = (ROOT / name).read_bytes() if (ROOT / name).is_file() else b""
        if b"\0" in data:
            continue
        try:
            data.decode()
        except UnicodeDecodeError:
            continue
        paths.append(name)
    return paths


def test_the_reference_checker_finds_what_points_outside() -> None:
    text = (
        "# ../shared/protocols/level2.md\n# DESIGN §5\n# (DESIGN: works at sea)\n"
        "# STYLE.md\n# level2.md §8.4\n# the thesis' client\n# Thesis §9\n# seed §4.1\n"
    )
    flagged = [entry.split(":")[0] for entry in outside_references(text)]
    assert flagged == [f"line {n}" for n in range(1, 9)], outside_references(text)
    fine = (
        "from hypothesis import given  # schemathesis too\nDESIGN_WORDS = set()\n"
        "# §8.4, docs/level2.md; docs/api.md#legacy-spab-endpoints; the original SPAB client\n"
    )
    assert outside_references(fine) == []


def test_no_tracked_file_points_outside_the_repository() -> None:
    files = tracked_text_files()
    assert "sms/level2/codec.py" in files and "docs/api.md" in files
    assert "tests/sms/level2/data/README.md" in files
    assert not any(f.endswith(".cfa") for f in files)
    found = [
        f"{name}: {where}"
        for name in files
        for where in outside_references((ROOT / name).read_text())
    ]
    assert found == []


def test_the_readme_is_a_front_door() -> None:
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 100
    # The two commands, exactly as scripts/ and the Makefile run them.
    assert "bash scripts/demo.sh" in text
    assert "bash scripts/test.sh" in text
    images = [t for t in LINK.findall(prose(text)) if t.endswith(".png")]
    assert images and all(t.startswith("docs/screenshots/") for t in images)
    # Where to read next: every page of docs/ is linked from the front door.
    linked = {t.partition("#")[0] for t in links(ROOT / "README.md")}
    pages = {str(p.relative_to(ROOT)) for p in DOCS.glob("*.md")}
    assert pages and pages <= linked, pages - linked


SETTING_READ = re.compile(
    r"(?:env_\w+|os\.environ\.get|os\.getenv)\(\s*\"([A-Z][A-Z0-9_]+)\"|os\.environ\[\"([A-Z0-9_]+)\"\]"
)


def env_names(path: Path) -> set[str]:
    """The variables a module reads: env helpers, os.environ and os.getenv with a literal name."""
    return {a or b for a, b in SETTING_READ.findall(path.read_text())}


def documented_text() -> str:
    return "\n".join(p.read_text() for p in DOCS.rglob("*.md"))


def test_every_setting_of_the_server_is_documented() -> None:
    names = env_names(ROOT / "fleet" / "settings.py")
    assert {"PRODUCTION", "SECRET_KEY", "DATABASE_URL", "MAP_TILES_URL", "LOG_LEVEL"} <= names
    docs = documented_text()
    missing = sorted(n for n in names if f"`{n}`" not in docs)
    assert missing == [], "settings read by fleet/settings.py but not in docs/"


def test_every_setting_of_the_glider_bridge_is_documented() -> None:
    from sms.bridge.process import ENV_PREFIX, BridgeConfig

    # run_wg_bridge reads WG_<FIELD> for every field of its config; the shore link names its own.
    bridge = {ENV_PREFIX + f.name.upper() for f in dataclasses.fields(BridgeConfig)}
    shore_config = (ROOT / "sms" / "bridge" / "shore_config.py").read_text()
    shore = set(re.findall(r"\"(WG_[A-Z0-9_]+)\"", shore_config))
    assert {"WG_VESSEL", "WG_LEVEL2_PORT", "WG_SHORE_URL", "WG_SHORE_TIMEOUT_S"} <= bridge | shore
    docs = documented_text()
    assert sorted(n for n in bridge | shore if f"`{n}`" not in docs) == []
