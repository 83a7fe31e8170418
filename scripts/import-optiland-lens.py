#!/usr/bin/env python3
"""Writes camsim lens files (TOML, see camsim/src/lens.rs) for published designs that
`optiland` (PyPI, MIT) carries as sample lenses, with the design's source named.

Usage: python scripts/import-optiland-lens.py OUT_DIR   (with optiland importable)

Only the prescription is taken (radii, thicknesses, glasses, the stop): figures of a published
design. Clear semi-diameters are not part of these prescriptions; they are set here from real
rays traced by optiland over the design's field and its F, d and C wavelengths: the stop's is
the paraxial marginal ray's height at the primary wavelength (so the entrance pupil is the
design's), every other
surface's the largest ray height on it plus 2 %, rounded up to 0.01 mm.
"""

import json
import math
import pathlib
import sys
import warnings

import numpy as np

warnings.filterwarnings("ignore")

from optiland.samples import objectives  # noqa: E402

def in_mm(cls):
    """A sample whose figures are Laikin's inches, scaled to millimetres."""

    def make():
        lens = cls()
        lens.updater.scale_system(25.4)
        return lens

    return make


LENSES = [
    (
        "tessar-f4.5.toml",
        in_mm(objectives.TessarLens),
        "Tessar f/4.5",
        "Milton Laikin, Lens Design, 4th ed., CRC Press, 2007, p. 63 (as optiland 0.6.3's samples.objectives.TessarLens, scaled from inches to mm)",
    ),
    (
        "telephoto-f5.6.toml",
        objectives.Telephoto,
        "Telephoto f/5.6",
        "Milton Laikin, Lens Design, 4th ed., CRC Press, 2007, p. 91 (as optiland 0.6.3's samples.objectives.Telephoto, scaled from inches to mm)",
    ),
    (
        "wide-angle-100deg-f4.toml",
        in_mm(objectives.WideAngle100FOV),
        "Wide angle, 100 degree field, f/4",
        "Milton Laikin, Lens Design, 4th ed., CRC Press, 2007, p. 108 (as optiland 0.6.3's samples.objectives.WideAngle100FOV, scaled from inches to mm)",
    ),
]


def semi_diameters(lens) -> list[float]:
    sg = lens.surface_group
    n = len(sg.surfaces)
    most = np.zeros(n)
    max_field = max(abs(f.y) for f in lens.fields.fields)
    for hy in (0.0, 0.5, 1.0) if max_field > 0 else (0.0,):
        for wl in (0.4861327, 0.5875618, 0.6562725):
            lens.trace(Hx=0.0, Hy=hy, wavelength=wl, num_rays=24, distribution="hexapolar")
            r = np.hypot(np.asarray(sg.x), np.asarray(sg.y))
            most = np.maximum(most, np.nanmax(r, axis=1))
    out = [math.ceil(v * 1.02 * 100.0) / 100.0 for v in most]
    y, _ = lens.paraxial.marginal_ray()
    stop = sg.stop_index
    out[stop] = abs(float(np.ravel(y)[stop]))
    return out


def write(path: pathlib.Path, lens, name: str, source: str) -> None:
    sg = lens.surface_group
    sd = semi_diameters(lens)
    lines = [
        "# camsim lens file (version 1); written by scripts/import-optiland-lens.py",
        "version = 1",
        f"name = {json.dumps(name)}",
        f"source = {json.dumps(source)}",
        f"field_deg = {max(abs(f.y) for f in lens.fields.fields)!r}",
        "",
    ]
    surfaces = sg.surfaces[1:-1]  # the object and image surfaces are not surfaces of the lens
    for i, s in enumerate(surfaces, start=1):
        radius = float(s.geometry.radius)
        k = float(getattr(s.geometry, "k", 0.0) or 0.0)
        if k != 0.0:
            raise SystemExit(f"{name}: surface {i} is a conic; extend the importer")
        lines.append("[[surface]]")
        lines.append(f"radius = {radius!r}" if math.isfinite(radius) else 'radius = "inf"')
        lines.append(f"thickness = {float(s.thickness)!r}")
        lines.append(f"semi_diameter = {sd[i]!r}")
        glass = getattr(s.material_post, "name", None)
        if glass:
            lines.append(f'glass = "{glass}"')
        if s.is_stop:
            lines.append("stop = true")
        lines.append("")
    path.write_text("\n".join(lines))
    print(f"wrote {path}")


def main() -> None:
    out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "camsim/lenses")
    out.mkdir(parents=True, exist_ok=True)
    for file, cls, name, source in LENSES:
        write(out / file, cls(), name, source)


if __name__ == "__main__":
    main()
