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


def test_hostile_tables_are_refused_with_file_line_and_value(tmp_path):
    """A seed that is no ASCII number, one of 5,000 digits, a field over 128 KiB, binary bytes, a
    NUL byte, a short row: exit code 2, the file, the line and the value (cut), no traceback."""
    row = "anisotropic,random,x,{seed},held_out,law,true,false,60,NaN,0,0,0,0,NaN\n"
    cases = {
        "superscript": (HEADER + row.format(seed="²")).encode(),
        "digits": (HEADER + row.format(seed="9" * 5000)).encode(),
        "huge_field": (HEADER + row.format(seed=1).replace(",x,", "," + "x" * 200_000 + ",")).encode(),
        "binary": (HEADER + row.format(seed=1)).encode() + bytes(range(256)) * 50,
        "nul": (HEADER + row.format(seed=1) + "\0\n").encode(),
        "short_row": (HEADER + "anisotropic,random,x,1\n").encode(),
        "over_u64": (HEADER + row.format(seed=2**64)).encode(),
    }
    for name, data in cases.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "oal_runs.csv").write_bytes(data)
        done = pair(tmp_path / name, "--against", "law")
        assert done.returncode == 2, (name, done.returncode, done.stderr[-500:])
        assert "Traceback" not in done.stderr, (name, done.stderr[-2000:])
        assert str(tmp_path / name / "oal_runs.csv") in done.stderr and "line " in done.stderr, (name, done.stderr)
        assert len(done.stderr) < 1000, (name, len(done.stderr))
    assert "'²'" in pair(tmp_path / "superscript", "--against", "law").stderr
    assert "(5000 characters)" in pair(tmp_path / "digits", "--against", "law").stderr


def test_100000_paired_fields_give_the_exact_mean_and_an_interval_around_it(tmp_path):
    """100,000 held-out fields (a 12 MB table): the mean paired difference is the exact one, and
    its interval lies around it within the bootstrap's spread (about 0.2 points here)."""
    rows = [HEADER]
    for i in range(100_000):
        rows.append(f"anisotropic,random,x,{1000 + i},held_out,law,{str(i % 10 < 3).lower()},false,60,NaN,0,0,0,0,NaN\n")
        rows.append(f"anisotropic,random,x,{1000 + i},held_out,base,{str(i % 10 == 0).lower()},false,60,NaN,0,0,0,0,NaN\n")
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "oal_runs.csv").write_text("".join(rows))
    done = pair(tmp_path / "a", "--against", "base")
    assert done.returncode == 0, done.stderr
    # law succeeds on i % 10 in {0, 1, 2}, the base on i % 10 == 0: +20 points exactly.
    # 20,000 discordant fields, all the law's: McNemar's p is 2 · 2^-20000, 0 in floating point.
    assert done.stdout.strip().splitlines()[-1] == "| anisotropic | random | `law` | 100000 | 30 | 10 | +20 (+20 – +20) | 0 (20000 / 0) |"
