#!/usr/bin/python3
"""One CSV row of bench/fit_sweep.sh: what a finished sweep produced, read back from its
files by an independent reader (h5py), never from the program's own summary.

  bench/fit_sweep_row.py --header
  bench/fit_sweep_row.py TABLE.h5 MIXTURE.h5 K_MIN K_MAX SECONDS_BEST SECONDS_ALL
"""
import os
import statistics
import sys

import h5py
import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)

COLUMNS = ("table,slices,cells_per_slice,k_min,k_max,runs,seconds_best,seconds_all,mean_k,l1_median,l1_p90,"
           "mixture_file_bytes,mixture_dataset_bytes,table_file_bytes,table_slice_bytes,full_table_bytes,"
           "ratio_files,ratio_datasets,ratio_full,cpu,cores")


def dataset_bytes(group):
    return sum(d.id.get_storage_size() for d in group.values() if isinstance(d, h5py.Dataset))


def main(argv):
    if argv[1:] == ["--header"]:
        print(COLUMNS)
        return 0
    table, mixture, k_min, k_max, best, runs = argv[1:7]
    with h5py.File(mixture, "r") as f:
        g = f["mixture"]
        k = g["k"][()]
        l1 = np.sort(g["l1_rel"][()])
        mix_ds = dataset_bytes(g)
    with h5py.File(table, "r") as f:
        t = f["table"]
        n_phi_i = t["phi_i"].shape[0]
        cells = t["theta_i"].shape[0] * n_phi_i
        azimuthal = t.attrs.get("symmetry", b"")
        azimuthal = (azimuthal.decode() if isinstance(azimuthal, bytes) else str(azimuthal)) == "azimuthal"
    slices = len(k)
    slice_bytes = slices * cells * 4
    full = slice_bytes * (n_phi_i if azimuthal else 1)
    mix_file, table_file = os.path.getsize(mixture), os.path.getsize(table)
    p90 = l1[min(slices - 1, int(np.ceil(0.9 * slices)) - 1)]
    seconds = [float(x) for x in runs.split()]
    print(",".join(str(x) for x in (
        os.path.basename(table), slices, cells, k_min, k_max, len(seconds), f"{float(best):.2f}",
        " ".join(f"{s:.2f}" for s in seconds), f"{k.mean():.2f}", f"{statistics.median(l1):.5f}", f"{p90:.5f}",
        mix_file, mix_ds, table_file, slice_bytes, full, f"{table_file / mix_file:.0f}", f"{slice_bytes / mix_ds:.0f}",
        f"{full / mix_ds:.0f}", cpu_model(), os.cpu_count())))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
