#!/usr/bin/env python3
"""Read a UFF file with pyuff and dump every dataset as JSON.

Usage: uff_pyuff_read.py FILE.uff OUT.json

OUT.json is a list with one object per dataset: pyuff's fields (id1..id5,
func_type, func_id, ver_num, rsp_node, ..., ordinate_axis_units_lab,
z_axis_value) and, for dataset 58, "x", "re" and "im" as exact floats.
Exits 2 when pyuff or numpy is missing, 1 when pyuff cannot read the file.
"""

import json
import sys

try:
    import numpy as np
    import pyuff
except ImportError as e:  # pragma: no cover
    print(f"SKIPPED: pyuff not installed ({e})")
    sys.exit(2)


def floats(a):
    return [float(v) for v in np.asarray(a).ravel()]


def main():
    path, out = sys.argv[1], sys.argv[2]
    try:
        sets = pyuff.UFF(path).read_sets()
    except Exception as e:
        print(f"pyuff cannot read {path}: {e}")
        sys.exit(1)
    if isinstance(sets, dict):
        sets = [sets]
    dump = []
    for d in sets:
        o = {}
        for k, v in d.items():
            if k in ("x", "data"):
                continue
            if isinstance(v, np.integer):
                v = int(v)
            elif isinstance(v, np.floating):
                v = float(v)
            o[k] = v
        if d.get("type") == 58:
            y = np.asarray(d["data"])
            o["x"] = floats(d["x"])
            o["re"] = floats(np.real(y))
            o["im"] = floats(np.imag(y)) if np.iscomplexobj(y) else []
        dump.append(o)
    with open(out, "w") as f:
        json.dump(dump, f)
    print("OK")


if __name__ == "__main__":
    main()
