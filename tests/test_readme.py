"""The README's Python blocks run as written (a tour that fails to run is worse than none)."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_the_readme_is_short_and_opens_with_the_two_commands():
    lines = README.read_text().splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines: keep it at most 200 (the lab log holds the history)"
    first_block = README.read_text().split("```bash\n", 1)[1].split("```", 1)[0]
    assert "pip install -e . && occrl demo" in first_block
    assert 'pip install -e ".[test]" && python -m pytest -q' in first_block


def test_the_readme_has_python_blocks():
    assert len(BLOCKS) >= 3


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_block_runs(index, tmp_path, monkeypatch):
    pytest.importorskip("gymnasium")
    monkeypatch.chdir(tmp_path)  # files the block writes (episode.gif) land here
    exec(compile(BLOCKS[index], f"README.md python block {index}", "exec"), {"__name__": "readme"})
