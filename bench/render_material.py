#!/usr/bin/python3
"""What limits the glossy spheres' images: the light-sampling estimators on the sphere's
own pixels. Each glossy RGL sphere of `render_rgl` (satin_rosaline, cc_iris_purple_gem) is
rendered as configured (the sky map, over the ground), without the ground, and under the
analytic sky (configs/scenes/sky.yaml) without the ground, with the estimators that sample
the light (mis_light_cdf, mis_light_gmm, mis_product, mis_light_rgl), at equal samples and
at equal time. Every row carries the relative MSE over the whole image and over the pixels
whose centre sees the sphere (render.csv's rel_mse_material), and the latter over
mis_light_rgl's. Each variant is rendered --runs times (default 3); the seeds are the
config's, so the equal-sample images repeat and the equal-time ones differ by the samples
each estimator reached in its time: every row is its best run (the least error on the
sphere's pixels, then the least time), as every performance row of bench/ is.

    /usr/bin/python3 bench/render_material.py [--materials satin,iris] [--runs 3] [--csv bench/results/render_material.csv]

The tables and mixtures are render_rgl's (out/render_<material>/), fitted here when absent.
"""
import argparse
import os

import yaml
from machine import cpu_model  # noqa: E402  (bench/machine.py)
from study_io import ROOT, bsdfmix, rows, write_rows  # noqa: E402  (bench/study_io.py)

ESTIMATORS = ["mis_light_cdf", "mis_light_gmm", "mis_product", "mis_light_rgl"]
# (variant, scene, ground)
VARIANTS = [("skymap", "configs/scenes/skymap.yaml", True),
            ("skymap_no_ground", "configs/scenes/skymap.yaml", False),
            ("sky_no_ground", "configs/scenes/sky.yaml", False)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--materials", default="satin,iris")
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "render_material"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "render_material.csv"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    out = []
    for m in filter(None, a.materials.split(",")):
        src = os.path.join(ROOT, "configs", "render", f"{m}_skymap.yaml")
        if not os.path.exists(src):
            raise SystemExit(f"render_material: no config {src} for material '{m}'")
        for variant, scene, ground in VARIANTS:
            with open(src) as f:
                cfg = yaml.safe_load(f)
            r = cfg["render"]
            r["output"] = os.path.join(a.work, f"{m}_{variant}")
            r["scene"] = scene
            r["estimators"] = ESTIMATORS
            r["stand_in"] = False
            if not ground:
                r["ground"] = {"enabled": False}
            path = os.path.join(a.work, f"{m}_{variant}.yaml")
            with open(path + ".tmp", "w") as f:
                f.write(f"# {variant} of configs/render/{m}_skymap.yaml, written by bench/render_material.py\n")
                yaml.safe_dump(cfg, f, sort_keys=False)
            os.replace(path + ".tmp", path)
            best = {}
            for _ in range(max(1, a.runs)):
                bsdfmix("render_material", "render", "-q", "--no-figures", path)
                for x in rows(os.path.join(r["output"], "render.csv")):
                    if x["mode"] not in ("equal_spp", "equal_time"):
                        continue
                    k = (x["estimator"], x["mode"])
                    key = (float(x["rel_mse_material"]), float(x["seconds"]))
                    if k not in best or key < (float(best[k]["rel_mse_material"]), float(best[k]["seconds"])):
                        best[k] = x
            got = list(best.values())
            base = {x["mode"]: float(x["rel_mse_material"]) for x in got if x["estimator"] == "mis_light_rgl"}
            for x in got:
                out.append({"material": m, "variant": variant, "scene": os.path.basename(scene), "ground": int(ground),
                            "estimator": x["estimator"], "mode": x["mode"], "spp": x["spp"], "seconds": x["seconds"],
                            "rel_mse": x["rel_mse"], "rel_mse_material": x["rel_mse_material"],
                            "material_over_mis_light_rgl": "%.3f" % (float(x["rel_mse_material"]) / base[x["mode"]]),
                            "ns_per_vertex": x["ns_per_vertex"], "runs": max(1, a.runs), "cpu": cpu_model()})
                print(", ".join(f"{k} {v}" for k, v in out[-1].items() if k != "cpu"), flush=True)
    write_rows(a.csv, out)


if __name__ == "__main__":
    main()
