"""docs/settings.md is generated from the episode config and up to date: every key, each with a
default, what the validation allows and a meaning."""

from __future__ import annotations

import dataclasses

from sim import config as episode_config
from sim.experiments import settings_doc


def test_the_committed_settings_reference_is_the_generated_one():
    committed = settings_doc.OUT.read_text(encoding="utf-8")
    assert committed == settings_doc.markdown(), (
        f"docs/settings.md is out of date: run {settings_doc.REGENERATE}"
    )


def test_every_key_of_the_config_is_listed_with_its_range_and_meaning():
    rows = [s for _, part in settings_doc.settings() for s in part]
    keys = {s.key for s in rows}
    assert set(episode_config.SCALARS) <= keys
    for name, cls in episode_config.SECTIONS.items():
        if name != "values":
            assert {f"{name}.{f.name}" for f in dataclasses.fields(cls)} <= keys
    for s in rows:
        assert s.default and s.meaning, s
        assert s.allowed != "-", s  # the validation refused a probe value of every key
    by_key = {s.key: s for s in rows}
    assert by_key["duration_s"].allowed == "1..36000 s" and by_key["duration_s"].unit == "s"
    assert by_key["video.width"].default == "640" and by_key["video.width"].unit == "px"
    assert by_key["cup.vacuum_pa"].unit == "Pa"


def test_the_check_mode_says_when_the_file_is_stale(tmp_path, capsys):
    stale = tmp_path / "settings.md"
    stale.write_text("# old\n")
    assert settings_doc.main(["--check", "--out", str(stale)]) == 1
    assert settings_doc.REGENERATE in capsys.readouterr().err
    assert settings_doc.main(["--out", str(stale)]) == 0
    assert settings_doc.main(["--check", "--out", str(stale)]) == 0
