"""The Mitsuba 3 peer of `camsim bench`'s render convergence: mitsuba.cornell_box() (camsim's
built-in `cornell-box` holds the same numbers) rendered with scalar_rgb on one thread at each
sample count, pinhole and thin lens, timed around mi.render, each image's RMSE taken against
Mitsuba's own render of the same camera at reference_spp (every core, seed 7), as camsim's are
against camsim's. Run by camsim with one JSON argument {size, depth, spps, reference_spp,
cameras: [{name, aperture, focus}]}; prints {rows: [{renderer, camera, spp, seconds, rmse}],
version}."""

import json
import os
import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def scene(size, depth, spp, camera):
    d = mi.cornell_box()
    d["integrator"]["max_depth"] = depth
    sensor = d["sensor"]
    sensor["film"]["rfilter"] = {"type": "box"}
    sensor["film"]["width"] = size
    sensor["film"]["height"] = size
    sensor["sampler"]["sample_count"] = spp
    if camera["aperture"] > 0:
        sensor["type"] = "thinlens"
        sensor["aperture_radius"] = camera["aperture"]
        sensor["focus_distance"] = camera["focus"]
    return mi.load_dict(d)


def main(request):
    size, rows = request["size"], []
    cores = os.cpu_count() or 1
    for camera in request["cameras"]:
        dr.set_thread_count(cores)
        spp = request["reference_spp"]
        reference = np.array(mi.render(scene(size, request["depth"], spp, camera), spp=spp, seed=7), dtype=np.float64)[..., :3]
        print(f"peers: Mitsuba 3 {camera['name']} reference", file=sys.stderr, flush=True)
        dr.set_thread_count(1)
        for spp in request["spps"]:
            s = scene(size, request["depth"], spp, camera)
            start = time.perf_counter()
            image = mi.render(s, spp=spp, seed=1)
            seconds = time.perf_counter() - start
            image = np.array(image, dtype=np.float64)[..., :3]
            rmse = float(np.sqrt(np.mean((image - reference) ** 2)))
            rows.append({"renderer": "Mitsuba 3", "camera": camera["name"], "spp": spp, "seconds": seconds, "rmse": rmse})
            print(f"peers: Mitsuba 3 {camera['name']} {spp} spp", file=sys.stderr, flush=True)
    print(json.dumps({"rows": rows, "version": mi.__version__}))


if __name__ == "__main__":
    main(json.loads(sys.argv[1]))
