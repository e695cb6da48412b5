"""scripts/oal-pair: paired success differences across oal-bench runs on the same fields."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HEADER = (
    "floor,family,layout,seed,split,condition,success,jammed,end_s,time_to_goal_s,distance_bl,speed_bl_per_cycle,"
    "heading_change_deg,exit_heading_deg,estimate_error\n"
)


def write_run(folder, rows):
    folder.mkdir()
    lines = [
        f"anisotropic,random,random 3 /m²,{seed},{split},{c},{str(s).lower()},false,60,NaN,0,0,0,0,NaN\n"
        for seed, split, c, s in rows
    ]
    (folder / "oal_runs.csv").write_text(HEADER + "".join(lines))


def pair(*args):
    return subprocess.run([sys.executable, str(ROOT / "scripts/oal-pair"), *map(str, args)], capture_output=True, text=True)


def test_conditions_of_two_runs_pair_on_their_common_held_out_fields(tmp_path):
    # Run a: the law on fields 1000-1003 (and a tuning field, left out); run b: the baseline on 1000-1004.
    write_run(tmp_path / "a", [(0, "tuning", "law", True)] + [(1000 + i, "held_out", "law", i < 3) for i in range(4)]
              + [(1000 + i, "held_out", "open_loop", False) for i in range(4)])
    write_run(tmp_path / "b", [(1000 + i, "held_out", "base", i == 0) for i in range(5)]
              + [(1000 + i, "held_out", "open_loop", False) for i in range(5)])
    done = pair(tmp_path / "a", tmp_path / "b", "--against", "base", "--conditions", "law")
    assert done.returncode == 0, done.stderr
    row = done.stdout.strip().splitlines()[-1]
    # 4 common fields: the law succeeds on 3, the baseline on 1 (the same field): +50 points;
    # 2 discordant fields, both the law's: McNemar's exact p = 2 · (1/2)² = 0.5.
    assert row.startswith("| anisotropic | random | `law` | 4 | 75 | 25 | +50 ("), row
    assert row.endswith("| 0.5 (2 / 0) |"), row


def test_runs_that_disagree_on_a_field_and_unknown_conditions_are_refused(tmp_path):
    write_run(tmp_path / "a", [(1000, "held_out", "open_loop", True)])
    write_run(tmp_path / "b", [(1000, "held_out", "open_loop", False)])
    done = pair(tmp_path / "a", tmp_path / "b", "--against", "open_loop")
    assert done.returncode != 0 and "not the same benchmark" in done.stderr
    done = pair(tmp_path / "a", "--against", "passive")
    assert done.returncode != 0 and "no such condition" in done.stderr and "open_loop" in done.stderr
    done = pair(tmp_path / "missing", "--against", "open_loop")
    assert done.returncode != 0 and "no such file" in done.stderr


def test_tables_with_a_missing_column_or_a_bad_value_are_refused(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "oal_runs.csv").write_text("floor,family,seed,split,condition\nanisotropic,random,1000,held_out,law\n")
    done = pair(tmp_path / "a", "--against", "law")
    assert done.returncode != 0 and "no column success" in done.stderr, done.stderr
    write_run(tmp_path / "b", [(1000, "held_out", "law", "yes")])
    done = pair(tmp_path / "b", "--against", "law")
    assert done.returncode != 0 and "line 2" in done.stderr and "'yes'" in done.stderr, done.stderr
