"""The user guide's Python snippets run as written: each page's blocks in order, in one namespace
(a later block may use what an earlier one made), in a temporary folder."""

import re
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide"
PAGES = sorted(GUIDE.glob("*.md"))


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)


def test_the_guide_has_its_pages():
    names = {p.stem for p in PAGES}
    assert {"index", "scenes", "evaluation", "training", "real_robot", "gymnasium"} <= names


@pytest.mark.integration  # whole episodes and a short training run: seconds each
@pytest.mark.parametrize("page", [p for p in PAGES if python_blocks(p)], ids=lambda p: p.stem)
def test_guide_page_snippets_run(page, tmp_path, monkeypatch):
    pytest.importorskip("gymnasium")
    monkeypatch.chdir(tmp_path)  # files the snippets write land here
    namespace = {"__name__": "guide"}
    for index, block in enumerate(python_blocks(page)):
        exec(compile(block, f"{page.name} python block {index}", "exec"), namespace)
