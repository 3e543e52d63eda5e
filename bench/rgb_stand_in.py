#!/usr/bin/python3
"""The chromatic stand-in on the RGL materials of data/rgl, against its targets
(docs/fitting.md, "Colour and energy").

Imports each material at the default grid (90 theta_o, 90 x 180 cells), fits it with the
default settings, and reads the fit report and the files back:
- from the report: the luminance L1 median (`l1_rel`), the RGB error median (`rgb_l1_rel`),
  the RGB error less its part in cells whose measured channel is negative (`rgb_l1_rel -
  rgb_negative`) and its ratio to the luminance median (target: at most 1.2);
- recomputed here, independently of the program, from the table and the mixture file with
  h5py and numpy, the stand-in exactly as the header evaluates it (include/bsdfmix/
  mixture.hpp: every phi image within 9 sigma; each component's cell mass its density at
  the cell center's point of the file's map times the cell's area there, or in (theta, phi)
  its mean over 3 x 3 points of the cell where it is narrower than half a cell; a
  Lambertian base on the disk, docs/formats.md): the largest difference between the reported
  and the recomputed l1_rel, rgb_l1_rel and rgb_negative, in points (target: 0.2);
- the stand-in's energy per channel (luminance, R, G, B): its in-domain integral (each
  component's closed-form in-domain mass times its amplitude) against the table's (the sum
  of its cells' integrand weights), the largest relative error over the slices (target:
  0.5%); and the same with the stand-in summed over the cells;
- the slices whose colour the file holds as colour copies (copied_slices; docs/fitting.md,
  "Colour copies"), recomputed like the rest from the copies' own shapes;
- how far each slice's channels are from the luminance's shape (grey_share: each channel
  against its sum's share of the luminance, summed over the three, over their absolute sum;
  the L1 refinement leaves the channels of a slice below 1% out, host/fit/l1_refine.hpp).
  A channel that is measurement noise around zero (its negative cells hold more than 0.5%
  of its absolute sum: cg_sunflower's blue) has no integral the stand-in keeps (its
  amplitudes are its least-L1 fit): it is counted, not compared.

    bench/rgb_stand_in.py [--bsdfmix build/bsdfmix] [--work out/bench_rgb]
                          [--tables satin,paper,sunflower,iris] [--csv bench/results/rgb_stand_in.csv]
                          [--set KEY=VALUE ...]   (fit settings, e.g. --set refine_rgb=0)
"""
import argparse
import csv
import math
import os
import statistics
import subprocess
import sys
import time

import h5py
import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)

# The project's one evaluator of mixture files that does not go through the header: every
# other script and study evaluates mixtures with the Python module bsdfmix, which is
# include/bsdfmix/mixture.hpp. This check recomputes the l1_rel, RGB error and energy that the
# fit reports (computed there with the header's density) from the files alone, so it must not
# share the header's code: a fault in the header would otherwise agree with itself. It follows
# the header by hand (docs/formats.md, "Slice mixtures" and "Colour copies").
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RGL = {
    "satin": "satin_rosaline_rgb.bsdf",
    "paper": "paper_white_rgb.bsdf",
    "sunflower": "cg_sunflower_rgb.bsdf",
    "iris": "cc_iris_purple_gem_rgb.bsdf",
}
# The fiber presets, generated at --fiber-theta-o rows (90 x 180 cells) in their colours
# (docs/fiber.md, "Colour"). The fiber domain's integrand weights have no cos theta_i.
FIBERS = ("silk", "cotton", "polyester", "wool")


def erf_mass(mu, s_tt, lo, hi):
    sd = math.sqrt(2.0 * s_tt)
    return 0.5 * (math.erf((hi - mu) / sd) - math.erf((lo - mu) / sd))


def component_mass(tt, pp, mu_t, mu_p, a, b, c, dth, dph, area, sub_cells=True):
    """A component's mass in every cell, as the header evaluates its density: at the cell
    points (tt, pp) of the mixture's plane times the cells' area there (an array on an
    equal-area map); in (theta, phi) (sub_cells) one narrower than half a cell takes its mean
    over 3 x 3 points of the cell."""
    det = a * c - b * b
    i_tt, i_tp, i_pp = c / det, -b / det, a / det
    norm = 1.0 / (2 * math.pi * math.sqrt(det))
    cut = 9.0 * math.sqrt(c)
    images = int(math.ceil((cut + math.pi + abs(mu_p)) / (2 * math.pi)))
    half_tr = 0.5 * (a + c)
    lmin = half_tr - math.sqrt(0.25 * (a - c) ** 2 + b * b)
    wide = 0.5 * min(dth, dph)
    narrow = sub_cells and lmin < wide * wide
    offsets = [(x * dth / 3, y * dph / 3) for x in (-1, 0, 1) for y in (-1, 0, 1)] if narrow else [(0.0, 0.0)]
    out = np.zeros_like(tt)
    for ot, op in offsets:
        t = tt + ot
        p = pp + op
        p = (p + math.pi) % (2 * math.pi) - math.pi  # wrap_phi
        dt = t - mu_t
        for m in range(-images, images + 1):
            dp = p + 2 * math.pi * m - mu_p
            q = i_tt * dt * dt + 2 * i_tp * dt * dp + i_pp * dp * dp
            out += np.where((np.abs(dp) <= cut) & (q < 1500), np.exp(-0.5 * np.minimum(q, 1500)), 0.0)
    return out * norm / len(offsets) * area


class Plane:
    """A mixture file's plane (docs/formats.md, "Maps") at a table's cells: each cell at the
    map point of its center, with its solid angle as its area; the components' in-domain
    masses; the Lambertian base's density (map disk)."""

    def __init__(self, mixture, theta, phi, domain):
        name = mixture.attrs.get("map", b"theta_phi")
        self.map = name.decode() if isinstance(name, bytes) else str(name)
        self.domain = domain
        self.dth, self.dph = theta[1] - theta[0], phi[1] - phi[0]
        tt, pp = np.meshgrid(theta, phi, indexing="ij")
        area = self.dth * self.dph
        if self.map == "disk":
            r = 2 * np.sin(tt / 2)
            self.x, self.y, self.area = r * np.cos(pp), r * np.sin(pp), np.sin(tt) * area
        elif self.map == "cylinder":
            self.x, self.y, self.area = np.sin(tt), pp, np.cos(tt) * area
        else:
            self.x, self.y, self.area = tt, pp, area
        self.base_density = np.maximum(1 - 0.5 * (self.x ** 2 + self.y ** 2), 0.0) / math.pi

    def mass(self, mu_t, mu_p, a, b, c):
        return component_mass(self.x, self.y, mu_t, mu_p, a, b, c, self.dth, self.dph, self.area,
                              sub_cells=self.map == "theta_phi")

    def in_domain(self, mu_t, mu_p, a, b, c):
        """The component's mass inside the domain: the first axis within its range, or on the
        disk within radius sqrt 2 (polar midpoints, 64 rings x 256 angles)."""
        if self.map != "disk":
            lo, hi = ((-1.0, 1.0) if self.map == "cylinder" else
                      (-math.pi / 2, math.pi / 2) if self.domain == "fiber" else (0.0, math.pi / 2))
            return erf_mass(mu_t, a, lo, hi)
        nr, na = 64, 256
        dr, da = math.sqrt(2.0) / nr, 2 * math.pi / na
        r = (np.arange(nr) + 0.5) * dr
        ang = np.arange(na) * da
        rr, aa = np.meshgrid(r, ang, indexing="ij")
        d = component_mass(rr * np.cos(aa), rr * np.sin(aa), mu_t, mu_p, a, b, c, 1.0, 1.0, rr * dr * da, False)
        return min(float(d.sum()), 1.0)


def abs_rgb_of(flat):
    return float(np.abs(flat).sum())


def recompute(table_path, mixture_path):
    t = h5py.File(table_path, "r")["table"]
    m = h5py.File(mixture_path, "r")["mixture"]
    theta, phi = t["theta_i"][:], t["phi_i"][:]
    dth, dph = theta[1] - theta[0], phi[1] - phi[0]
    area = dth * dph
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    domain = t.attrs["domain"]
    domain = domain.decode() if isinstance(domain, bytes) else str(domain)
    if domain == "fiber":  # f J dtheta dphi, J = cos(theta_i), theta_i in [-pi/2, pi/2]
        jac = np.cos(tt) * area
    else:  # hemisphere: f cos(theta_i) J dtheta dphi, J = sin(theta_i)
        jac = np.cos(tt) * np.sin(tt) * area
    plane = Plane(m, theta, phi, domain)
    has_rgb = "rgb_scale" in m
    # colour copies: the rows of the slices that have them, slice s's at copies_offset[s] (-1: none)
    copies = m["rgb_copies"][:] if "rgb_copies" in m else None
    copies_offset = m["copies_offset"][:] if "rgb_copies" in m else None
    rows = []
    for s in range(m["k"].shape[0]):
        k = int(m["k"][s])
        w_y = t["values"][s, 0].astype(np.float64) * jac
        w_c = t["rgb"][s, 0].astype(np.float64) * jac[..., None]
        weights = m["weights"][s, :k].astype(np.float64)
        base = float(m["base"][s]) if "base" in m else 0.0
        base, weights = base / (weights.sum() + base), weights / (weights.sum() + base)  # as the header's prepare()
        scale = float(m["scale"][s])
        rgb_amp = m["rgb_scale"][s, :k].astype(np.float64) if has_rgb else np.outer(scale * weights, np.ones(3))
        y = scale * base * plane.base_density * plane.area
        energy = np.zeros(4)
        energy[0] = scale * base  # the base lies inside the domain
        base_rgb = m["base_rgb"][s].astype(np.float64) if base > 0 and "base_rgb" in m else np.zeros(3)
        c = (plane.base_density * plane.area)[..., None] * base_rgb
        energy[1:] = base_rgb
        copied = copies is not None and int(copies_offset[s]) >= 0
        copy_amp = copies[int(copies_offset[s]):int(copies_offset[s]) + k].astype(np.float64) if copied else None
        for j in range(k):
            a, b, cc = (float(x) for x in m["covariances"][s, j])
            mt, mp = (float(x) for x in m["means"][s, j])
            mass = plane.mass(mt, mp, a, b, cc)
            y += scale * weights[j] * mass
            z = plane.in_domain(mt, mp, a, b, cc)
            energy[0] += scale * weights[j] * z
            if not copied:
                c += mass[..., None] * rgb_amp[j]
                energy[1:] += rgb_amp[j] * z
                continue
            # Colour copies (docs/formats.md): copy i moved by 0.5 along a column of the
            # Cholesky factor L (i = 0, 1: -, + L e_theta; 2, 3: -, + L e_phi), covariance x 0.875.
            l_tt = math.sqrt(a)
            l_pt = b / l_tt
            l_pp = math.sqrt(max(cc - l_pt * l_pt, 0.0))
            for i in range(4):
                sign = 1.0 if i % 2 else -1.0
                ct = mt + (0.5 * sign * l_tt if i < 2 else 0.0)
                cp = mp + 0.5 * sign * (l_pt if i < 2 else l_pp)
                mass_i = plane.mass(ct, cp, 0.875 * a, 0.875 * b, 0.875 * cc)
                c += mass_i[..., None] * copy_amp[j, i]
                energy[1:] += copy_amp[j, i] * plane.in_domain(ct, cp, 0.875 * a, 0.875 * b, 0.875 * cc)
        table_energy = np.concatenate([[w_y.sum()], w_c.reshape(-1, 3).sum(axis=0)])
        flat = w_c.reshape(-1, 3)
        noise = [False] + [bool(-flat[:, ch][flat[:, ch] < 0].sum() > 0.005 * np.abs(flat[:, ch]).sum())
                           for ch in range(3)]
        cell_energy = np.concatenate([[y.sum()], c.reshape(-1, 3).sum(axis=0)])
        abs_rgb = np.abs(w_c).sum()
        err = np.abs(w_c - c)
        # How far the channels are from the luminance's shape: each channel against its sum's
        # share of the luminance, summed over the three, over their absolute sum (below 1%
        # the L1 refinement leaves the slice's channels out: host/fit/l1_refine.hpp).
        grey = (sum(np.abs(flat[:, ch] - flat[:, ch].sum() / w_y.sum() * w_y.reshape(-1)).sum() for ch in range(3))
                / abs_rgb_of(flat) if w_y.sum() > 0 and abs_rgb_of(flat) > 0 else 0.0)
        rows.append({
            "grey_share": grey, "copied": copied,
            "l1_rel": np.abs(w_y - y).sum() / w_y.sum() if w_y.sum() > 0 else 0.0,
            "rgb_l1_rel": err.sum() / abs_rgb if abs_rgb > 0 else 0.0,
            "rgb_negative": err[w_c < 0].sum() / abs_rgb if abs_rgb > 0 else 0.0,
            "table_energy": table_energy, "energy": energy, "cell_energy": cell_energy, "noise": noise,
        })
    return rows, has_rgb


def run(args):
    os.makedirs(args.work, exist_ok=True)
    results = []
    for name in [n for n in args.tables.split(",") if n]:
        table = os.path.join(args.work, name + ".h5")
        if not os.path.exists(table) and name in FIBERS:
            subprocess.run([args.bsdfmix, "generate", "fiber", "--preset", name, "--theta-o", str(args.fiber_theta_o),
                            "-o", table, "--quiet"], check=True)
        elif not os.path.exists(table):
            subprocess.run([args.bsdfmix, "import", "rgl", os.path.join(ROOT, "data", "rgl", RGL[name]), "-o", table,
                            "--quiet"], check=True)
        out = os.path.join(args.work, name)
        cfg = out + ".yaml"
        with open(cfg, "w") as f:
            f.write(f"table: {table}\nfit:\n  output: {out}_mixture.h5\n  report: {out}_fit.csv\n"
                    f"  search_report: {out}_search.csv\n")
            for setting in args.set:
                key, _, value = setting.partition("=")
                f.write(f"  {key}: {value}\n")
        if os.path.exists(out + "_mixture.h5"):
            os.remove(out + "_mixture.h5")
        start = time.monotonic()
        subprocess.run([args.bsdfmix, "fit", "-q", cfg], check=True, stdout=subprocess.DEVNULL)
        seconds = time.monotonic() - start
        with open(out + "_fit.csv") as f:
            report = list(csv.DictReader(f))
        rows, has_rgb = recompute(table, out + "_mixture.h5")
        if not has_rgb:
            sys.exit(f"{name}: the mixture file has no rgb_scale")
        l1 = [float(r["l1_rel"]) for r in report]
        rgb = [float(r["rgb_l1_rel"]) for r in report]
        rest = [float(r["rgb_l1_rel"]) - float(r["rgb_negative"]) for r in report]
        diff = {key: max(abs(float(r[key]) - x[key]) for r, x in zip(report, rows))
                for key in ("l1_rel", "rgb_l1_rel", "rgb_negative")}
        worst, worst_cells, skipped = np.zeros(4), np.zeros(4), 0
        for x in rows:
            for ch in range(4):
                if x["noise"][ch] or not x["table_energy"][ch] > 0:
                    skipped += 1
                    continue
                worst[ch] = max(worst[ch], abs(x["energy"][ch] / x["table_energy"][ch] - 1))
                worst_cells[ch] = max(worst_cells[ch], abs(x["cell_energy"][ch] / x["table_energy"][ch] - 1))
        r = {
            "table": name, "slices": len(report), "mean_k": statistics.mean(int(x["k"]) for x in report),
            "l1_median": statistics.median(l1), "rgb_median": statistics.median(rgb),
            "rgb_less_negative_median": statistics.median(rest),
            "ratio": statistics.median(rest) / statistics.median(l1),
            "energy_max_y": worst[0], "energy_max_r": worst[1], "energy_max_g": worst[2], "energy_max_b": worst[3],
            "energy_cells_max": worst_cells.max(), "noise_channels": skipped,
            "l1_diff_points": 100 * diff["l1_rel"], "rgb_diff_points": 100 * diff["rgb_l1_rel"],
            "negative_diff_points": 100 * diff["rgb_negative"], "fit_seconds": seconds,
            "grey_share_min": min(x["grey_share"] for x in rows),
            "grey_share_median": statistics.median(x["grey_share"] for x in rows),
            "grey_share_max": max(x["grey_share"] for x in rows),
            "copied_slices": sum(1 for x in rows if x["copied"]),
        }
        print(f"{name:10s} L1 median {100 * r['l1_median']:.2f}%, RGB median {100 * r['rgb_median']:.2f}%, less the "
              f"negative part {100 * r['rgb_less_negative_median']:.2f}% ({r['ratio']:.3f}x); energy max Y/R/G/B "
              f"{100 * worst[0]:.2g}/{100 * worst[1]:.2g}/{100 * worst[2]:.2g}/{100 * worst[3]:.2g}% (cell sums "
              f"{100 * r['energy_cells_max']:.2f}%; {skipped} (slice, channel) noise); report vs recomputed "
              f"{r['l1_diff_points']:.2g} / {r['rgb_diff_points']:.2g} / {r['negative_diff_points']:.2g} points; "
              f"fit {seconds:.1f} s; {r['copied_slices']} slices with colour copies", flush=True)
        results.append(r)
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "bench_rgb"))
    ap.add_argument("--tables", default="satin,paper,sunflower,iris," + ",".join(FIBERS))
    ap.add_argument("--fiber-theta-o", type=int, default=45, help="theta_o rows of the generated fiber tables")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "rgb_stand_in.csv"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a fit setting for every table (repeatable), e.g. refine_rgb=0")
    args = ap.parse_args()
    results = run(args)
    os.makedirs(os.path.dirname(args.csv), exist_ok=True)
    cpu, cores = cpu_model(), os.cpu_count()
    with open(args.csv, "w", newline="") as f:
        w = csv.writer(f)
        keys = list(results[0].keys())
        w.writerow(keys + ["cpu_model", "logical_cpus"])
        for r in results:
            w.writerow([f"{r[k]:.6g}" if isinstance(r[k], float) else r[k] for k in keys] + [cpu, cores])
    print(f"wrote {args.csv} ({cpu}, {cores} logical CPUs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
