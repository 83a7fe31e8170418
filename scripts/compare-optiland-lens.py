#!/usr/bin/env python3
"""Sets `camsim lens` beside optiland (PyPI, MIT) on camsim lens files: paraxial data at the
F, d and C lines, and real rays over a grid of fields and pupil points traced by both to the
same image plane (the paraxial focal plane at that wavelength).

Usage: python scripts/compare-optiland-lens.py CAMSIM LENS.toml... (optiland and tomllib
importable). Prints the largest differences and exits 1 when one exceeds the issue's bounds:
paraxial figures 1e-6 relative, ray intercepts 1e-6 mm, distortion 1e-4 percentage points (over
the file's field_deg, f-tan, on the paraxial focal plane), chromatic focal shift 0.1 um.
"""

import json
import math
import subprocess
import sys
import tempfile
import tomllib
import warnings

import numpy as np

warnings.filterwarnings("ignore")

from optiland import optic  # noqa: E402
from optiland.materials import IdealMaterial  # noqa: E402
from optiland.analysis.distortion_strategies.model import create_distortion_model  # noqa: E402

LINES = (486.1327, 587.5618, 656.2725)


def model_index(nd: float, vd: float, wavelength_nm: float) -> float:
    """camsim's model glass: n = A + B / l^2 (l in um) through nd at the d line with
    (nd - 1) / (nF - nC) = Vd (optics-core's Medium::Model)."""
    inv2 = lambda l: 1e6 / (l * l)  # noqa: E731
    b = (nd - 1.0) / (vd * (inv2(LINES[0]) - inv2(LINES[2])))
    a = nd - b * inv2(LINES[1])
    return a + b * inv2(wavelength_nm)


def build(lens: dict, wavelength_nm: float, image_distance: float, max_field_deg: float):
    o = optic.Optic()
    o.surfaces.add(index=0, radius=np.inf, thickness=np.inf)
    for i, s in enumerate(lens["surface"], start=1):
        r = s.get("radius", "inf")
        r = np.inf if r == "inf" or r == 0 else float(r)
        kw = dict(index=i, radius=r, thickness=float(s["thickness"]))
        if i == len(lens["surface"]):
            kw["thickness"] = image_distance
        if "glass" in s:
            kw["material"] = (s["glass"], "schott")
        elif "nd" in s:
            # camsim's model glass (a two-term Cauchy through nd and Vd at the F, d and C
            # lines), as optiland's constant index at the one wavelength this optic traces.
            kw["material"] = IdealMaterial(n=model_index(s["nd"], s["vd"], wavelength_nm))
        if "conic" in s or "aspheric" in s:
            kw["surface_type"] = "even_asphere"
            kw["conic"] = float(s.get("conic", 0.0))
            # optiland's even asphere starts at r^2, camsim's at r^4.
            kw["coefficients"] = [0.0] + [float(a) for a in s.get("aspheric", [])]
        if s.get("stop"):
            kw["is_stop"] = True
        o.surfaces.add(**kw)
    o.surfaces.add(index=len(lens["surface"]) + 1)
    stop = next(s for s in lens["surface"] if s.get("stop"))
    o.set_aperture(aperture_type="float_by_stop_size", value=2.0 * float(stop["semi_diameter"]))
    o.fields.set_type(field_type="angle")
    o.fields.add(y=0.0)
    o.fields.add(y=max_field_deg)
    o.wavelengths.add(value=wavelength_nm / 1000.0, is_primary=True)
    return o


def scalar(v) -> float:
    return float(np.ravel(np.asarray(v))[0])


def camsim(binary: str, path: str, wavelength_nm: float, rays=None) -> dict:
    args = [binary, "lens", path, "--json", "--wavelength", repr(wavelength_nm)]
    if rays is not None:
        with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
            json.dump(rays, f)
        args += ["--trace", f.name]
    return json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)


def main() -> int:
    binary, files = sys.argv[1], sys.argv[2:]
    worst_paraxial, worst_ray = 0.0, 0.0
    compared, vignetted, backwards = 0, 0, 0
    worst_distortion, worst_shift = 0.0, 0.0
    for path in files:
        with open(path, "rb") as f:
            lens = tomllib.load(f)
        last = float(lens["surface"][-1]["thickness"])
        for wl in LINES:
            ours = camsim(binary, path, wl)
            bfl = ours["bfl_mm"]
            field = float(lens.get("field_deg", 15.0))
            o = build(lens, wl, bfl, field)
            p = o.paraxial
            peer = {
                "efl_mm": scalar(p.f2()),
                "bfl_mm": scalar(p.F2()) + bfl,
                "entrance_pupil_position_mm": scalar(p.EPL()),
                "entrance_pupil_diameter_mm": scalar(p.EPD()),
                "exit_pupil_position_mm": scalar(p.XPL()) + bfl,
                "exit_pupil_diameter_mm": scalar(p.XPD()),
            }
            for key, v in peer.items():
                d = abs(ours[key] - v) / max(abs(v), 1.0)
                worst_paraxial = max(worst_paraxial, d)
                if d > 1e-6:
                    print(f"{path} {wl} nm {key}: camsim {ours[key]!r} optiland {v!r}")
            # Distortion on the same plane, f-tan, against optiland's chief-ray model.
            curves = ours.get("curves")
            if curves:
                hy = np.array([k / 10.0 for k in range(1, 11)])
                model = create_distortion_model("paraxial", distortion_type="f-tan")
                result = model.compute(o, np.zeros_like(hy), hy, wl / 1000.0)
                peer_d = np.ravel(np.asarray(model.percent(result, signed=True)))
                for k in range(10):
                    mine = curves["distortion_percent"][k + 1]
                    if mine is None:
                        continue
                    d = abs(mine - float(peer_d[k]))
                    worst_distortion = max(worst_distortion, d)
                    if d > 1e-4:
                        print(f"{path} {wl} nm field {hy[k]}: distortion {mine} % (camsim) and {peer_d[k]} % (optiland)")
            # Chromatic focal shift: the back focus against the d line's, optiland's paraxial.
            if wl != 587.5618:
                d_line = build(lens, 587.5618, bfl, field).paraxial
                peer_shift = scalar(p.F2()) - scalar(d_line.F2())
                mine = ours["bfl_mm"] - camsim(binary, path, 587.5618)["bfl_mm"]
                worst_shift = max(worst_shift, abs(mine - peer_shift) * 1000.0)
            # Real rays: optiland's own starting rays (aimed at its paraxial entrance pupil),
            # traced by both to the paraxial focal plane at this wavelength.
            rays, hits = [], []
            for hy in (0.0, 0.5, 1.0):
                for px, py in ((0, 0), (0, 0.7), (0, -0.7), (0.7, 0), (0.5, 0.5), (0, 1.0), (0, -1.0)):
                    o.trace_generic(Hx=0.0, Hy=hy, Px=px, Py=py, wavelength=wl / 1000.0)
                    sg = o.surface_group
                    start = [float(np.ravel(a)[0]) for a in (sg.x[0], sg.y[0], sg.z[0])]
                    direction = [float(np.ravel(a)[0]) for a in (sg.L[0], sg.M[0], sg.N[0])]
                    first_z = float(np.ravel(sg.positions[1])[0])
                    hit = [float(np.ravel(sg.x[-1])[0]), float(np.ravel(sg.y[-1])[0])]
                    if not all(math.isfinite(v) for v in start + direction + hit):
                        continue
                    # optiland follows a ray wherever the surfaces' equations meet it, even
                    # backwards (past the rim where an element's two faces cross); camsim
                    # ends such a ray. Those are not compared, but counted.
                    zs = [float(np.ravel(z)[0]) for z in sg.z[1:-1]]
                    if any(b < a - 1e-9 for a, b in zip(zs, zs[1:])):
                        backwards += 1
                        continue
                    rays.append({"origin": [start[0], start[1], start[2] - first_z], "direction": direction, "wavelength_nm": wl})
                    hits.append(hit)
            traced = camsim(binary, path, wl, rays)["rays"]
            for r, hit in zip(traced, hits):
                if r["image"] is None:
                    # optiland is given no clear apertures: a rim ray camsim's stop or a lens
                    # edge vignettes is not compared, but counted.
                    if r["lost_because"] != "vignetted":
                        print(f"{path} {wl} nm: camsim lost a ray: {r['lost_because']} at surface {r['lost_at_surface']}")
                        worst_ray = math.inf
                    vignetted += 1
                    continue
                compared += 1
                d = math.hypot(r["image"][0] - hit[0], r["image"][1] - hit[1])
                worst_ray = max(worst_ray, d)
                if d > 1e-6:
                    print(f"{path} {wl} nm: ray lands at {r['image'][:2]} (camsim) and {hit} (optiland)")
        print(f"{path}: checked at {LINES} nm")
    print(f"largest distortion difference {worst_distortion:.3g} percentage points; largest chromatic focal shift difference {worst_shift:.3g} um")
    print(f"largest paraxial difference {worst_paraxial:.3g} (relative); largest ray difference {worst_ray:.3g} mm over {compared} rays ({vignetted} vignetted by camsim's clear apertures, which optiland is not given; {backwards} that optiland followed backwards past an element's rim)")
    ok = worst_paraxial <= 1e-6 and worst_ray <= 1e-6 and worst_distortion <= 1e-4 and worst_shift <= 0.1
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
