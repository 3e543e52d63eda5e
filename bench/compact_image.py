#!/usr/bin/python3
"""The compact representations in the image: red polyester cloth under the sky and the RGL satin
on a sphere under the sky map, rendered with the full table and with each representation at
8 KiB (the mixture, the smaller table, spherical harmonics, each with its sampling CDF where it
needs one; bench/compact_rivals.py writes them as full-resolution tables, the value at each
cell center as the representation evaluates it).

Every image is rendered by `bsdfmix render` as a table (f looked up in the table's cell, linear
in theta_o), with the same estimator (`mis_light_cdf`: light sampling and the table's CDF,
MIS), samples and seed, 128 x 128 (the scenes and cameras of configs/render/polyester_sky_small.yaml
and configs/render/satin_skymap.yaml). The difference from the full table's image is measured
as the render measures the stand-in's (docs/render.md, "Outputs"): over 4 x 4 pixel blocks,
sum |image - table| / sum table over the channels, and the image means per channel against the
table's. The full table rendered again under another seed gives the noise floor of that
difference (its row `table_seed2`). The time per vertex of a representation rendered as a table
is the table's; the mixture's own (the header's `eval_rgb` in the renderer) is the `stand_in`
row: the full table's render with the stand-in the render fits for the slices the scene needs
(K max 16) as f, the same estimator and seed. The representations' own evaluation costs are
bench/results/compact_rivals.csv's `eval_ns`.

    /usr/bin/python3 bench/compact_image.py [--materials polyester,satin_rosaline] [--spp 64]
                                            [--csv bench/results/compact_rivals_image.csv]
"""
import argparse
import csv
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bsdfmix")
WORK = os.path.join(ROOT, "out", "compact_rivals")
SCENES = {
    "polyester": "  scene: configs/scenes/sky.yaml\n",
    "satin_rosaline": "  scene: configs/scenes/skymap.yaml\n  camera:\n    position: [0.0, -1.2, 0.75]\n"
                      "    look_at: [0.0, 0.0, 0.22]\n    fov_deg: 36\n",
}
REPS = ["mixture", "table", "sh"]


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    c = 3 if kind == b"PF" else 1
    return data.reshape(h, w, c).astype(np.float64)


def block_difference(a, b, block=4):
    """The render's image_difference(a, b, block): sum |a - b| over blocks and channels / sum |b|."""
    h, w = (a.shape[0] // block) * block, (a.shape[1] // block) * block
    sa = a[:h, :w].reshape(h // block, block, w // block, block, 3).sum(axis=(1, 3))
    sb = b[:h, :w].reshape(h // block, block, w // block, block, 3).sum(axis=(1, 3))
    return float(np.abs(sa - sb).sum() / np.abs(sb).sum())


def render(mat, name, table, spp, seed, stand_in):
    out = os.path.join(WORK, "image", mat, name)
    cfg = out + ".yaml"
    os.makedirs(os.path.dirname(cfg), exist_ok=True)
    fit = os.path.join(WORK, "image", mat, name + "_fit")
    # The fit serves the stand-in row only; elsewhere one Gaussian per slice keeps it short.
    k = "  k_min: 1\n  k_max: 16\n" if stand_in else "  k_min: 1\n  k_max: 1\n  final_restarts: 1\n"
    with open(cfg, "w") as f:
        f.write("table: %s\nfit:\n  output: %s.h5\n  report: %s.csv\n  search_report: %s_search.csv\n%s  seed: 1\n"
                "render:\n  output: %s\n  width: 128\n  height: 128\n  spp: %d\n  seconds: 0.001\n  reference_spp: 1\n"
                "  estimators: [mis_light_cdf]\n  stand_in: %s\n  stand_in_spp: %d\n  stand_in_estimator: mis_light_cdf\n"
                "  seed: %d\n%s" % (table, fit, fit, fit, k, out, spp, "true" if stand_in else "false", spp, seed, SCENES[mat]))
    t0 = time.time()
    r = subprocess.run([BIN, "render", cfg, "--quiet", "--no-figures"], cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed: render %s\n%s%s" % (cfg, r.stdout, r.stderr))
    rows = list(csv.DictReader(open(os.path.join(out, "render.csv"))))
    return out, rows, time.time() - t0


def ns_of(rows, estimator, mode):
    for r in rows:
        if r["estimator"] == estimator and r["mode"] == mode:
            return float(r["ns_per_vertex"])
    return float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--materials", default="polyester,satin_rosaline")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "compact_rivals_image.csv"))
    ap.add_argument("--rivals-csv", default=os.path.join(ROOT, "bench", "results", "compact_rivals.csv"),
                    help="the per-slice study's CSV, for each representation's bytes and configuration")
    a = ap.parse_args()
    cpu = "unknown"
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            cpu = line.split(":", 1)[1].strip().replace(",", ";")
            break
    command = "/usr/bin/python3 bench/compact_image.py" + "".join(" " + x for x in sys.argv[1:])
    bytes_of = {}
    for r in csv.DictReader(open(a.rivals_csv)):
        if r["budget"] == "8192":
            bytes_of[(r["material"], r["representation"])] = (r["bytes"], r["config"], r["median_rgb"])
    out = []
    for mat in a.materials.split(","):
        full = os.path.join(WORK, "%s_table.h5" % mat)
        base, rows, sec = render(mat, "full", full, a.spp, 1, True)
        ref = read_pfm(os.path.join(base, "mis_light_cdf_spp.pfm"))
        means = ref.reshape(-1, 3).mean(axis=0)
        lum = lambda m: float(m @ np.array([0.2126, 0.7152, 0.0722]))
        print("%s: full table rendered in %.0f s" % (mat, sec), flush=True)

        def row(rep, img, ns, b="", cfg="", slice_rgb=""):
            m = img.reshape(-1, 3).mean(axis=0)
            out.append(dict(material=mat, representation=rep, bytes=b, config=cfg, median_rgb=slice_rgb,
                            difference_4x4=block_difference(img, ref), difference_pixels=block_difference(img, ref, 1),
                            mean_luminance=lum(m) / lum(means) - 1, mean_r=m[0] / means[0] - 1,
                            mean_g=m[1] / means[1] - 1, mean_b=m[2] / means[2] - 1, ns_per_vertex=ns, spp=a.spp,
                            width=128, height=128, cpu=cpu, cores=os.cpu_count(), command=command))
            print("  %s: 4x4 difference %.2f%%, mean %+.2f%%, %.0f ns per vertex" % (
                rep, 100 * out[-1]["difference_4x4"], 100 * out[-1]["mean_luminance"], ns), flush=True)

        row("table_full", ref, ns_of(rows, "mis_light_cdf", "equal_spp"), cfg="the full table")
        row("stand_in", read_pfm(os.path.join(base, "stand_in.pfm")), ns_of(rows, "mis_light_cdf", "stand_in"),
            cfg="the render's own fit of the slices the scene needs, K max 16, evaluated by the header")
        s2, rows2, _ = render(mat, "full_seed2", full, a.spp, 2, False)
        row("table_seed2", read_pfm(os.path.join(s2, "mis_light_cdf_spp.pfm")), ns_of(rows2, "mis_light_cdf", "equal_spp"),
            cfg="the full table, another seed: the noise floor")
        for rep in REPS:
            t = os.path.join(WORK, "%s_%s_8k_table.h5" % (mat, rep))
            d, rr, sec = render(mat, rep, t, a.spp, 1, False)
            b, cfg, med = bytes_of.get((mat, rep), ("", "", ""))
            row(rep, read_pfm(os.path.join(d, "mis_light_cdf_spp.pfm")), ns_of(rr, "mis_light_cdf", "equal_spp"), b, cfg, med)
    cols = list(out[0].keys())
    with open(a.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, lineterminator="\n")
        w.writeheader()
        for r in out:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    print("wrote %s" % a.csv)


if __name__ == "__main__":
    main()
