"""The busy-belt camera tables: purity per bin and seed, ratios against truth, from sweep CSVs."""

from __future__ import annotations

import csv

from sim.results.camera_busy_tables import line_table, main, one_robot_table, pooled_purity

EPISODE_KEYS = ("variant", "seed", "n_items", "items_per_m", "entered", "never_detected",
                "never_visible", "picked", "profit_eur", "wrong_bin", "empty_picks",
                "left_unsure", "thrown_off")  # fmt: skip
PICK_KEYS = ("variant", "seed", "n_items", "bin", "true_class", "success")


def _episode(variant, seed, picked, profit, wrong=0, never=0, unsure=0):
    values = (variant, seed, "100", "6.0", "100", never, 0, picked, profit, wrong, 1, unsure, 0)
    return dict(zip(EPISODE_KEYS, map(str, values), strict=True))


def _picks(variant, seed, rights, wrongs):
    """`rights` picks in their own bins (paper), `wrongs` plastic items in the paper bin."""
    rows = [(variant, seed, "100", "paper", "paper", "1")] * rights
    rows += [(variant, seed, "100", "paper", "plastic", "1")] * wrongs
    rows += [(variant, seed, "100", "aluminium", "aluminium", "0")]  # dropped: not in a bin
    return [dict(zip(PICK_KEYS, r, strict=True)) for r in rows]


EPISODES = [
    _episode("truth", 1, 100, 25.0),
    _episode("camera", 1, 98, 24.0, wrong=2, never=1, unsure=3),
    _episode("truth", 2, 100, 20.0),
    _episode("camera", 2, 99, 19.0, wrong=1),
]
PICKS = _picks("camera", "1", 48, 2) + _picks("camera", "2", 39, 1) + _picks("truth", "1", 50, 0)


def test_purity_counts_what_each_bin_holds():
    assert pooled_purity(PICKS, variant="camera") == {
        "paper": (87, 90), "plastic": (0, 0), "aluminium": (0, 0)
    }  # fmt: skip
    assert pooled_purity(PICKS, variant="camera", seed="1")["paper"] == (48, 50)


def test_one_robot_rows_and_their_sum():
    table = one_robot_table(EPISODES, PICKS, "100").splitlines()
    assert len(table) == 2 + 2 + 1
    assert table[2].startswith("| 1 | 6.0 | 1 | 0 | 98 (100) | 24.00 (25.00) | 0.960 | 2 | 1 | 3 |")
    assert "0.960 / - / -" in table[2] and "0.975 / - / -" in table[3]
    total = table[4]
    assert "1 of 200 (0.5 %)" in total and "197 (200)" in total
    assert f"| {43 / 45:.3f} | 3 | 2 | 3 |" in total  # profit over truth's, wrong, empty, unsure
    assert "0.967 / - / - pooled; lowest seed 0.960 / - / -" in total


def test_line_rows_per_perception():
    episodes = [dict(e, variant="one camera") if e["variant"] == "camera" else e for e in EPISODES]
    picks = [dict(p, variant="one camera") if p["variant"] == "camera" else p for p in PICKS]
    rows = line_table(episodes, picks).splitlines()[2:]
    assert [r.split(" | ")[0] for r in rows] == ["| truth", "| one camera"]
    assert rows[1].startswith("| one camera | 98.5 (0.985) | 21.50 (0.956) | 0.980 / 0.950 |")


def test_main_prints_both_and_refuses_a_folder_without_a_sweep(tmp_path, capsys):
    for name, rows, keys in (("episodes.csv", EPISODES, EPISODE_KEYS), ("picks.csv", PICKS,
                                                                         PICK_KEYS)):  # fmt: skip
        for folder in ("one", "line"):
            (tmp_path / folder).mkdir(exist_ok=True)
            with open(tmp_path / folder / name, "w", newline="") as f:
                writer = csv.DictWriter(f, keys)
                writer.writeheader()
                writer.writerows(rows)
    assert main([str(tmp_path / "one"), str(tmp_path / "line")]) == 0
    out = capsys.readouterr().out
    assert "One robot, 100 items in 90 s, camera" in out and "A line" in out
    assert main([str(tmp_path / "one"), str(tmp_path / "none")]) == 2
    assert "episodes.csv" in capsys.readouterr().err
