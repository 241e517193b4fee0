"""README.md indexes every document in docs/, and every document it names exists."""

from __future__ import annotations

import re

from sim.paths import REPO_ROOT


def test_the_readme_names_every_document_in_docs():
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    index = readme.split("## Documentation", 1)[1].split("\n## ", 1)[0]
    named = set(re.findall(r"`docs/([\w.-]+\.md)`", index))
    present = {p.name for p in (REPO_ROOT / "docs").glob("*.md")}
    assert present - named == set(), "README's Documentation list misses these"
    assert named - present == set(), "README's Documentation list names missing files"


def test_the_pictures_the_readme_shows_exist():
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    for path in re.findall(r"\]\((docs/[\w./-]+\.png)\)", readme):
        assert (REPO_ROOT / path).is_file(), path
