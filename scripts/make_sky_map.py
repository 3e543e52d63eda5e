#!/usr/bin/python3
"""A clear-sky lat-long environment map (luminance, PFM) from the Preetham sky model.

Model: A. J. Preetham, P. Shirley, B. Smits, "A Practical Analytic Model for Daylight",
SIGGRAPH 1999. Only the luminance Y is computed (one channel):

  Y(theta, gamma) = Y_z F(theta, gamma) / F(0, theta_s)
  F(theta, gamma) = (1 + A exp(B / cos theta)) (1 + C exp(D gamma) + E cos^2 gamma)

theta is the view direction's angle from the zenith (+z), gamma its angle to the sun,
theta_s the sun's angle from the zenith. The Perez coefficients for Y are the paper's
(appendix), linear in the turbidity T:

  A = 0.1787 T - 1.4630    B = -0.3554 T + 0.4275    C = -0.0227 T + 5.3251
  D = 0.1206 T - 2.5771    E = -0.0670 T + 0.3703

and the zenith luminance (kcd/m^2) is
  chi = (4/9 - T/120) (pi - 2 theta_s)
  Y_z = (4.0453 T - 4.9710) tan(chi) - 0.2155 T + 2.4192.

Below the horizon (z < 0) the map is a dim constant ground: 0.1 x the sky luminance
averaged over azimuth at the horizon (theta = pi/2, where exp(B / cos theta) -> 0).

The sun is a disc of angular radius --sun-radius-deg (default 1 degree, larger than the
real sun's 0.27 degrees so that it spans a few pixels at 512 x 256) of uniform radiance
--sun-to-sky x Y_z. It replaces the sky where it covers a pixel; its coverage of each
pixel is the share of a 4 x 4 grid of sub-pixel directions inside the disc, which gives
an antialiased edge about one pixel wide.

The whole map is then scaled so that its solid-angle-weighted mean over the sphere is 1.

Layout (the project's reader, host/io/pfm.cpp read_pfm, and
host/sampling/lighting.cpp radiance_world): "Pf" (greyscale), "W H", "-1.0" (little
endian), then float32 rows. Image row y covers the polar angle acos(w.z) in
[pi y / H, pi (y + 1) / H) (row 0 at +z); column x covers the azimuth atan2(w.y, w.x) in
[-pi + 2 pi x / W, -pi + 2 pi (x + 1) / W). As in standard PFM the file stores the rows
bottom-up: the reader takes file row h - 1 - y as image row y, so image row H - 1 (-z) is
written first and image row 0 (+z) last.

  scripts/make_sky_map.py [--out data/sky_preetham.pfm] [--width 512 --height 256]
      [--turbidity 3] [--sun-elevation-deg 35] [--sun-azimuth-deg 40]
      [--sun-radius-deg 1] [--sun-to-sky 40000]
  scripts/make_sky_map.py --check [--out data/sky_preetham.pfm] [same model arguments]

--check reads the file back (pure Python, no numpy) in the reader's row order and checks
the solid-angle-weighted mean (1 within 1e-3), that the brightest pixel lies on the sun,
and that the ground is constant; it also reads data/envmap_synthetic.pfm (if present) to
confirm the row order against that file's documented peak.
"""

import argparse
import math
import os
import struct
import sys

import numpy as np


def perez_coefficients(T):
    return (0.1787 * T - 1.4630, -0.3554 * T + 0.4275, -0.0227 * T + 5.3251,
            0.1206 * T - 2.5771, -0.0670 * T + 0.3703)


def perez(theta, gamma, coef):
    """F(theta, gamma); exp(B / cos theta) -> 0 at the horizon (B < 0 for T > 1.2)."""
    A, B, C, D, E = coef
    cos_t = np.cos(theta)
    with np.errstate(divide="ignore", over="ignore"):
        e = np.where(cos_t > 1e-6, np.exp(B / np.maximum(cos_t, 1e-6)), 0.0)
    return (1 + A * e) * (1 + C * np.exp(D * gamma) + E * np.cos(gamma) ** 2)


def zenith_luminance(T, theta_s):
    chi = (4.0 / 9.0 - T / 120.0) * (math.pi - 2 * theta_s)
    return (4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192


def sun_direction(elev_deg, azim_deg):
    el, az = math.radians(elev_deg), math.radians(azim_deg)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def directions(polar, azimuth):
    st = np.sin(polar)
    return np.stack([st * np.cos(azimuth), st * np.sin(azimuth), np.cos(polar)], axis=-1)


def pixel_solid_angles(W, H):
    """Exact solid angle of each row's pixels: (2 pi / W) (cos theta_0 - cos theta_1)."""
    edges = np.pi * np.arange(H + 1) / H
    return (2 * np.pi / W) * (np.cos(edges[:-1]) - np.cos(edges[1:]))


def build(args):
    W, H, T = args.width, args.height, args.turbidity
    if H % 2:
        sys.exit("--height must be even (the horizon is a row boundary)")
    if not 1.2 < T < 20:
        sys.exit("--turbidity outside the model's range (1.2 < T < 20 here)")
    theta_s = math.radians(90.0 - args.sun_elevation_deg)
    sun = sun_direction(args.sun_elevation_deg, args.sun_azimuth_deg)
    coef = perez_coefficients(T)
    Yz = zenith_luminance(T, theta_s)
    F0 = float(perez(np.array(0.0), np.array(theta_s), coef))

    def sky(d):
        polar = np.arccos(np.clip(d[..., 2], -1, 1))
        gamma = np.arccos(np.clip(d @ sun, -1, 1))
        return Yz * perez(polar, gamma, coef) / F0

    # pixel centres (image row 0 at +z, column 0 at azimuth -pi)
    polar_c = np.pi * (np.arange(H) + 0.5) / H
    azim_c = -np.pi + 2 * np.pi * (np.arange(W) + 0.5) / W
    P, A = np.meshgrid(polar_c, azim_c, indexing="ij")
    L = sky(directions(P, A))

    # ground: 0.1 x the sky's mean luminance at the horizon (theta = pi/2), over azimuth
    az_fine = -np.pi + 2 * np.pi * (np.arange(4096) + 0.5) / 4096
    horizon = sky(directions(np.full_like(az_fine, np.pi / 2), az_fine))
    ground = 0.1 * float(horizon.mean())
    L[H // 2:, :] = ground

    # the sun disc: coverage by 4 x 4 sub-pixel directions, only near the sun
    cos_r = math.cos(math.radians(args.sun_radius_deg))
    L_sun = args.sun_to_sky * Yz
    cov = np.zeros((H, W))
    margin = math.radians(args.sun_radius_deg) + 2 * max(math.pi / H, 2 * math.pi / W)  # > half a pixel diagonal
    near = np.arccos(np.clip(directions(P, A) @ sun, -1, 1)) < margin
    sub = (np.arange(4) + 0.5) / 4
    for y, x in zip(*np.nonzero(near)):
        sp = np.pi * (y + sub) / H
        sa = -np.pi + 2 * np.pi * (x + sub) / W
        SP, SA = np.meshgrid(sp, sa, indexing="ij")
        cov[y, x] = np.mean(directions(SP, SA) @ sun >= cos_r)
    if cov.sum() == 0:
        sys.exit("the sun disc covers no sub-pixel: increase --sun-radius-deg")
    L = (1 - cov) * L + cov * L_sun

    dO = pixel_solid_angles(W, H)[:, None]
    total = float((L * dO).sum())
    sun_power = float((cov * L_sun * dO).sum())
    scale = 4 * np.pi / total  # mean over the sphere = total / (4 pi) -> 1
    L = (L * scale).astype(np.float32)
    info = dict(Yz=Yz, F0=F0, coef=coef, ground=ground, ground_scaled=ground * scale,
                sun=sun, sun_share=sun_power / total, scale=scale, L_sun=L_sun * scale,
                sun_pixels=int(np.count_nonzero(cov)), full_pixels=int(np.count_nonzero(cov == 1)),
                sun_solid_angle=float((cov * dO).sum()),
                disc_solid_angle=2 * math.pi * (1 - cos_r))
    return L, info


def write_pfm(path, img):
    H, W = img.shape
    d = os.path.dirname(path)
    if d:
        os.makedirs(d, exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(b"Pf\n%d %d\n-1.0\n" % (W, H))
        # bottom-up, as the project's reader (io/pfm.cpp read_pfm) expects: image row H - 1 first
        f.write(np.ascontiguousarray(img[::-1, :]).astype("<f4").tobytes())
    os.replace(tmp, path)


# ---- the check: an independent pure-Python reader and quadrature -----------------------

def read_pfm_like_project(path):
    """Greyscale PFM as the project reads it: returns (W, H, rows), rows[y] = image row y,
    row 0 at +z; file row h - 1 - y is image row y."""
    with open(path, "rb") as f:
        data = f.read()
    tokens, pos = [], 0
    while len(tokens) < 4:  # magic, W, H, scale, separated by whitespace
        while data[pos:pos + 1].isspace():
            pos += 1
        start = pos
        while not data[pos:pos + 1].isspace():
            pos += 1
        tokens.append(data[start:pos].decode("ascii"))
    pos += 1  # the single whitespace byte after the header
    magic, W, H, s = tokens[0], int(tokens[1]), int(tokens[2]), float(tokens[3])
    if magic != "Pf":
        raise ValueError("%s: expected a greyscale 'Pf' PFM, got %r" % (path, magic))
    fmt = ("<" if s < 0 else ">") + "%df" % W
    file_rows = [struct.unpack_from(fmt, data, pos + 4 * W * r) for r in range(H)]
    if len(data) != pos + 4 * W * H:
        raise ValueError("%s: %d bytes of data, expected %d" % (path, len(data) - pos, 4 * W * H))
    return W, H, [file_rows[H - 1 - y] for y in range(H)]


def pixel_direction(x, y, W, H):
    polar = math.pi * (y + 0.5) / H
    az = -math.pi + 2 * math.pi * (x + 0.5) / W
    return (math.sin(polar) * math.cos(az), math.sin(polar) * math.sin(az), math.cos(polar))


def check(args):
    ok = True
    W, H, rows = read_pfm_like_project(args.out)
    print("check: %s: %d x %d" % (args.out, W, H))
    if (W, H) != (args.width, args.height):
        print("check FAILED: size %d x %d, expected %d x %d" % (W, H, args.width, args.height))
        ok = False
    # solid-angle-weighted mean by the midpoint rule in the polar angle:
    # dOmega ~ sin(theta_c) (pi / H) (2 pi / W), independent of the generator's exact band areas
    acc = 0.0
    for y in range(H):
        acc += math.fsum(rows[y]) * math.sin(math.pi * (y + 0.5) / H)
    mean = acc * (math.pi / H) * (2 * math.pi / W) / (4 * math.pi)
    lo = min(min(r) for r in rows)
    hi = max(max(r) for r in rows)
    print("check: min %.6g  max %.6g  solid-angle-weighted mean %.6f" % (lo, hi, mean))
    if abs(mean - 1.0) > 1e-3:
        print("check FAILED: mean %.6f is not 1 within 1e-3" % mean)
        ok = False
    # the brightest pixel must lie on the sun (orientation and row order)
    yb, xb = max(((y, x) for y in range(H) for x in range(W)), key=lambda p: rows[p[0]][p[1]])
    d = pixel_direction(xb, yb, W, H)
    el, az = math.radians(args.sun_elevation_deg), math.radians(args.sun_azimuth_deg)
    s = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
    ang = math.degrees(math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(d, s))))))
    print("check: brightest pixel (x %d, y %d), direction (%.4f, %.4f, %.4f), %.3f deg from the sun"
          % (xb, yb, d[0], d[1], d[2], ang))
    if ang > args.sun_radius_deg:
        print("check FAILED: the brightest pixel is not inside the sun disc")
        ok = False
    # the ground (image rows H/2 .. H-1, z < 0) is one constant
    g = {v for y in range(H // 2, H) for v in rows[y]}
    print("check: ground values below the horizon: %s" % sorted(g)[:3])
    if len(g) != 1:
        print("check FAILED: the ground is not constant")
        ok = False
    # the row order of the reader, against the project's synthetic map: its value is largest
    # near 60 degrees from +z at azimuth 0.8 rad (data/envmap_synthetic.PROVENANCE.md)
    ref = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "envmap_synthetic.pfm")
    if os.path.exists(ref):
        W2, H2, r2 = read_pfm_like_project(ref)
        yb, xb = max(((y, x) for y in range(H2) for x in range(W2)), key=lambda p: r2[p[0]][p[1]])
        polar = math.degrees(math.pi * (yb + 0.5) / H2)
        azim = -math.pi + 2 * math.pi * (xb + 0.5) / W2
        good = abs(polar - 60) < 180.0 / H2 + 1e-9 and abs(azim - 0.8) < 2 * math.pi / W2
        print("check: envmap_synthetic.pfm read in the same order peaks at polar %.1f deg, "
              "azimuth %.3f rad (documented: 60 deg, 0.8 rad): %s" % (polar, azim, "ok" if good else "MISMATCH"))
        ok &= good
    print("check: %s" % ("passed" if ok else "FAILED"))
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="data/sky_preetham.pfm")
    ap.add_argument("--width", type=int, default=512)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--turbidity", type=float, default=3.0)
    ap.add_argument("--sun-elevation-deg", type=float, default=35.0)
    ap.add_argument("--sun-azimuth-deg", type=float, default=40.0)
    ap.add_argument("--sun-radius-deg", type=float, default=1.0,
                    help="angular radius of the sun disc (real sun: 0.27; 1 so it spans a few pixels)")
    ap.add_argument("--sun-to-sky", type=float, default=40000.0,
                    help="sun disc radiance over the zenith luminance Y_z")
    ap.add_argument("--check", action="store_true",
                    help="read --out back and check it (does not write)")
    args = ap.parse_args()
    if args.check:
        sys.exit(0 if check(args) else 1)

    L, info = build(args)
    write_pfm(args.out, L)
    s = info["sun"]
    A, B, C, D, E = info["coef"]
    print("turbidity %.3g: Perez Y coefficients A %.4f B %.4f C %.4f D %.4f E %.4f"
          % (args.turbidity, A, B, C, D, E))
    print("zenith luminance Y_z %.4f kcd/m^2 (sun %.1f deg from zenith), F(0, theta_s) %.4f"
          % (info["Yz"], 90 - args.sun_elevation_deg, info["F0"]))
    print("sun direction (%.6f, %.6f, %.6f)" % tuple(s))
    print("sun disc: radius %.3g deg, solid angle %.4e sr (pixel coverage sums to %.4e sr), "
          "%d pixels touched, %d fully covered"
          % (args.sun_radius_deg, info["disc_solid_angle"], info["sun_solid_angle"],
             info["sun_pixels"], info["full_pixels"]))
    print("sun radiance %.6g (sun-to-sky %.6g x Y_z), ground %.6g (0.1 x mean horizon luminance)"
          % (info["L_sun"], args.sun_to_sky, info["ground_scaled"]))
    print("sun power share %.4f" % info["sun_share"])
    print("scale %.6e (from kcd/m^2 to a mean of 1 over the sphere)" % info["scale"])
    dO = pixel_solid_angles(*L.shape[::-1])[:, None]
    print("min %.6g  max %.6g  mean %.6f" % (L.min(), L.max(), float((L * dO).sum()) / (4 * np.pi)))
    print("wrote %s (%d x %d, %d bytes)" % (args.out, L.shape[1], L.shape[0], os.path.getsize(args.out)))


if __name__ == "__main__":
    main()
