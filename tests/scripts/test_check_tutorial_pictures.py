"""scripts/check_tutorial_pictures.py fails a built tutorial page without a picture or missing."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("check_tutorial_pictures", ROOT / "scripts" / "check_tutorial_pictures.py")
check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check)


def _site(tmp_path: Path, pages: dict[str, str]) -> tuple[Path, Path]:
    notebooks, html = tmp_path / "notebooks", tmp_path / "html"
    (html / "tutorials").mkdir(parents=True)
    notebooks.mkdir()
    for stem, body in pages.items():
        (notebooks / f"{stem}.ipynb").write_text("{}")
        if body is not None:
            (html / "tutorials" / f"{stem}.html").write_text(body)
    return html, notebooks


def test_pages_with_pictures_pass(tmp_path):
    html, notebooks = _site(tmp_path, {"01_a": '<p>x</p><img src="a.png" alt="">', "02_b": "<IMG alt='' src='b.png'><img src='c.png'>"})
    counts, problems = check.tutorial_problems(html, notebooks)
    assert problems == [] and counts == {"01_a": 1, "02_b": 2}


def test_a_page_without_picture_or_missing_fails(tmp_path):
    html, notebooks = _site(tmp_path, {"01_a": "<p>only text, an imgur link</p>", "02_b": None, "03_c": "<img src='x.png'>"})
    counts, problems = check.tutorial_problems(html, notebooks)
    assert len(problems) == 2
    assert "01_a.html: no picture" in problems[0] and "02_b.html: missing" in problems[1]


def test_the_command_exits_1_on_a_site_without_tutorials(tmp_path, capsys):
    (tmp_path / "tutorials").mkdir()
    assert check.main([str(tmp_path)]) == 1
    assert "missing" in capsys.readouterr().err
