#!/usr/bin/env python3
"""Writes camsim lens files (TOML, see host-tracer/src/lens_file.rs) for published designs,
with each design's source named: those `optiland` (PyPI, MIT) carries as sample lenses, and
three whose prescriptions are typed in below from the files `ray-optics` (PyPI `rayoptics`
0.9.8, BSD-3) ships (a Cooke triplet from Sasian's textbook, a double Gauss, and Thorlabs'
published Zemax file of an aspheric condenser), built in optiland to size their apertures.

Usage: python scripts/import-optiland-lens.py OUT_DIR [FILE...]  (with optiland importable;
FILE names pick some of the lenses)

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

from optiland import optic  # noqa: E402
from optiland.samples import objectives  # noqa: E402

def in_mm(cls):
    """A sample whose figures are Laikin's inches, scaled to millimetres."""

    def make():
        lens = cls()
        lens.updater.scale_system(25.4)
        return lens

    return make


def typed_in(epd: float, field_deg: float, surfaces: list[dict]):
    """An optiland lens from a prescription typed in: object at infinity, the entrance pupil
    diameter `epd`, fields 0 and `field_deg`, the F, d and C lines. Each surface: radius (or
    inf), thickness, glass (a SCHOTT name) or nd + vd (an Abbe-number model), stop, conic,
    aspheric (A4, A6, ... as camsim takes them)."""

    def make():
        from optiland.materials import AbbeMaterial

        o = optic.Optic()
        o.surfaces.add(index=0, radius=np.inf, thickness=np.inf)
        for i, sf in enumerate(surfaces, start=1):
            kw = dict(index=i, radius=sf.get("radius", np.inf), thickness=sf["thickness"])
            if "glass" in sf:
                kw["material"] = (sf["glass"], "schott")
            elif "nd" in sf:
                kw["material"] = AbbeMaterial(n=sf["nd"], abbe=sf["vd"])
            if sf.get("stop"):
                kw["is_stop"] = True
            if "aspheric" in sf or "conic" in sf:
                kw["surface_type"] = "even_asphere"
                kw["conic"] = sf.get("conic", 0.0)
                kw["coefficients"] = [0.0] + list(sf.get("aspheric", []))
            o.surfaces.add(**kw)
        o.surfaces.add(index=len(surfaces) + 1)
        o.set_aperture(aperture_type="EPD", value=epd)
        o.fields.set_type(field_type="angle")
        o.fields.add(y=0.0)
        o.fields.add(y=field_deg)
        for wl in (0.4861327, 0.5875618, 0.6562725):
            o.wavelengths.add(value=wl, is_primary=wl == 0.5875618)
        o.typed_in = surfaces
        return o

    return make


# Jose Sasian's Cooke triplet, as ray-optics' models/Sasian Triplet.roa holds it: curvatures
# (1/mm), gaps (mm), SCHOTT glasses, the stop on the second element's front; EPD 12.5 mm,
# half field 20 degrees.
SASIAN_TRIPLET = typed_in(12.5, 20.0, [
    dict(radius=1 / 0.042170961076202926, thickness=4.831, glass="N-LAK9"),
    dict(radius=1 / 0.00013640168003221264, thickness=5.86),
    dict(radius=1 / -0.04088976120379457, thickness=0.975, glass="N-SF5", stop=True),
    dict(radius=1 / 0.04567044208987943, thickness=4.822),
    dict(radius=1 / 0.011526181721781025, thickness=3.127, glass="N-LAK9"),
    dict(radius=1 / -0.04879429301948844, thickness=41.2365),
])

# "Double Gauss F/2 - Available Glasses", the CODE V sequence file ray-optics ships as
# codev/tests/ag_dblgauss.seq (curvatures, gaps, SCHOTT glasses, the stop on the flat after
# the front group); EPD 50 mm, half field 14 degrees.
DOUBLE_GAUSS = typed_in(50.0, 14.0, [
    dict(radius=1 / 0.01779284094091543, thickness=8.75, glass="N-SSK2"),
    dict(radius=1 / 0.006566600536925569, thickness=0.5),
    dict(radius=1 / 0.02653743294670983, thickness=12.5, glass="N-SK2"),
    dict(thickness=3.8, glass="F5"),
    dict(radius=1 / 0.04126892878570084, thickness=16.36944492653564),
    dict(thickness=13.74795696388906, stop=True),
    dict(radius=1 / -0.03523942654429074, thickness=3.8, glass="F5"),
    dict(thickness=11.0, glass="N-SK16"),
    dict(radius=1 / -0.02636750828657709, thickness=0.5),
    dict(radius=1 / 0.005636604951748545, thickness=7.0, glass="N-SK16"),
    dict(radius=1 / -0.0125926458590576, thickness=61.4875364179821),
])

# Thorlabs ACL3026U, an aspheric condenser (f = 26.5 mm, 30 mm across), from the Zemax file
# Thorlabs publishes (ray-optics ships it as elem/tests/ACL3026U-Zemax(ZMX).zmx): the stop on
# the aspheric face (curvature 0.073794747 1/mm, conic -0.6301, A4 5.513e-6), 11.9 mm of
# B 270 glass, a flat back. B 270 as a model glass: nd 1.5230, nF 1.5292, nC 1.5203 from
# SCHOTT's B 270 datasheet (1993) as refractiveindex.info tabulates it, so Vd 58.8. Half
# field 5 degrees (a condenser, not a camera lens: the aspheric singlet of the set).
ASPHERIC_SINGLET = typed_in(27.0, 5.0, [
    dict(radius=1 / 0.073794747289887913, thickness=11.9, nd=1.5230, vd=58.8, stop=True,
         conic=-0.6301, aspheric=[5.513e-6]),
    dict(thickness=18.09209481007),
])


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
    (
        "cooke-triplet-f4.toml",
        SASIAN_TRIPLET,
        "Cooke triplet f/4 (Sasian)",
        "Jose Sasian, Introduction to Lens Design, Cambridge University Press, 2019 (as ray-optics 0.9.8's models/Sasian Triplet.roa: curvatures, gaps and SCHOTT glasses typed in)",
    ),
    (
        "double-gauss-f2.toml",
        DOUBLE_GAUSS,
        "Double Gauss f/2",
        "\"Double Gauss F/2 - Available Glasses\", CODE V sequence file of 16 July 2015 shipped with ray-optics 0.9.8 (codev/tests/ag_dblgauss.seq; BSD-3): curvatures, gaps and SCHOTT glasses typed in",
    ),
    (
        "aspheric-singlet-acl3026u.toml",
        ASPHERIC_SINGLET,
        "Aspheric singlet (Thorlabs ACL3026U)",
        "Thorlabs ACL3026U aspheric condenser lens, Zemax file as published by Thorlabs (shipped with ray-optics 0.9.8 as elem/tests/ACL3026U-Zemax(ZMX).zmx); B 270 glass as a model glass nd 1.5230, Vd 58.8 from SCHOTT's B 270 datasheet (1993) via refractiveindex.info",
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
    typed = getattr(lens, "typed_in", None)
    for i, s in enumerate(surfaces, start=1):
        radius = float(s.geometry.radius)
        k = float(getattr(s.geometry, "k", 0.0) or 0.0)
        given = typed[i - 1] if typed else {}
        if k != 0.0 and "conic" not in given:
            raise SystemExit(f"{name}: surface {i} is a conic; extend the importer")
        lines.append("[[surface]]")
        lines.append(f"radius = {radius!r}" if math.isfinite(radius) else 'radius = "inf"')
        lines.append(f"thickness = {float(s.thickness)!r}")
        lines.append(f"semi_diameter = {sd[i]!r}")
        if "nd" in given:
            lines.append(f"nd = {given['nd']!r}")
            lines.append(f"vd = {given['vd']!r}")
        else:
            glass = getattr(s.material_post, "name", None)
            if glass:
                lines.append(f'glass = "{glass}"')
        if s.is_stop:
            lines.append("stop = true")
        if "conic" in given:
            lines.append(f"conic = {given['conic']!r}")
        if "aspheric" in given:
            lines.append(f"aspheric = {given['aspheric']!r}")
        lines.append("")
    path.write_text("\n".join(lines))
    print(f"wrote {path}")


def main() -> None:
    out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "camsim/lenses")
    out.mkdir(parents=True, exist_ok=True)
    only = set(sys.argv[2:])
    for file, cls, name, source in LENSES:
        if only and file not in only:
            continue
        write(out / file, cls(), name, source)


if __name__ == "__main__":
    main()
