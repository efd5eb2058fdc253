#!/usr/bin/env python3
"""Write UFF 58 time records with pyuff, the reference Python implementation.

Usage: uff_pyuff_write.py OUT_DIR

Writes into OUT_DIR:
  ascii_double.uff   dataset 151 (header), 164 (units), then force [N],
                     acceleration [g], velocity [mm/s], displacement [um]:
                     ASCII, double precision (4E20.12 as pyuff prints it),
                     even abscissa
  ascii_single.uff   force and acceleration, ASCII single precision (6E13.5)
  binary_double.uff  force and acceleration, 58b double (pyuff writes the
                     machine's byte order)
  ascii_uneven.uff   force and acceleration with an uneven abscissa (pyuff's
                     default: the time stored beside each value)
  binary_single.uff  force, 58b with ordinate data type 2 (single)
and expect.json: for each file, what pyuff reads back from it (every
dataset's fields, abscissa and ordinate as exact floats) and the arrays that
were written ("written"). The test compares hystid's reading of the same
files with both.

Exits 2 when pyuff or numpy is missing.
"""

import json
import os
import sys

try:
    import numpy as np
    import pyuff
except ImportError as e:  # pragma: no cover
    print(f"SKIPPED: pyuff not installed ({e})")
    sys.exit(2)

FS = 2048.0
N = 1000


def signals():
    t = np.arange(N) / FS
    w = 2 * np.pi * 37.0
    force = 12.5 * np.sin(w * t) + 0.8 * np.sin(3 * w * t + 0.3) - 0.01
    acc = 0.31 * np.sin(w * t + 1.1) + 4e-3 * np.cos(2 * w * t)
    vel = 1.7e3 * np.cos(w * t + 0.4) * np.exp(-t)
    disp = -2.5e-2 * np.sin(w * t - 0.7) + 1e-9 * t
    return t, {"force": force, "acc": acc, "vel": vel, "disp": disp}


def dataset(t, y, name, data_type, units, node, direction, binary=0, even=1, precision=4):
    return {
        "type": 58,
        "binary": binary,
        "id1": name,
        "id2": "pyuff interop",
        "id3": "01-Jan-26 00:00:00",
        "id4": "NONE",
        "id5": "NONE",
        "func_type": 1,
        "func_id": node * 10 + abs(direction),
        "ver_num": 0,
        "load_case_id": 0,
        "rsp_ent_name": name[:10],
        "rsp_node": node,
        "rsp_dir": direction,
        "ref_ent_name": "NONE",
        "ref_node": 0,
        "ref_dir": 0,
        "ord_data_type": precision,
        "abscissa_spacing": even,
        "abscissa_spec_data_type": 17,
        "abscissa_axis_lab": "Time",
        "abscissa_axis_units_lab": "s",
        "ordinate_spec_data_type": data_type,
        "ordinate_axis_lab": name,
        "ordinate_axis_units_lab": units,
        "orddenom_spec_data_type": 0,
        "z_axis_spec_data_type": 0,
        "x": t,
        "data": y,
    }


def header_151():
    return {
        "type": 151,
        "model_name": "hystid interop",
        "description": "written by pyuff",
        "db_app": "pyuff",
        "date_db_created": "01-Jan-26",
        "time_db_created": "00:00:00",
        "version_db1": 0,
        "version_db2": 0,
        "file_type": 0,
        "date_db_saved": "01-Jan-26",
        "time_db_saved": "00:00:00",
        "program": "pyuff",
        "date_db_written": "01-Jan-26",
        "time_db_written": "00:00:00",
    }


def units_164():
    return {
        "type": 164,
        "units_code": 1,
        "units_description": "SI units",
        "temp_mode": 2,
        "length": 1.0,
        "force": 1.0,
        "temp": 1.0,
        "temp_offset": 273.15,
    }


def floats(a):
    return [float(v) for v in np.asarray(a).ravel()]


def described(dset):
    out = {}
    for k, v in dset.items():
        if k in ("x", "data"):
            continue
        if isinstance(v, (np.integer,)):
            v = int(v)
        elif isinstance(v, (np.floating,)):
            v = float(v)
        out[k] = v
    if dset.get("type") == 58:
        x = np.asarray(dset["x"])
        y = np.asarray(dset["data"])
        out["x"] = floats(x)
        if np.iscomplexobj(y):
            out["re"] = floats(y.real)
            out["im"] = floats(y.imag)
        else:
            out["re"] = floats(y)
    return out


def write(path, dsets, force_double=True):
    if os.path.exists(path):
        os.remove(path)
    # mode "add" on a new file: pyuff's binary writer reopens the file
    u = pyuff.UFF(path)
    u.write_sets(dsets, mode="add", force_double=force_double)


def main():
    out = sys.argv[1]
    t, s = signals()
    files = {
        "ascii_double.uff": (
            [
                header_151(),
                units_164(),
                dataset(t, s["force"], "Force", 13, "N", 1, 3),
                dataset(t, s["acc"], "Acc", 12, "g", 2, -1),
                dataset(t, s["vel"], "Vel", 11, "mm/s", 3, 2),
                dataset(t, s["disp"], "Disp", 8, "um", 4, 3),
            ],
            True,
        ),
        "ascii_single.uff": (
            [
                dataset(t, s["force"], "Force", 13, "N", 1, 3, precision=2),
                dataset(t, s["acc"], "Acc", 12, "m/s2", 2, 3, precision=2),
            ],
            False,
        ),
        "binary_double.uff": (
            [
                dataset(t, s["force"], "Force", 13, "N", 1, 3, binary=1),
                dataset(t, s["acc"], "Acc", 12, "m/s2", 2, 3, binary=1),
            ],
            True,
        ),
        "ascii_uneven.uff": (
            [
                dataset(t, s["force"], "Force", 13, "N", 1, 3, even=0),
                dataset(t, s["acc"], "Acc", 12, "m/s2", 2, 3, even=0),
            ],
            True,
        ),
        "binary_single.uff": (
            [dataset(t, s["force"], "Force", 13, "N", 1, 3, binary=1, precision=2)],
            False,
        ),
    }
    expect = {
        "pyuff": pyuff.__version__,
        "sample_rate_hz": FS,
        "written": {
            "t": floats(t),
            **{k: floats(v) for k, v in s.items()},
        },
        "files": {},
    }
    for name, (dsets, force_double) in files.items():
        path = os.path.join(out, name)
        write(path, dsets, force_double)
        try:
            back = pyuff.UFF(path).read_sets()
            if isinstance(back, dict):
                back = [back]
            read = [described(d) for d in back]
            ok = all(
                len(d.get("re", [])) == N for d in read if d.get("type") == 58
            )
            # what pyuff reads from a file it cannot read back is not kept
            expect["files"][name] = {"read": read if ok else [], "pyuff_reads_it": ok}
        except Exception as e:  # pyuff cannot read its own file
            expect["files"][name] = {"read": [], "pyuff_reads_it": False, "error": str(e)}
    with open(os.path.join(out, "expect.json"), "w") as f:
        json.dump(expect, f)
    print("OK")


if __name__ == "__main__":
    main()
