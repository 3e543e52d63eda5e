#!/usr/bin/python3
"""Interpolation between slices, blend against displace, by leaving slices out: each shipped
RGL material's mixture (the study sampling_peers' fit at the default grid and settings)
keeps every other theta_o slice, so that the slices left out are served by the two around
them. Each of the two interpolations is then measured
- against the table at the left-out slices (`bsdfmix compare`: the relative L1 error), and
- as a sampler against the file's own (`bsdfmix bench sampling`, f the file's evaluation,
  random view elevations): the variance per sample over the RGL sampler's.

    /usr/bin/python3 bench/interpolation.py [--work out/sampling_peers] [--directions 8]
        [--samples 16384] [--csv bench/results/interpolation.csv]

The fits are the study sampling_peers' (bench/reproduce.sh sampling_peers makes them).
"""
import argparse
import glob
import os
import sys

import h5py
import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)
from study_io import ROOT, by_view, bsdfmix, over_rgl, rows, write_rows  # noqa: E402  (bench/study_io.py)



def run(*args):
    bsdfmix("interpolation", *args)


def every_other_slice(src, dst):
    """The padded mixture file src with slices 0, 2, 4, ... alone (colour copies kept)."""
    with h5py.File(src, "r") as f, h5py.File(dst, "w") as g:
        m, o = f["mixture"], g.create_group("mixture")
        if "offset" in m:
            sys.exit(f"interpolation: {src}: needs the padded storage `bsdfmix fit` writes")
        for k, v in m.attrs.items():
            o.attrs[k] = v
        S = m["theta_o"].shape[0]
        keep = np.arange(0, S, 2)
        K = m["k"][()]
        for name, d in m.items():
            if name in ("rgb_copies", "copies_offset"):
                continue
            a = d[()]
            if name not in ("table_theta_o", "table_phi_o") and a.shape[0] == S:
                a = a[keep]
            o.create_dataset(name, data=a)
        if "copies_offset" in m:
            off, rows, new, r = m["copies_offset"][()], [], [], 0
            for s in keep:
                if off[s] < 0:
                    new.append(-1)
                    continue
                new.append(r)
                rows.append(m["rgb_copies"][off[s]:off[s] + K[s]])
                r += K[s]
            o.create_dataset("copies_offset", data=np.array(new, dtype=np.int32))
            o.create_dataset("rgb_copies", data=np.concatenate(rows) if rows else np.zeros((0, 4, 3)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "sampling_peers"))
    ap.add_argument("--directions", type=int, default=8)
    ap.add_argument("--samples", type=int, default=16384)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "interpolation.csv"))
    a = ap.parse_args()
    out = []
    for rgl in sorted(glob.glob(os.path.join(ROOT, "data", "rgl", "*_rgb.bsdf"))):
        name = os.path.basename(rgl).replace("_rgb.bsdf", "")
        table, mixture = os.path.join(a.work, name + ".h5"), os.path.join(a.work, name + "_mixture.h5")
        if not (os.path.exists(table) and os.path.exists(mixture)):
            sys.exit(f"interpolation: {mixture} is missing: run bench/reproduce.sh sampling_peers first")
        half = os.path.join(a.work, name + "_half_blend.h5")
        every_other_slice(mixture, half)
        for mode in ("blend", "displace"):
            f = os.path.join(a.work, f"{name}_half_{mode}.h5")
            if mode != "blend":
                run("pack", "-q", half, "--storage", "padded", "--interpolation", mode, "-o", f)
            cmp_csv, smp_csv = f[:-3] + "_compare.csv", f[:-3] + "_sampling.csv"
            run("compare", "-q", f, table, "--csv", cmp_csv)
            left_out = [float(r["l1_rel"]) for r in rows(cmp_csv) if r["fitted"] == "0"]
            run("bench", "sampling", "-q", "--rgl", rgl, "--table", table, "--mixture", f, "--directions",
                str(a.directions), "--samples", str(a.samples), "--seed", "1", "--csv", smp_csv)
            ratio = over_rgl(by_view(smp_csv), "is_mixture")
            out.append({"material": name, "interpolation": mode, "slices_left_out": len(left_out),
                        "l1_left_out_median": f"{np.median(left_out):.5f}",
                        "l1_left_out_p90": f"{np.percentile(left_out, 90):.5f}",
                        "views": len(ratio), "samples": a.samples,
                        "is_mixture_over_rgl_median": f"{np.median(ratio):.4g}",
                        "is_mixture_over_rgl_max": f"{np.max(ratio):.4g}", "cpu": cpu_model()})
            print(f"{name:20s} {mode:9s} L1 left out median {float(out[-1]['l1_left_out_median']):.4f} "
                  f"p90 {float(out[-1]['l1_left_out_p90']):.4f}; is_mixture / rgl median "
                  f"{out[-1]['is_mixture_over_rgl_median']} max {out[-1]['is_mixture_over_rgl_max']}", flush=True)
    write_rows(a.csv, out)


if __name__ == "__main__":
    main()
