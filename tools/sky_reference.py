#!/usr/bin/env python3
"""Reference values for prism's Hosek–Wilkie sky and sun from an
independent implementation: Mitsuba 3's `sunsky` emitter (scalar_spectral,
complex_sun = true for the limb-darkened solar radiance function), and the
sun irradiance table Mitsuba ships (sampling_data.bin).

    python3 -m venv /tmp/mv && /tmp/mv/bin/pip install -r tools/bench-requirements.txt
    /tmp/mv/bin/python tools/sky_reference.py    # writes tests/data/sky_reference.csv

Mitsuba's sky is +z up; each row gives the sun and view directions in that
frame (tests/sky.rs turns them to prism's +y up). Columns:
  kind        sky (sky_scale 1, sun_scale 0) | sun (sky_scale 0, complex sun)
              | sun_irradiance (W m^-2 nm^-1 at normal incidence, from the table)
  turbidity, albedo, sun_x, sun_y, sun_z, view_x, view_y, view_z, nm, value
"""

import csv
import math
import struct
from pathlib import Path

import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_spectral")

OUT = Path(__file__).resolve().parent.parent / "tests" / "data" / "sky_reference.csv"
# 716, not 720: Mitsuba 3.9.1 returns NaN at exactly 720 nm (it interpolates
# towards a band past the last).
WAVELENGTHS = [360, 400, 455, 500, 555, 600, 650, 700, 716]
HALF_APERTURE = math.radians(0.5 * 0.5358)


def direction(elevation_deg, azimuth_deg):
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    return [math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)]


def emitter(sun, turbidity, albedo, part):
    props = {
        "type": "sunsky",
        "sun_direction": sun,
        "turbidity": turbidity,
        "albedo": albedo,
        "complex_sun": True,
    }
    props["sun_scale" if part == "sky" else "sky_scale"] = 0.0
    return mi.load_dict(props)


def radiance(em, view):
    """Radiance arriving from `view` (towards the sky) at WAVELENGTHS."""
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(-view[0], -view[1], -view[2])
    out = []
    for i in range(0, len(WAVELENGTHS), 4):
        lams = (WAVELENGTHS[i : i + 4] + [WAVELENGTHS[-1]] * 4)[:4]
        si.wavelengths = mi.Spectrum(lams)
        value = em.eval(si)
        out += [float(value[k]) for k in range(4)][: len(WAVELENGTHS[i : i + 4])]
    return out


def sun_irradiance_table():
    """Mitsuba's precomputed sun irradiance: [turbidity 1..10][elevation
    2°, 5°, ..., 89°][band 320..720 nm]."""
    blob = (Path(mi.__file__).parent / "data" / "sunsky" / "sampling_data.bin").read_bytes()
    (count,) = struct.unpack_from("<I", blob, 14)
    at = 18
    for _ in range(count):
        (length,) = struct.unpack_from("<H", blob, at)
        name = blob[at + 2 : at + 2 + length].decode()
        at += 2 + length
        (ndim,) = struct.unpack_from("<H", blob, at)
        (offset,) = struct.unpack_from("<Q", blob, at + 3)
        shape = struct.unpack_from(f"<{ndim}Q", blob, at + 11)
        at += 11 + 8 * ndim
        if name == "sun_irradiance":
            n = shape[0] * shape[1] * shape[2]
            flat = struct.unpack_from(f"<{n}f", blob, offset)
            return [
                [list(flat[(t * shape[1] + e) * shape[2] :][: shape[2]]) for e in range(shape[1])]
                for t in range(shape[0])
            ]
    raise SystemExit("no sun_irradiance in sampling_data.bin")


def main():
    rows = []
    # The sky: turbidity/albedo pairs across the model's range, the sun
    # from the horizon to the zenith, views all over the dome.
    for turbidity, albedo in [(2.0, 0.0), (3.0, 0.3), (4.7, 0.8), (6.5, 0.5), (10.0, 1.0)]:
        for sun_elevation in [1.0, 5.0, 15.0, 30.0, 50.0, 75.0, 89.0]:
            sun = direction(sun_elevation, 0.0)
            em = emitter(sun, turbidity, albedo, "sky")
            views = [(0.5, 0.0), (2.0, 180.0), (10.0, 45.0), (30.0, 90.0), (45.0, 10.0),
                     (60.0, 170.0), (89.0, 0.0), (min(sun_elevation + 3.0, 89.5), 0.0)]
            for v_el, v_az in views:
                view = direction(v_el, v_az)
                for nm, value in zip(WAVELENGTHS, radiance(em, view)):
                    rows.append(["sky", turbidity, albedo, *sun, *view, nm, value])
    # The sun: the limb-darkened disc at its centre, halfway and near the
    # rim, across and along the vertical, low and high.
    for turbidity in [2.0, 3.0, 6.3, 10.0]:
        for sun_elevation in [1.0, 3.0, 10.0, 30.0, 60.0, 85.0]:
            sun = direction(sun_elevation, 0.0)
            em = emitter(sun, turbidity, 0.3, "sun")
            up = [-math.sin(math.radians(sun_elevation)), 0.0, math.cos(math.radians(sun_elevation))]
            side = [0.0, 1.0, 0.0]
            for fraction, axis in [(0.0, side), (0.5, side), (0.9, side), (0.9, up), (-0.7, up)]:
                g = fraction * HALF_APERTURE
                view = [math.cos(g) * s + math.sin(g) * a for s, a in zip(sun, axis)]
                for nm, value in zip(WAVELENGTHS, radiance(em, view)):
                    rows.append(["sun", turbidity, 0.3, *sun, *view, nm, value])
    # Mitsuba's sun irradiance table at a few of its elevations and levels.
    table = sun_irradiance_table()
    for level in [1, 3, 10]:
        for k in [0, 2, 9, 19, 29]:
            sun = direction(2.0 + 3.0 * k, 0.0)
            for band in range(1, 11):
                nm = 320 + 40 * band
                rows.append(["sun_irradiance", float(level), 0.3, *sun, *sun, nm,
                             table[level - 1][k][band]])
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with open(OUT, "w", newline="") as f:
        f.write(f"# Hosek–Wilkie sky and sun from Mitsuba {mi.__version__} sunsky (scalar_spectral),\n")
        f.write("# written by tools/sky_reference.py; +z up. See that script for the columns.\n")
        w = csv.writer(f)
        w.writerow(["kind", "turbidity", "albedo", "sun_x", "sun_y", "sun_z",
                    "view_x", "view_y", "view_z", "nm", "value"])
        for r in rows:
            w.writerow([r[0]] + [f"{v:.9g}" for v in r[1:]])
    print(f"wrote {OUT}: {len(rows)} rows")


if __name__ == "__main__":
    main()
