#!/usr/bin/python3
"""Regenerates the binary files of the bad-input corpus (tests/data/bad/).

    /usr/bin/python3 tests/data/bad/make_corpus.py

Needs h5py and numpy (Debian: python3-h5py, python3-numpy). The output is
deterministic up to HDF5's own bytes (library version), so regenerating
may change the .h5 files byte-wise without changing what they test. The YAML
configs and cases.txt are written by hand and are not touched here.

Every malformed file is derived from a small well-formed one (ok_table.h5,
ok_mixture.h5, ok_rgl.bsdf) that the test also runs, so a failure of a bad
case is due to its one defect. ok_rgl.bsdf is data/rgl/paper_white_rgb.bsdf
with its grids subsampled, to stay small.
"""
import math
import os
import struct

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
PI = math.pi


def path(name):
    return os.path.join(HERE, name)


def centers(lo, hi, n):
    step = (hi - lo) / n
    return np.array([lo + (i + 0.5) * step for i in range(n)], dtype=np.float64)


# ------------------------------------------------------------------ tables

N_TO, N_TI, N_PI = 2, 4, 8


def table_arrays():
    theta_o = centers(-PI / 2, PI / 2, N_TO)
    theta_i = centers(-PI / 2, PI / 2, N_TI)
    phi_i = centers(-PI, PI, N_PI)
    rng = np.random.default_rng(7)
    values = (0.1 + rng.random((N_TO, 1, N_TI, N_PI))).astype(np.float32)
    return {
        "theta_o": theta_o,
        "phi_o": np.array([0.0]),
        "theta_i": theta_i,
        "phi_i": phi_i,
        "values": values,
    }


def write_table(name, mutate=None, attrs_mutate=None):
    a = table_arrays()
    attrs = {
        "domain": "fiber",
        "symmetry": "azimuthal",
        "source": '{"model": "badinput-corpus"}',
    }
    if mutate:
        mutate(a)
    if attrs_mutate:
        attrs_mutate(attrs)
    with h5py.File(path(name), "w", libver="earliest") as f:
        g = f.create_group("table")
        for axis in ("theta_o", "phi_o", "theta_i", "phi_i"):
            if a.get(axis) is not None:
                g.create_dataset(axis, data=a[axis])
        v = a["values"]
        if v is not None:
            chunks = tuple([1] * max(0, v.ndim - 2) + list(v.shape[-2:])) if v.ndim >= 2 else None
            g.create_dataset("values", data=v, chunks=chunks)
        for k, val in attrs.items():
            if val is not None:
                g.attrs[k] = val


def set_cell(value):
    def m(a):
        a["values"][1, 0, 2, 5] = value
    return m


def make_tables():
    write_table("ok_table.h5")
    write_table("table_nan.h5", set_cell(np.nan))
    write_table("table_inf.h5", set_cell(np.inf))
    write_table("table_negative.h5", set_cell(-0.5))

    def rank3(a):
        a["values"] = a["values"].reshape(N_TO, N_TI, N_PI)
    write_table("table_rank3.h5", rank3)

    def shape(a):  # 7 phi_i cells stored, the axis says 8
        a["values"] = np.ascontiguousarray(a["values"][:, :, :, :7])
    write_table("table_shape.h5", shape)

    def nonuniform(a):
        a["theta_i"] = a["theta_i"].copy()
        a["theta_i"][2] += 0.1
    write_table("table_nonuniform.h5", nonuniform)

    def out_of_domain(a):  # theta_i shifted past pi/2
        a["theta_i"] = a["theta_i"] + 0.5
    write_table("table_out_of_domain.h5", out_of_domain)

    def phi_period(a):  # phi_i covers half the period
        a["phi_i"] = centers(-PI, 0.0, N_PI)
    write_table("table_phi_period.h5", phi_period)

    def nan_axis(a):
        a["theta_o"] = a["theta_o"].copy()
        a["theta_o"][1] = np.nan
    write_table("table_nan_axis.h5", nan_axis)

    def no_values(a):
        a["values"] = None
    write_table("table_no_values.h5", no_values)

    def int_values(a):
        a["values"] = (a["values"] * 100).astype(np.int32)
    write_table("table_int_values.h5", int_values)

    def no_axis(a):
        a["phi_i"] = None
    write_table("table_missing_axis.h5", no_axis)

    def no_domain(at):
        at["domain"] = None
    write_table("table_missing_domain.h5", attrs_mutate=no_domain)

    def unknown_domain(at):
        at["domain"] = "sphere"
    write_table("table_unknown_domain.h5", attrs_mutate=unknown_domain)

    def newline_domain(at):  # a control character in a value echoed in the message
        at["domain"] = "fib\ner"
    write_table("table_newline_domain.h5", attrs_mutate=newline_domain)

    def domain_array(at):  # 40 variable-length strings where one belongs
        at["domain"] = ["fiber"] * 40
    write_table("table_domain_array.h5", attrs_mutate=domain_array)

    def symmetry_fixed_array(at):  # 40 fixed-length strings where one belongs
        at["symmetry"] = np.array([b"azimuthal"] * 40, dtype="S9")
    write_table("table_symmetry_array.h5", attrs_mutate=symmetry_fixed_array)

    def unknown_symmetry(at):
        at["symmetry"] = "mirror"
    write_table("table_unknown_symmetry.h5", attrs_mutate=unknown_symmetry)

    def numeric_domain(at):
        at["domain"] = np.float64(1.0)
    write_table("table_numeric_domain.h5", attrs_mutate=numeric_domain)

    # theta_o claims 2^34 elements that were never written (an 11 KiB file).
    def huge_axis(a):
        a["theta_o"] = None
    write_table("table_huge_axis.h5", huge_axis)
    with h5py.File(path("table_huge_axis.h5"), "a") as f:
        f["table"].create_dataset("theta_o", shape=(1 << 34,), dtype="f8")

    # A file without /table (a mixture given where a table is expected).
    with h5py.File(path("table_no_group.h5"), "w", libver="earliest") as f:
        f.create_group("other")

    ok = open(path("ok_table.h5"), "rb").read()
    # Cut in half: the superblock's end-of-file address lies beyond the end.
    open(path("table_truncated.h5"), "wb").write(ok[: len(ok) // 2])
    # Bytes overwritten in the middle of the metadata: the object headers and
    # B-tree nodes that h5py writes before the raw data. The overwritten range
    # is found as the first metadata block after the superblock (byte 800 on).
    bad = bytearray(ok)
    start = 800
    for k in range(start, start + 512):
        bad[k] = (k * 37 + 11) & 0xFF
    open(path("table_corrupt.h5"), "wb").write(bytes(bad))
    with open(path("table_text.h5"), "w") as f:
        f.write("theta_o,phi_o,theta_i,phi_i,value\n0,0,0,0,1.0\n")
    open(path("table_empty.h5"), "wb").close()


# ------------------------------------------------------------------ mixtures


def mixture_arrays():
    theta_o = centers(-PI / 2, PI / 2, N_TO)
    return {
        "theta_o": theta_o,
        "phi_o": np.zeros(N_TO),
        "k": np.array([2, 1], dtype=np.int32),
        "weights": np.array([[0.5, 0.5], [1.0, 0.0]], dtype=np.float32),
        "means": np.array([[[0.1, 0.0], [-0.2, 1.0]], [[0.0, -1.0], [0.0, 0.0]]], dtype=np.float32),
        "covariances": np.array([[[0.05, 0.01, 0.2], [0.1, 0.0, 0.1]], [[0.2, 0.0, 0.3], [0, 0, 0]]],
                                dtype=np.float32),
        "scale": np.array([1.0, 2.0]),
        "loglik": np.array([-1.0, -2.0]),
        "l1_rel": np.array([0.1, 0.2]),
        "table_theta_o": theta_o,
        "table_phi_o": np.array([0.0]),
    }


def write_mixture(name, mutate=None):
    a = mixture_arrays()
    if mutate:
        mutate(a)
    with h5py.File(path(name), "w", libver="earliest") as f:
        g = f.create_group("mixture")
        for k, v in a.items():
            if v is not None:
                g.create_dataset(k, data=v)
        g.attrs["domain"] = "fiber"
        g.attrs["symmetry"] = "azimuthal"
        g.attrs["table_source"] = '{"model": "badinput-corpus"}'
        g.attrs["fit_settings"] = "{}"


def make_mixtures():
    write_mixture("ok_mixture.h5")

    def weights_rank(a):
        a["weights"] = a["weights"].reshape(-1)
    write_mixture("mix_weights_rank.h5", weights_rank)

    def means_shape(a):
        a["means"] = np.zeros((2, 2, 3), dtype=np.float32)
    write_mixture("mix_means_shape.h5", means_shape)

    def cov_shape(a):
        a["covariances"] = np.ones((2, 3, 3), dtype=np.float32)
    write_mixture("mix_cov_shape.h5", cov_shape)

    def not_pd(a):  # s_tp^2 > s_tt * s_pp
        a["covariances"][1, 0] = [0.1, 0.5, 0.1]
    write_mixture("mix_cov_not_pd.h5", not_pd)

    def weights_sum(a):
        a["weights"][0] = [0.5, 0.2]
    write_mixture("mix_weights_sum.h5", weights_sum)

    def k_zero(a):
        a["k"] = np.array([2, 0], dtype=np.int32)
    write_mixture("mix_k_zero.h5", k_zero)

    def nan_mean(a):
        a["means"][0, 1, 0] = np.nan
    write_mixture("mix_nan_mean.h5", nan_mean)

    def means_rank2(a):  # [S, 2 Kmax]: as many elements as [S, Kmax, 2]
        a["means"] = a["means"].reshape(2, 4)
    write_mixture("mix_means_rank2.h5", means_rank2)

    def cov_transposed(a):  # [S, 3, Kmax]: as many elements as [S, Kmax, 3]
        a["covariances"] = np.ascontiguousarray(a["covariances"].transpose(0, 2, 1))
    write_mixture("mix_cov_transposed.h5", cov_transposed)

    def short_scale(a):
        a["scale"] = np.array([1.0])
    write_mixture("mix_short_scale.h5", short_scale)


# ------------------------------------------------------------------ RGL

RGL_MAGIC = b"tensor_file\x00"


def rgl_parse(b):
    n = struct.unpack_from("<I", b, 14)[0]
    p = 18
    fields = []
    for _ in range(n):
        ln = struct.unpack_from("<H", b, p)[0]
        p += 2
        name = b[p : p + ln].decode()
        p += ln
        nd, dt, off = struct.unpack_from("<HBQ", b, p)
        p += 11
        shape = struct.unpack_from("<%dQ" % nd, b, p)
        p += 8 * nd
        fields.append((name, dt, shape, off))
    return fields


DTYPES = {1: np.uint8, 2: np.int8, 3: np.uint16, 4: np.int16, 5: np.uint32, 6: np.int32,
          7: np.uint64, 8: np.int64, 10: np.float32, 11: np.float64}


def rgl_read(file):
    b = open(file, "rb").read()
    out = []
    for name, dt, shape, off in rgl_parse(b):
        n = int(np.prod(shape)) if shape else 1
        arr = np.frombuffer(b, dtype=DTYPES[dt], count=n, offset=off).reshape(shape).copy()
        out.append((name, dt, arr))
    return out


def rgl_write(fields, version=(1, 0), dtype_override=None, shape_override=None):
    """fields: [(name, dtype code, array)]; returns the file bytes."""
    dtype_override = dtype_override or {}
    shape_override = shape_override or {}
    header = bytearray(RGL_MAGIC + bytes(version) + struct.pack("<I", len(fields)))
    hdr_len = len(header)
    for name, dt, arr in fields:
        shape = shape_override.get(name, arr.shape)
        hdr_len += 2 + len(name.encode()) + 2 + 1 + 8 + 8 * len(shape)
    data = bytearray()
    offset = hdr_len
    for name, dt, arr in fields:
        shape = shape_override.get(name, arr.shape)
        while (offset + len(data)) % 8:
            data.append(0)
        off = offset + len(data)
        nm = name.encode()
        header += struct.pack("<H", len(nm)) + nm
        header += struct.pack("<HBQ", len(shape), dtype_override.get(name, dt), off)
        header += b"".join(struct.pack("<Q", s) for s in shape)
        data += np.ascontiguousarray(arr).tobytes()
    assert len(header) == hdr_len
    return bytes(header + data)


def rgl_small():
    """paper_white_rgb with 2 of its 8 theta_i and every 8th (vndf) or 4th (luminance, rgb) cell."""
    src = rgl_read(os.path.join(REPO, "data", "rgl", "paper_white_rgb.bsdf"))
    out = []
    ti = [0, 4]
    for name, dt, arr in src:
        if name == "theta_i":
            arr = arr[ti]
        elif name == "vndf":
            arr = arr[:, ti][:, :, ::8, ::8]
        elif name == "luminance":
            arr = arr[:, ti][:, :, ::4, ::4]
        elif name == "rgb":
            arr = arr[:, ti][:, :, :, ::4, ::4]
        elif name == "valid":
            arr = arr.reshape(32, 32)[::4, ::4].reshape(-1)
        elif name in ("ndf", "sigma"):
            arr = arr[:, ::8]
        out.append((name, dt, np.ascontiguousarray(arr)))
    return out


def replace(fields, name, arr):
    return [(n, d, arr if n == name else a) for n, d, a in fields]


def make_rgl():
    fields = rgl_small()
    ok = rgl_write(fields)
    open(path("ok_rgl.bsdf"), "wb").write(ok)
    real = open(os.path.join(REPO, "data", "rgl", "paper_white_rgb.bsdf"), "rb").read()
    # Bad magic: the real file's first 4 KiB with the magic's first bytes changed.
    open(path("rgl_bad_magic.bsdf"), "wb").write(b"TENSOR" + real[6:4096])
    # A PNG signature: another format entirely.
    open(path("rgl_png.bsdf"), "wb").write(b"\x89PNG\r\n\x1a\n" + bytes(64))
    # The real file cut inside its field headers (byte 200 of 412).
    open(path("rgl_truncated_header.bsdf"), "wb").write(real[:200])
    # Cut after the magic and version: no field count.
    open(path("rgl_truncated_count.bsdf"), "wb").write(real[:15])
    # Cut inside the data of the last field (headers intact).
    open(path("rgl_truncated_field.bsdf"), "wb").write(ok[: len(ok) - 300])
    open(path("rgl_empty.bsdf"), "wb").close()
    # Version 2.0.
    open(path("rgl_version.bsdf"), "wb").write(ok[:12] + bytes([2, 0]) + ok[14:])
    # vndf stored as [1, 2, 256] (rank 3) instead of [1, n_theta, ny, nx].
    vndf = dict((n, a) for n, _, a in fields)["vndf"]
    open(path("rgl_wrong_dims.bsdf"), "wb").write(
        rgl_write(replace(fields, "vndf", vndf.reshape(1, 2, -1))))
    # luminance with 3 theta_i slices while theta_i has 2.
    lum = dict((n, a) for n, _, a in fields)["luminance"]
    open(path("rgl_theta_mismatch.bsdf"), "wb").write(
        rgl_write(replace(fields, "luminance", np.concatenate([lum, lum[:, :1]], axis=1))))
    # Anisotropic: phi_i has 2 values.
    open(path("rgl_anisotropic.bsdf"), "wb").write(
        rgl_write(replace(fields, "phi_i", np.array([0.0, 1.0], dtype=np.float32))))
    # A NaN in the NDF.
    ndf = dict((n, a) for n, _, a in fields)["ndf"].copy()
    ndf[0, 3] = np.nan
    open(path("rgl_nan.bsdf"), "wb").write(rgl_write(replace(fields, "ndf", ndf)))
    # A shape whose size overflows 64 bits.
    open(path("rgl_huge_shape.bsdf"), "wb").write(
        rgl_write(fields, shape_override={"ndf": (1 << 40, 1 << 40)}))
    # A field name with a newline in it (echoed in messages), duplicated.
    dup = fields + [("ndf\nx", 10, np.zeros(2, np.float32)), ("ndf\nx", 10, np.zeros(2, np.float32))]
    open(path("rgl_newline_name.bsdf"), "wb").write(rgl_write(dup))
    # Field 'rgb' missing.
    open(path("rgl_missing_field.bsdf"), "wb").write(
        rgl_write([f for f in fields if f[0] != "rgb"]))


if __name__ == "__main__":
    make_tables()
    make_mixtures()
    make_rgl()
