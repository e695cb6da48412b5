"""Compares the tables (*.csv) of two run folders of the same config: byte for byte, and where
they differ, value by value (the largest absolute difference, relative to the column's largest
magnitude, and the first time it appears). Exits 1 when the tables differ in names, columns or
row counts; value differences are reported, not judged (scripts/test-windows: Linux against
Windows under Wine)."""

import csv
import math
import sys
from pathlib import Path


def rows(path):
    with open(path, newline="") as f:
        reader = csv.reader(f)
        return next(reader), [r for r in reader if r]


def main(a_dir, b_dir):
    a_dir, b_dir = Path(a_dir), Path(b_dir)
    names = sorted(p.name for p in a_dir.glob("*.csv"))
    if names != sorted(p.name for p in b_dir.glob("*.csv")):
        print(f"different tables: {names} and {sorted(p.name for p in b_dir.glob('*.csv'))}")
        return 1
    status = 0
    for name in names:
        a, b = a_dir / name, b_dir / name
        if a.read_bytes() == b.read_bytes():
            print(f"{name:14} identical ({a.stat().st_size} bytes)")
            continue
        (head_a, ra), (head_b, rb) = rows(a), rows(b)
        if head_a != head_b or len(ra) != len(rb):
            print(f"{name:14} different columns or row counts ({len(ra)} and {len(rb)} rows)")
            status = 1
            continue
        scale = [0.0] * len(head_a)
        worst = (0.0, 0.0, "", "")  # relative, absolute, column, time
        first = None
        n_diff = n_values = 0
        for ra_row, rb_row in zip(ra, rb):
            for j, (x, y) in enumerate(zip(ra_row, rb_row)):
                n_values += 1
                try:
                    fx, fy = float(x), float(y)
                except ValueError:
                    fx = fy = math.nan
                if not math.isnan(fx):
                    scale[j] = max(scale[j], abs(fx))
                if x == y:
                    continue
                n_diff += 1
                if first is None:
                    first = ra_row[0]
                if math.isnan(fx) or math.isnan(fy):
                    print(f"{name:14} text differs in column {head_a[j]}: {x!r} and {y!r}")
                    status = 1
                    continue
                absolute = abs(fx - fy)
                if absolute > worst[1]:
                    worst = (0.0, absolute, head_a[j], ra_row[0])
        if worst[2]:
            j = head_a.index(worst[2])
            relative = worst[1] / scale[j] if scale[j] > 0 else math.inf
            print(
                f"{name:14} {n_diff} of {n_values} values differ, first at {head_a[0]} = {first}; largest: "
                f"{worst[1]:.3g} in {worst[2]} at {head_a[0]} = {worst[3]} ({relative:.3g} of that column's largest magnitude)"
            )
    return status


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
