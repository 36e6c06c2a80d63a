"""Every repository path that the README and the docs cite exists.

A path in the tree (``results/sweep-v4/sweep.png``) must exist in the checkout; a glob
(``results/mujoco-tags/*.json``) must match at least one file; a path at a commit
(``53b1240:results/old.json``, read with ``git show 53b1240:results/old.json``) must exist at that
commit, which the test checks where the clone has the history. Braces expand as in a shell
(``hybrid_s{2,3}.json``) and a lone capital stands for any part of a name (``M_sS.json``: method M,
stage S), so a template cites every file it names.
"""

from __future__ import annotations

import itertools
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CITING = [ROOT / "README.md", ROOT / "CONTRIBUTING.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "docs").rglob("*.rst"))]
TOP_FOLDERS = ("results", "checkpoints", "scripts", "benchmarks", "examples")
# a path starts a token (after an optional ``../`` chain or a commit and a colon) in one of the top folders
CITED = re.compile(
    r"(?<![\w./:-])(?:\.\./)*(?:(?P<rev>[0-9a-f]{7,40}):)?(?P<path>(?:"
    + "|".join(TOP_FOLDERS)
    + r")/(?:[A-Za-z0-9_./*-]|\{[A-Za-z0-9_.,*-]*\})*)"
)
BRACES = re.compile(r"\{([^{}]*)\}")
PLACEHOLDER = re.compile(r"(?<![A-Z])[A-Z](?![A-Z])")


def expand(path: str) -> list[str]:
    """The paths a cited template names: braces expanded, lone capitals turned into ``*``.

    >>> expand("results/M_s{2,3}.json")
    ['results/*_s2.json', 'results/*_s3.json']
    >>> expand("checkpoints/README.md")
    ['checkpoints/README.md']
    """
    pieces = BRACES.split(path)  # text, choices, text, choices, ..., text
    choices = [piece.split(",") if index % 2 else [piece] for index, piece in enumerate(pieces)]
    paths = ["".join(parts) for parts in itertools.product(*choices)]
    return [path if path.endswith(".md") else PLACEHOLDER.sub("*", path) for path in paths]


def cited_paths() -> list[tuple[str, str | None, str]]:
    """(citing file, commit or None, path) for every path cited by the README and the docs."""
    found = set()
    for page in CITING:
        for match in CITED.finditer(page.read_text(encoding="utf-8")):
            for path in expand(match.group("path").rstrip(".")):
                found.add((str(page.relative_to(ROOT)), match.group("rev"), path))
    return sorted(found, key=lambda item: (item[0], item[1] or "", item[2]))


def exists_at(rev: str, path: str) -> bool | None:
    """Whether ``path`` exists at commit ``rev``; None where this clone lacks the commit."""
    has_commit = subprocess.run(["git", "cat-file", "-e", f"{rev}^{{commit}}"], cwd=ROOT, capture_output=True)
    if has_commit.returncode != 0:
        return None
    return subprocess.run(["git", "cat-file", "-e", f"{rev}:{path.rstrip('/')}"], cwd=ROOT, capture_output=True).returncode == 0


CITATIONS = cited_paths()


def test_the_docs_cite_repository_paths():
    assert len(CITATIONS) >= 20


def test_the_pattern_reads_tree_paths_commit_paths_and_globs():
    text = "see results/a/b.json, ../results/c.png and `53b1240:results/d.json` or scripts/*.py. Not https://x.org/examples/e"
    found = [(m.group("rev"), m.group("path").rstrip(".")) for m in CITED.finditer(text)]
    assert found == [(None, "results/a/b.json"), (None, "results/c.png"), ("53b1240", "results/d.json"), (None, "scripts/*.py")]
    assert [m.group("path") for m in CITED.finditer("(`results/x_s{2,3}.{txt,json}`)")] == ["results/x_s{2,3}.{txt,json}"]


@pytest.mark.parametrize("page,rev,path", [c for c in CITATIONS if c[1] is None], ids=lambda value: str(value))
def test_cited_path_exists_in_the_tree(page, rev, path):
    if "*" in path:
        assert list(ROOT.glob(path)), f"{page} cites {path}, which matches no file"
    else:
        assert (ROOT / path).exists(), f"{page} cites {path}, which is not in the tree (cite a removed file as COMMIT:{path})"


@pytest.mark.parametrize("page,rev,path", [c for c in CITATIONS if c[1] is not None], ids=lambda value: str(value))
def test_cited_path_exists_at_its_commit(page, rev, path):
    if "*" in path:
        pytest.skip("a template at a commit is not checked")
    present = exists_at(rev, path)
    if present is None:
        pytest.skip(f"this clone lacks commit {rev} (a shallow clone)")
    assert present, f"{page} cites {rev}:{path}, which `git show {rev}:{path}` does not find"
