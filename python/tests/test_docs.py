"""The Python blocks of README.md and docs/ marked `<!-- runnable -->` run as
written: a page's blocks in order, in one namespace, from a folder that has
the repository's scenes/ and spectra/ (and an out/ of its own)."""

import os
import re

import pytest

from conftest import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def runnable_python(page):
    text = page.read_text()
    return re.findall(r"<!-- runnable -->\n```python\n(.*?)\n```", text, flags=re.S)


@pytest.mark.parametrize("page", [p for p in PAGES if runnable_python(p)], ids=lambda p: p.name)
def test_the_pages_python_runs_as_written(page, tmp_path, monkeypatch):
    for name in ("scenes", "spectra"):
        os.symlink(ROOT / name, tmp_path / name)
    (tmp_path / "out").mkdir()
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for block in runnable_python(page):
        exec(compile(block, f"{page.name} block", "exec"), namespace)


def test_readme_and_the_guide_have_runnable_python():
    assert runnable_python(ROOT / "README.md")
    assert len(runnable_python(ROOT / "docs" / "python.md")) >= 3
