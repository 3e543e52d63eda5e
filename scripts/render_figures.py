#!/usr/bin/python3
"""The figures of a `bsdfmix render` run (docs/render.md), from its render.csv and render.json.

  scripts/render_figures.py --dir out/render_polyester [-o out/render_polyester/figures] [--summary PATH]

Reads D/render.csv (columns scene, fiber, estimator, mode, spp, seconds, rays_per_second,
rel_mse, image; `image` an EXR path relative to D, read through the PFM of the same stem
beside it) and D/render.json (scene, fiber, width, height, table_bytes, mixture_bytes,
full_table_bytes, slices_needed, slices_total, equal_time_seconds, reference). Writes, all
PNG at 150 dpi:

  <image stem>.png     beside every image's PFM: 8-bit sRGB color, each channel
                       v = 1 - exp(-exposure x), sRGB-encoded; one exposure per scene, set
                       for the cloth: the 99th percentile of the reference's luminance over
                       the pixels whose primary ray meets a fiber (D/cloth_mask.pfm; every
                       pixel when it is missing) maps to 0.85, so the cloth is neither dark
                       nor white, the bright ground and sky may clip, and the images of a
                       scene compare
  OUT/figure_sheet.png one column per estimator (CSV order) plus the reference: the
                       equal-spp images, their per-pixel relative squared error
                       (img - ref)^2 / (ref^2 + eps), eps = 1e-2 mean(ref)^2 (the eps of
                       bsdfmix's relative_mse), as log10 in [-4, 0]; then the equal-time
                       images and their errors. Modes without rows are left out.
  OUT/error_vs_time.png  rel MSE against seconds (log-log) of the `progress` rows, one line
                       per estimator, the equal-time budget dashed
  OUT/stand_in.png     with `table` and `stand_in` rows: the two renders and their relative
                       difference |s - t| / (t + 0.1 mean(t)), with the memory of each f
  PATH (--summary; default OUT/summary.png)
                       the run in one figure: the table's and the stand-in's renders with
                       their memory (the stand-in against the table and the full 4D table),
                       their difference against the table image's own noise, and every
                       estimator's rel MSE against time (the `progress` rows, the equal-time
                       images as stars); its titles name the estimator with the least error
                       at equal time and by how much it leads the next and the last, and the
                       best estimator on the other side (with the mixtures / the table alone)

Prints each file written. Missing files, columns or keys: `render_figures: error: ...`, exit 1.
"""

import argparse
import csv
import math
import os
import struct
import sys
import zlib

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import colors as mcolors  # noqa: E402

COLUMNS = ["scene", "fiber", "estimator", "mode", "spp", "seconds", "rays_per_second", "rel_mse", "image"]
JSON_KEYS = ["scene", "fiber", "width", "height", "table_bytes", "mixture_bytes", "full_table_bytes",
             "slices_needed", "slices_total", "equal_time_seconds", "reference"]
MODES = {"equal_spp", "equal_time", "reference", "progress", "stand_in", "table"}
DPI = 150
ERR_RANGE = (-4.0, 0.0)   # log10 of the relative squared error shown
DIFF_RANGE = (-3.0, 0.0)  # log10 of the stand-in's relative difference shown


def fail(msg):
    print("render_figures: error: " + msg, file=sys.stderr)
    sys.exit(1)


# ---------------------------------------------------------------------------- inputs

def read_pfm(path):
    """A PFM as a float64 [h, w, 3] array, row 0 at the top (a grey "Pf": R = G = B)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        fail("cannot read %s: %s" % (path, e.strerror or e))
    tokens, pos = [], 0
    for _ in range(4):
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace():
            pos += 1
        if pos >= len(data) or pos == start:
            fail("%s: not a PFM file (truncated header)" % path)
        tokens.append(data[start:pos].decode("ascii", "replace"))
    pos += 1  # the single whitespace byte after the scale
    magic = tokens[0]
    if magic not in ("Pf", "PF"):
        fail("%s: not a PFM file (magic %r)" % (path, magic))
    try:
        w, h, scale = int(tokens[1]), int(tokens[2]), float(tokens[3])
    except ValueError:
        fail("%s: bad PFM header %r" % (path, " ".join(tokens[1:])))
    if w <= 0 or h <= 0 or scale == 0 or not math.isfinite(scale):
        fail("%s: bad PFM header %r" % (path, " ".join(tokens[1:])))
    ch = 1 if magic == "Pf" else 3
    n = w * h * ch
    if len(data) - pos < 4 * n:
        fail("%s: truncated PFM (%dx%d pixels expected)" % (path, w, h))
    a = np.frombuffer(data, dtype="<f4" if scale < 0 else ">f4", count=n, offset=pos).astype(np.float64)
    a = a.reshape(h, w, ch)[::-1]  # stored bottom row first
    if ch == 3:
        return a.copy()
    return np.repeat(a[..., :1], 3, axis=2)


def luminance(a):
    """Y of a [h, w, 3] linear Rec. 709 image."""
    return 0.2126 * a[..., 0] + 0.7152 * a[..., 1] + 0.0722 * a[..., 2]


def read_inputs(d):
    import json
    csv_path, json_path = os.path.join(d, "render.csv"), os.path.join(d, "render.json")
    for p in (csv_path, json_path):
        if not os.path.isfile(p):
            fail("missing %s" % p)
    try:
        with open(json_path) as f:
            meta = json.load(f)
    except (OSError, ValueError) as e:
        fail("cannot read %s: %s" % (json_path, e))
    if not isinstance(meta, dict):
        fail("%s: not a JSON object" % json_path)
    missing = [k for k in JSON_KEYS if k not in meta]
    if missing:
        fail("%s: missing keys %s" % (json_path, ", ".join(missing)))
    try:
        with open(csv_path, newline="") as f:
            reader = csv.DictReader(f)
            header = reader.fieldnames or []
            rows = list(reader)
    except OSError as e:
        fail("cannot read %s: %s" % (csv_path, e))
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        fail("%s: missing columns %s" % (csv_path, ", ".join(missing)))
    if not rows:
        fail("%s: no rows" % csv_path)
    for i, r in enumerate(rows, start=2):
        where = "%s line %d" % (csv_path, i)
        if r["mode"] not in MODES:
            fail("%s: unknown mode %r" % (where, r["mode"]))
        for k in ("spp", "seconds", "rays_per_second", "rel_mse"):
            v = (r[k] or "").strip()
            if v == "":
                r[k] = None
                continue
            try:
                r[k] = float(v)
            except ValueError:
                fail("%s: %s is not a number: %r" % (where, k, v))
        r["image"] = (r["image"] or "").strip()
        if r["mode"] != "progress" and not r["image"]:
            fail("%s: mode %s without an image" % (where, r["mode"]))
    return rows, meta


def pfm_of(d, image):
    return os.path.join(d, os.path.splitext(image)[0] + ".pfm")


# ---------------------------------------------------------------------------- images

def rel_sq_error(img, ref):
    """Per pixel, the relative squared error averaged over the channels (bsdfmix's
    relative_mse is its mean)."""
    eps = 1e-2 * float(np.mean(ref)) ** 2
    d = img - ref
    den = ref * ref + eps
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(d == 0, 0.0, d * d / den)
    return e.mean(axis=2)


def rel_mse(img, ref):
    return float(np.mean(rel_sq_error(img, ref)))


def exposure_for(ref, mask=None):
    """The exposure that maps the 99th percentile of the luminance over `mask` (the cloth's
    pixels; all when None or empty) to 0.85."""
    y = luminance(ref)
    if mask is not None and mask.shape == y.shape and np.any(mask):
        y = y[mask]
    v = y[np.isfinite(y)]
    p = float(np.percentile(v, 99.0)) if v.size else 0.0
    if not p > 0:
        p = float(v.max()) if v.size and v.max() > 0 else 1.0
    return -math.log(1.0 - 0.85) / p  # 1 - exp(-k p) = 0.85


def tone_map(img, exposure):
    x = np.nan_to_num(img, nan=0.0, posinf=np.inf, neginf=0.0)
    x = np.maximum(x, 0.0)
    v = 1.0 - np.exp(-exposure * x)
    v = np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1.0 / 2.4) - 0.055)
    return np.clip(v, 0.0, 1.0)


def write_rgb_png(path, v):
    """8-bit RGB PNG of v [h, w, 3] in [0, 1], 150 dpi."""
    a = np.round(v * 255.0).astype(np.uint8)
    h, w = a.shape[:2]
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff)

    ppm = int(round(DPI / 0.0254))
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    tmp = path + ".partial-%d" % os.getpid()
    try:
        with open(tmp, "wb") as f:
            f.write(png)
        os.replace(tmp, path)
    except OSError as e:
        fail("cannot write %s: %s" % (path, e.strerror or e))


def save(fig, path):
    try:
        fig.savefig(path, dpi=DPI)
    except OSError as e:
        fail("cannot write %s: %s" % (path, e.strerror or e))
    plt.close(fig)
    print(path)


# ---------------------------------------------------------------------------- figures

def fmt_bytes(n):
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return ("%d %s" % (n, unit)) if unit == "B" else (("%.0f %s" if abs(n) >= 100 else "%.3g %s") % (n, unit))
        n /= 1024.0


def fmt_rate(r):
    if r is None:
        return "?"
    for div, unit in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if r >= div:
            return "%.3g%s" % (r / div, unit)
    return "%.3g" % r


def fmt_spp(s):
    return "%d" % s if s is not None and float(s).is_integer() else ("%.3g" % s if s is not None else "?")


def estimators_in_order(rows, modes):
    out = []
    for r in rows:
        if r["mode"] in modes and r["estimator"] not in out:
            out.append(r["estimator"])
    return out


def panel_size(w, h):
    """Inches of one image panel: about 2.4 in across the longer side."""
    s = 2.4 / max(w, h)
    return max(w * s, 2.0), max(h * s, 0.9)  # wide enough for the two-line titles


def figure_sheet(rows, images, ref, ref_row, meta, exposure, out):
    modes = [m for m in ("equal_spp", "equal_time") if any(r["mode"] == m for r in rows)]
    if not modes:
        print("render_figures: note: no equal_spp or equal_time rows; figure_sheet.png skipped", file=sys.stderr)
        return
    ests = estimators_in_order(rows, set(modes))
    ncol = len(ests) + 1
    nrow = 2 * len(modes)
    h, w = ref.shape[:2]
    pw, ph = panel_size(w, h)
    title_h = 0.5
    fig_w = ncol * (pw + 0.25) + 1.35
    fig_h = nrow * (ph + title_h) + 0.7
    fig = plt.figure(figsize=(fig_w, fig_h))
    left, right = 0.4 / fig_w, 1.0 - 0.95 / fig_w
    top, bottom = 1.0 - 0.6 / fig_h, 0.1 / fig_h
    gs = fig.add_gridspec(nrow, ncol, left=left, right=right, top=top, bottom=bottom,
                          wspace=0.25 / pw, hspace=title_h / ph)
    ref_tm = tone_map(ref, exposure)
    err_norm = mcolors.Normalize(*ERR_RANGE)
    cmap = plt.get_cmap("viridis")
    err_axes = []
    for mi, mode in enumerate(modes):
        by_est = {}
        for r in rows:
            if r["mode"] == mode and r["estimator"] not in by_est:
                by_est[r["estimator"]] = r
        for c in range(ncol):
            ax_img = fig.add_subplot(gs[2 * mi, c])
            ax_err = fig.add_subplot(gs[2 * mi + 1, c])
            for ax in (ax_img, ax_err):
                ax.set_xticks([])
                ax.set_yticks([])
            if c == ncol - 1:  # the reference column
                ax_img.imshow(ref_tm, interpolation="nearest")
                t = "reference"
                if ref_row is not None and ref_row["spp"] is not None:
                    t += "\n%s spp" % fmt_spp(ref_row["spp"])
                ax_img.set_title(t, fontsize=8)
                ax_err.axis("off")
                continue
            r = by_est.get(ests[c])
            if r is None:  # frameless but not axis("off"): the row labels of column 0 stay
                for ax in (ax_img, ax_err):
                    ax.imshow(np.full(ref.shape[:2], np.nan), cmap="gray", vmin=0, vmax=1)  # same box
                    for sp in ax.spines.values():
                        sp.set_visible(False)
                ax_img.text(0.5, 0.5, "%s\n(no %s row)" % (ests[c], mode), ha="center", va="center",
                            fontsize=8, color="0.4", transform=ax_img.transAxes)
                continue
            img = images[r["image"]]
            e = rel_sq_error(img, ref)
            mse = r["rel_mse"] if r["rel_mse"] is not None else float(np.mean(e))
            ax_img.imshow(tone_map(img, exposure), interpolation="nearest")
            if mode == "equal_spp":
                t = "%s\n%s spp, rel MSE %.3g" % (r["estimator"], fmt_spp(r["spp"]), mse)
            else:
                sec = "%.3g s" % r["seconds"] if r["seconds"] is not None else "? s"
                t = "%s\n%s spp in %s, rel MSE %.3g" % (r["estimator"], fmt_spp(r["spp"]), sec, mse)
            ax_img.set_title(t, fontsize=8)
            with np.errstate(divide="ignore"):
                le = np.log10(np.maximum(e, 1e-30))
            ax_err.imshow(le, cmap=cmap, norm=err_norm, interpolation="nearest")
            ax_err.set_title("mean %.3g" % float(np.mean(e)), fontsize=7)
            err_axes.append(ax_err)
        # A label on the left of each pair of rows.
        first = fig.axes[-2 * ncol]
        first.set_ylabel("equal spp" if mode == "equal_spp" else "equal time", fontsize=9)
        fig.axes[-2 * ncol + 1].set_ylabel("rel. sq. error", fontsize=8)
    if err_axes:
        sm = plt.cm.ScalarMappable(norm=err_norm, cmap=cmap)
        cax = fig.add_axes([1.0 - 0.8 / fig_w, bottom + 0.1 * (top - bottom), 0.14 / fig_w, 0.8 * (top - bottom)])
        cb = fig.colorbar(sm, cax=cax)
        cb.set_label("log10 (img - ref)$^2$ / (ref$^2$ + eps)", fontsize=8)
        cb.ax.tick_params(labelsize=7)
    sup = "%s, %s: %dx%d" % (meta["scene"], meta["fiber"], w, h)
    if "equal_time" in modes:
        sup += ", equal time %.3g s" % float(meta["equal_time_seconds"])
    fig.suptitle(sup, fontsize=10, y=1.0 - 0.12 / fig_h, va="top")
    save(fig, os.path.join(out, "figure_sheet.png"))


def error_vs_time(rows, meta, out):
    prog = [r for r in rows if r["mode"] == "progress"]
    if not prog:
        print("render_figures: note: no progress rows; error_vs_time.png skipped", file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    markers = "osD^v<>ph*"
    rates = []
    for i, est in enumerate(estimators_in_order(prog, {"progress"})):
        pts = sorted((r["seconds"], r["rel_mse"]) for r in prog
                     if r["estimator"] == est and r["seconds"] is not None and r["rel_mse"] is not None
                     and r["seconds"] > 0 and r["rel_mse"] > 0)
        rr = [r["rays_per_second"] for r in prog if r["estimator"] == est and r["rays_per_second"]]
        rate = float(np.median(rr)) if rr else None
        if rate is not None:
            rates.append(rate)
        if not pts:
            continue
        x, y = zip(*pts)
        ax.plot(x, y, marker=markers[i % len(markers)], ms=4, lw=1.3,
                label="%s (%s rays/s)" % (est, fmt_rate(rate)))
    ax.set_xscale("log")
    ax.set_yscale("log")
    budget = float(meta["equal_time_seconds"])
    if budget > 0:
        ax.axvline(budget, color="0.3", ls="--", lw=1, label="equal-time budget %.3g s" % budget)
    ax.set_xlabel("render time [s]")
    ax.set_ylabel("relative MSE")
    ax.grid(True, which="major", alpha=0.3)
    ax.grid(True, which="minor", alpha=0.1)
    rate_s = ("%s rays/s" % fmt_rate(float(np.median(rates)))) if rates else "rays/s unknown"
    ax.set_title("%s (%s): error vs time, %s" % (meta["scene"], meta["fiber"], rate_s), fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, os.path.join(out, "error_vs_time.png"))


def stand_in_pair(rows, images):
    """The stand-in row and image and the table row and image it is compared with (the same
    estimator), or None when the render has no stand-in."""
    st = [r for r in rows if r["mode"] == "stand_in"]
    tb = [r for r in rows if r["mode"] == "table"]
    if not st or not tb:
        return None
    s_row = st[0]
    t_row = next((r for r in tb if r["estimator"] == s_row["estimator"]), tb[0])
    s, t = images[s_row["image"]], images[t_row["image"]]
    if s.shape != t.shape:
        fail("%s is %dx%d but %s is %dx%d" % (s_row["image"], s.shape[1], s.shape[0],
                                             t_row["image"], t.shape[1], t.shape[0]))
    return s_row, s, t_row, t


def relative_difference(s, t):
    """Per pixel |s - t| / (t + 0.1 mean t), averaged over the channels."""
    diff = np.abs(s - t) / (np.abs(t) + 0.1 * abs(float(np.mean(t))))
    return np.where(s == t, 0.0, diff).mean(axis=2)


def stand_in(rows, images, meta, exposure, out):
    pair = stand_in_pair(rows, images)
    if pair is None:
        return
    s_row, s, t_row, t = pair
    diff = relative_difference(s, t)
    mean_diff = float(np.mean(diff))
    h, w = t.shape[:2]
    pw, ph = panel_size(w, h)
    fig_w, fig_h = 3 * (pw + 0.3) + 1.0, ph + 1.05
    fig = plt.figure(figsize=(fig_w, fig_h))
    gs = fig.add_gridspec(1, 3, left=0.15 / fig_w, right=1.0 - 0.95 / fig_w, top=1.0 - 0.85 / fig_h,
                          bottom=0.15 / fig_h, wspace=0.3 / pw)
    axes = [fig.add_subplot(gs[0, i]) for i in range(3)]
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    tb_bytes, mix_bytes, full = int(meta["table_bytes"]), int(meta["mixture_bytes"]), int(meta["full_table_bytes"])
    axes[0].imshow(tone_map(t, exposure), interpolation="nearest")
    axes[0].set_title("table (%s)\n%s in %s/%s slices\n(full table %s)"
                      % (t_row["estimator"], fmt_bytes(tb_bytes), meta["slices_needed"],
                         meta["slices_total"], fmt_bytes(full)), fontsize=8)
    axes[1].imshow(tone_map(s, exposure), interpolation="nearest")
    ratio = ("{:,.0f}x".format(full / mix_bytes) if full >= 100 * mix_bytes else "%.3gx" % (full / mix_bytes)) \
        if mix_bytes > 0 else "?"
    ratio += " smaller than the full table"
    axes[1].set_title("mixture stand-in (%s)\n%s\n%s" % (s_row["estimator"], fmt_bytes(mix_bytes), ratio),
                      fontsize=8)
    norm = mcolors.Normalize(*DIFF_RANGE)
    with np.errstate(divide="ignore"):
        im = axes[2].imshow(np.log10(np.maximum(diff, 1e-30)), cmap="magma", norm=norm, interpolation="nearest")
    if "stand_in_difference_4x4" in meta:
        axes[2].set_title("sum |s - t| / sum t: %.2f %% (pixels),\n%.2f %% (4 x 4 blocks; noise floor %.2f %%)"
                          % (100 * float(meta["stand_in_difference"]), 100 * float(meta["stand_in_difference_4x4"]),
                             100 * float(meta.get("table_noise_4x4", 0.0))), fontsize=8)
    else:
        axes[2].set_title("relative difference\nmean %.3g" % mean_diff, fontsize=8)
    cax = fig.add_axes([1.0 - 0.8 / fig_w, 0.15 / fig_h, 0.12 / fig_w, 1.0 - 1.0 / fig_h])
    cb = fig.colorbar(im, cax=cax)
    cb.set_label("log10 |s - t| / (t + 0.1 mean t)", fontsize=7)
    cb.ax.tick_params(labelsize=7)
    fig.suptitle("%s, %s: stand-in vs table" % (meta["scene"], meta["fiber"]), fontsize=10,
                 y=1.0 - 0.08 / fig_h, va="top")
    save(fig, os.path.join(out, "stand_in.png"))


# What each estimator draws a fiber's next direction from (docs/render.md, "Estimators"),
# and the ones that sample with the mixtures.
KIND = {"uniform": "uniform", "mis_tab": "mixture", "cdf_tab": "table CDF",
        "mis_light_cdf": "table CDF + light samples", "mis_light_gmm": "mixture + light samples",
        "mis_product": "mixture x lighting + light samples", "guided": "learnt radiance + light samples",
        "guided_product": "learnt radiance x mixture + light samples", "is_rgl": "the RGL file's warps",
        "mis_light_rgl": "the RGL file's warps + light samples"}
WITH_MIXTURE = {"mis_tab", "mis_light_gmm", "mis_product", "guided", "guided_product"}


def fmt_ratio(x):
    if not (x > 0 and math.isfinite(x)):
        return "?"
    return "{:,.0f}x".format(x) if x >= 10 else "%.2gx" % x


def equal_time_ranking(rows):
    """[(estimator, rel MSE)] of the equal_time rows, the least error first."""
    eq = {}
    for r in rows:
        if r["mode"] == "equal_time" and r["rel_mse"] is not None and r["estimator"] not in eq:
            eq[r["estimator"]] = r["rel_mse"]
    return sorted(eq.items(), key=lambda x: x[1])


def equal_time_verdict(ranking, budget):
    """Which estimator has the least error at equal time and by how much: two or three lines."""
    if not ranking:
        return "error against time (no equal-time rows)"
    best, m = ranking[0]
    lines = ["At equal time (%.3g s) %s has the least error, relative MSE %.3g" % (budget, best, m)]
    if len(ranking) > 1:
        below = ["%s less than %s (next)" % (fmt_ratio(ranking[1][1] / m), ranking[1][0])]
        if len(ranking) > 2:
            below.append("%s less than %s (last)" % (fmt_ratio(ranking[-1][1] / m), ranking[-1][0]))
        lines.append(", ".join(below))
        mixture = best in WITH_MIXTURE
        other = next(((e, x) for e, x in ranking[1:] if (e in WITH_MIXTURE) != mixture), None)
        if other is not None:
            lines.append("the best %s, %s: %s %s's error" % (
                "with the table alone" if mixture else "with the mixtures", other[0], fmt_ratio(other[1] / m), best))
    return "\n".join(lines)


def summary(rows, images, ref, meta, exposure, path):
    """One figure for a first look: the cloth with the table and with the mixtures, their
    memory and difference, and every estimator's error against time with the one that
    wins at equal time."""
    pair = stand_in_pair(rows, images)
    prog = [r for r in rows if r["mode"] == "progress"]
    budget = float(meta["equal_time_seconds"])
    h, w = ref.shape[:2]
    fig = plt.figure(figsize=(10.0, 8.0))
    gs = fig.add_gridspec(1, 3, left=0.03, right=0.89, top=0.86, bottom=0.5, wspace=0.14)
    gs_plot = fig.add_gridspec(1, 1, left=0.08, right=0.62, top=0.38, bottom=0.07)
    tb_bytes, mix_bytes = int(meta["table_bytes"]), int(meta["mixture_bytes"])
    full = int(meta["full_table_bytes"])
    vs_table = tb_bytes / mix_bytes if mix_bytes > 0 else float("nan")
    vs_full = full / mix_bytes if mix_bytes > 0 else float("nan")
    head = "%s, %s, %d x %d" % (meta["fiber"], meta["scene"], w, h)
    if pair is not None:
        s_row, s, t_row, t = pair
        diff = relative_difference(s, t)
        axes = [fig.add_subplot(gs[0, i]) for i in range(3)]
        for ax in axes:
            ax.set_xticks([])
            ax.set_yticks([])
        spp = "%s spp, %s" % (fmt_spp(t_row["spp"]), t_row["estimator"])
        axes[0].imshow(tone_map(t, exposure), interpolation="nearest")
        axes[0].set_title("rendered with the table\n%s (full 4D table: %s)\n%s"
                          % (fmt_bytes(tb_bytes), fmt_bytes(full), spp), fontsize=8.5)
        slices = "" if meta["slices_needed"] == meta["slices_total"] else \
            " (%s of %s slices)" % (meta["slices_needed"], meta["slices_total"])
        axes[1].imshow(tone_map(s, exposure), interpolation="nearest")
        axes[1].set_title("rendered with the mixtures (stand-in)\n%s%s: %s less than the table,\n%s less than the full 4D table"
                          % (fmt_bytes(mix_bytes), slices, fmt_ratio(vs_table), fmt_ratio(vs_full)), fontsize=8.5)
        norm = mcolors.Normalize(*DIFF_RANGE)
        with np.errstate(divide="ignore"):
            im = axes[2].imshow(np.log10(np.maximum(diff, 1e-30)), cmap="magma", norm=norm, interpolation="nearest")
        if "stand_in_difference_4x4" in meta and "table_noise_4x4" in meta:
            d4, n4 = 100 * float(meta["stand_in_difference_4x4"]), 100 * float(meta["table_noise_4x4"])
            axes[2].set_title("their difference: %.2g %% (4 x 4 blocks)\nthe table image's own noise: %.2g %%\n"
                              "(against the reference)" % (d4, n4), fontsize=8.5)
            verdict = "within the table image's own noise" if d4 <= n4 else "%.2g %% from the table image" % d4
        else:
            axes[2].set_title("their difference\nmean %.3g" % float(np.mean(diff)), fontsize=8.5)
            verdict = "mean difference %.3g" % float(np.mean(diff))
        cb = fig.colorbar(im, cax=axes[2].inset_axes([1.04, 0.0, 0.05, 1.0]))
        cb.set_label("log10 |s - t| / (t + 0.1 mean t)", fontsize=7)
        cb.ax.tick_params(labelsize=7)
        sup = "%s: the mixtures render the same cloth in %s less memory than the table, %s" % (
            head, fmt_ratio(vs_table), verdict)
    else:
        ax = fig.add_subplot(gs[0, 1])
        ax.set_xticks([])
        ax.set_yticks([])
        ax.imshow(tone_map(ref, exposure), interpolation="nearest")
        ax.set_title("the reference\n(no stand-in render: render.stand_in is false)", fontsize=8.5)
        sup = "%s: the estimators against the reference" % head

    ax = fig.add_subplot(gs_plot[0, 0])
    markers = "osD^v<>ph*"
    ests = estimators_in_order(rows, {"progress", "equal_time"})
    eq = {r["estimator"]: r for r in rows if r["mode"] == "equal_time"}
    for i, est in enumerate(ests):
        pts = sorted((r["seconds"], r["rel_mse"]) for r in prog
                     if r["estimator"] == est and r["seconds"] is not None and r["rel_mse"] is not None
                     and r["seconds"] > 0 and r["rel_mse"] > 0)
        label = "%s: %s" % (est, KIND[est]) if est in KIND and KIND[est] != est else est
        color = None
        if pts:
            x, y = zip(*pts)
            (line,) = ax.plot(x, y, marker=markers[i % len(markers)], ms=3.5, lw=1.3, label=label)
            color, label = line.get_color(), None
        e = eq.get(est)
        if e is not None and e["seconds"] and e["rel_mse"]:
            ax.plot([e["seconds"]], [e["rel_mse"]], marker="*", ms=11, ls="none", color=color,
                    markeredgecolor="black", markeredgewidth=0.6, label=label)
    if budget > 0:
        ax.axvline(budget, color="0.3", ls="--", lw=1)
        ax.plot([], [], marker="*", ms=9, ls="none", color="0.7", markeredgecolor="black", markeredgewidth=0.6,
                label="equal time: each estimator's image\nafter %.3g s (dashed line)" % budget)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("render time [s]")
    ax.set_ylabel("relative MSE against the reference")
    ax.grid(True, which="major", alpha=0.3)
    ax.grid(True, which="minor", alpha=0.1)
    ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              title="next direction at a fiber", title_fontsize=7.5)
    ax.set_title(equal_time_verdict(equal_time_ranking(rows), budget), fontsize=9, loc="left")
    fig.suptitle(sup, fontsize=10.5, y=0.985, va="top", wrap=True)
    d = os.path.dirname(path)
    if d:
        try:
            os.makedirs(d, exist_ok=True)
        except OSError as e:
            fail("cannot create %s: %s" % (d, e.strerror or e))
    save(fig, path)


# ---------------------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description="Figures of a `bsdfmix render` run.")
    ap.add_argument("--dir", required=True, help="the render's output directory (render.csv, render.json)")
    ap.add_argument("-o", "--out", help="where the figures go (default DIR/figures)")
    ap.add_argument("--summary", help="the one-figure summary's path (default OUT/summary.png)")
    args = ap.parse_args()
    d = args.dir
    out = args.out or os.path.join(d, "figures")
    if not os.path.isdir(d):
        fail("missing directory %s" % d)
    rows, meta = read_inputs(d)

    # Every image the rows name, read once (through its PFM), plus the reference.
    images = {}
    for r in rows:
        if r["image"] and r["image"] not in images:
            images[r["image"]] = read_pfm(pfm_of(d, r["image"]))
    ref_rows = [r for r in rows if r["mode"] == "reference"]
    ref_row = ref_rows[0] if ref_rows else None
    ref_name = ref_row["image"] if ref_row else str(meta["reference"])
    if ref_name not in images:
        images[ref_name] = read_pfm(pfm_of(d, ref_name))
    ref = images[ref_name]
    for name, img in images.items():
        if img.shape != ref.shape and name != ref_name:
            fail("%s is %dx%d but the reference %s is %dx%d"
                 % (name, img.shape[1], img.shape[0], ref_name, ref.shape[1], ref.shape[0]))

    # Tone-mapped images beside their PFMs; one exposure per scene, for the cloth of its reference.
    mask_path = os.path.join(d, "cloth_mask.pfm")
    mask = luminance(read_pfm(mask_path)) > 0.5 if os.path.exists(mask_path) else None
    exposure = exposure_for(ref, mask)
    scene_exposure = {}
    for r in ref_rows:
        scene_exposure.setdefault(r["scene"], exposure_for(images[r["image"]], mask))
    for name in images:
        scene = next((r["scene"] for r in rows if r["image"] == name), meta["scene"])
        p = os.path.splitext(pfm_of(d, name))[0] + ".png"
        write_rgb_png(p, tone_map(images[name], scene_exposure.get(scene, exposure)))
        print(p)

    try:
        os.makedirs(out, exist_ok=True)
    except OSError as e:
        fail("cannot create %s: %s" % (out, e.strerror or e))
    figure_sheet(rows, images, ref, ref_row, meta, exposure, out)
    error_vs_time(rows, meta, out)
    stand_in(rows, images, meta, exposure, out)
    summary(rows, images, ref, meta, exposure, args.summary or os.path.join(out, "summary.png"))


if __name__ == "__main__":
    main()
