"""Make the trimmed copy of NHTSA test 10146 in this folder from the full export.

    python data/nhtsa-10146/trim.py /path/to/nhtsa-10146     # the folder holding v10146.EV5

Writes (see README.md): the header trimmed to the channels kept plus one row (curve 900)
for the summed barrier force, the vehicle accelerometer files 093, 094, 095, 096, 099, 100
verbatim, ``v10146.900`` (sum of every valid barrier Fx load cell), and ``cells/`` (a
header with five raw Fx cells and the two invalid ones, and the five cells' files).
"""

import shutil
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
VEHICLE_CURVES = (93, 94, 95, 96, 99, 100)
RAW_CELLS = (131, 260, 263, 275, 287)
SUM_CURVE = 900


def main(src: Path) -> None:
    lines = (src / "v10146.EV5").read_text(encoding="latin-1").splitlines()
    k = lines.index("----- INSTRUMENTATION -----")
    head, rows = lines[: k + 1], [r for r in lines[k + 1:] if "|" in r]
    by_curve = {int(r.split("|")[1]): r for r in rows}
    cells = [r for r in rows if r.split("|")[0] == "0" and r.split("|")[7] == "NWT"]
    valid = [r for r in cells if r.split("|")[17] == "AM"]
    invalid = [r for r in cells if r.split("|")[17] != "AM"]

    total = None
    for r in valid:
        data = np.loadtxt(src / f"v10146.{int(r.split('|')[1]):03d}")
        if total is None:
            t, total = data[:, 0], np.zeros(len(data))
        assert np.allclose(data[:, 0], t)
        total += data[:, 1]
    with open(HERE / f"v10146.{SUM_CURVE}", "w") as f:
        for ti, fi in zip(t, total):
            f.write(f"{ti:.6f}\t{fi:.3f}\n")
    sum_row = (f"0|{SUM_CURVE}|LC|NA|LCSUM|XG|SEC|NWT|2800|SUM OF {len(valid)} VALID BARRIER Fx "
               f"LOAD CELLS (see README.md)|03/OCT/2017|300000|0|0.0|-500|2999|100|AM|P|"
               f"BARRIER SUM OF {len(valid)} Fx CELLS")
    out = head + [by_curve[c] for c in VEHICLE_CURVES] + [sum_row, "----- END -----"]
    (HERE / "v10146.EV5").write_text("\n".join(out) + "\n", encoding="latin-1")
    for c in VEHICLE_CURVES:
        shutil.copy(src / f"v10146.{c:03d}", HERE / f"v10146.{c:03d}")

    (HERE / "cells").mkdir(exist_ok=True)
    out = head + [by_curve[c] for c in RAW_CELLS] + invalid + ["----- END -----"]
    (HERE / "cells" / "v10146.EV5").write_text("\n".join(out) + "\n", encoding="latin-1")
    for c in RAW_CELLS:
        shutil.copy(src / f"v10146.{c:03d}", HERE / "cells" / f"v10146.{c:03d}")
    print(f"summed {len(valid)} valid cells, skipped {len(invalid)} invalid ones")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
