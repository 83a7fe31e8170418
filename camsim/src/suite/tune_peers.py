"""The tuning peers of `camsim bench tune`, run with the tuning peers' Python (.venv-tune, made by
scripts/test-all.sh from tests/oracle/tune-peers-requirements.txt) on the capture set camsim
tuned, timed in the same run. Embedded in camsim.

argv[1]: a JSON object {captures, work, manifest, ptc}:
- captures: the capture folder; manifest: the chart, flat-field and dark files in it (the
  names rpi-ctt reads; the photon-transfer pairs are left out, which it would take for charts);
- work: a folder for rpi-ctt's output;
- ptc: [{iso, exposure_s, dark: [a, b], levels: [[level, a, b], ...]}], paths of the DNGs of
  each ISO's photon-transfer pairs (level: the relative light, the photon count's stand-in).

Peers:
- rpi-ctt (Raspberry Pi's Camera Tuning Tool), run as its command line is (`ctt -t pisp`); its
  tuning file's CCMs, ALSC tables, noise and black level are returned as written;
- emva1288 (the EMVA 1288 reference implementation): Data1288 and Results1288 on each CFA
  position's plane of the photon-transfer pairs (a pair of frames per level, the dark pair as
  its 0.0 photon point; the spatial point is the dark pair and the middle level), returning the
  system gain K (DN/e-) and the temporal dark noise sigma_y_dark (DN). emva1288 1.0.2 calls
  numpy's asfarray, which numpy 2 removed: it is given back as asarray with a float dtype.

Prints {versions, ctt: {tuning, seconds} | {error}, emva1288: {per_iso: [{iso, positions: [{K,
sigma_y_dark}] x 4 (position = 2 y + x in the 2x2 block)}], seconds} | {error}}.
"""

import json
import subprocess
import sys
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np
import rawpy

if not hasattr(np, "asfarray"):
    np.asfarray = lambda a, dtype=np.float64: np.asarray(a, dtype=dtype)

import emva1288.process.routines as routines  # noqa: E402
from emva1288.process.data import Data1288  # noqa: E402
from emva1288.process.results import Results1288  # noqa: E402


def run_ctt(a):
    work = Path(a["work"])
    work.mkdir(parents=True, exist_ok=True)
    manifest = work / "manifest.txt"
    manifest.write_text("".join(name + "\n" for name in a["manifest"]))
    ctt = Path(sys.executable).parent / "ctt"
    start = time.perf_counter()
    done = subprocess.run(
        [str(ctt), "-i", a["captures"], "-o", str(work), "-t", "pisp", "--name", "sim",
         "--manifest", str(manifest)],
        capture_output=True, text=True,
    )
    seconds = time.perf_counter() - start
    out = work / "sim_pisp.json"
    if done.returncode != 0 or not out.is_file():
        tail = (done.stdout + done.stderr).strip().splitlines()[-12:]
        return {"error": f"ctt exited {done.returncode}: " + " | ".join(tail)}
    tuning = json.loads(out.read_text())
    algorithms = {}
    for entry in tuning.get("algorithms", []):
        algorithms.update(entry)
    keep = {k: algorithms.get(k) for k in ("rpi.black_level", "rpi.noise", "rpi.alsc", "rpi.ccm", "rpi.awb")}
    return {"tuning": keep, "seconds": seconds}


def plane(path, position):
    with rawpy.imread(path) as raw:
        image = raw.raw_image_visible.copy()
    return image[position // 2::2, position % 2::2]


def emva(a):
    start = time.perf_counter()
    per_iso = []
    for entry in a["ptc"]:
        positions = []
        for p in range(4):
            def pair(paths):
                return [plane(f, p) for f in paths]

            dark = pair(entry["dark"])
            levels = sorted(entry["levels"], key=lambda l: l[0])
            h, w = dark[0].shape

            def temporal(imgs):
                d = routines.get_int_imgs(imgs)
                return {"sum": np.sum(d["sum"]), "pvar": np.sum(d["pvar"]), "dmean": d["dmean"]}

            texp = entry["exposure_s"]
            t = {texp: {0.0: temporal(dark)}}
            for level, fa, fb in levels:
                t[texp][float(level)] = temporal(pair([fa, fb]))
            middle = levels[len(levels) // 2]
            s = {texp: {0.0: routines.get_int_imgs(dark),
                        float(middle[0]): routines.get_int_imgs(pair([middle[1], middle[2]]))}}
            data = Data1288({"width": w, "height": h, "temporal": t, "spatial": s}, loglevel=40)
            results = Results1288(data.data, loglevel=40)
            positions.append({"K": float(results.K), "sigma_y_dark": float(results.sigma_y_dark)})
        per_iso.append({"iso": entry["iso"], "positions": positions})
    return {"per_iso": per_iso, "seconds": time.perf_counter() - start}


def main():
    a = json.loads(sys.argv[1])
    reply = {"versions": {"rpi-ctt": version("rpi-ctt"), "emva1288": version("emva1288"),
                          "numpy": np.__version__}}
    try:
        reply["ctt"] = run_ctt(a)
    except Exception as e:  # reported, not raised: the other peer still runs
        reply["ctt"] = {"error": f"{type(e).__name__}: {e}"}
    try:
        reply["emva1288"] = emva(a)
    except Exception as e:
        reply["emva1288"] = {"error": f"{type(e).__name__}: {e}"}
    print(json.dumps(reply))


if __name__ == "__main__":
    main()
