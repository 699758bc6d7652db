#!/usr/bin/env python3
"""Compares two GOLDEN_DUMP folders of tests/golden.rs: for every array, the
largest change relative to the array's largest value and the number of
entries that differ at all. Usage: golden_diff.py OLD_DIR NEW_DIR"""
import array, os, sys

old, new = sys.argv[1], sys.argv[2]
for name in sorted(os.listdir(old)):
    a, b = array.array('f'), array.array('f')
    a.frombytes(open(os.path.join(old, name), 'rb').read())
    b.frombytes(open(os.path.join(new, name), 'rb').read())
    if len(a) != len(b):
        print(f"{name}: {len(a)} vs {len(b)} values")
        continue
    scale = max((abs(x) for x in a), default=0.0) or 1.0
    diff = [abs(x - y) for x, y in zip(a, b)]
    changed = sum(1 for d in diff if d != 0.0)
    mean_a = sum(a) / max(len(a), 1)
    mean_b = sum(b) / max(len(b), 1)
    print(f"{name:32s} changed {changed:6d}/{len(a):6d}  max |diff| / max {max(diff, default=0.0) / scale:.2e}  "
          f"mean {mean_a:.6g} -> {mean_b:.6g}")
