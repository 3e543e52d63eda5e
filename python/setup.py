"""Builds and installs the Python module `bsdfmix` (python/bsdfmix_module.cpp and the readers it
links, host/io and host/core) with setuptools, pybind11 and the HDF5 C library, offline:

    /usr/bin/python3 -m venv --system-site-packages V
    V/bin/python -m pip install --no-build-isolation --no-index ./python

(Debian: python3-setuptools, python3-wheel, python3-pybind11, libhdf5-dev; scripts/setup installs
them). The CMake build makes the same module (python/CMakeLists.txt, target bsdfmix_python).
"""
import os
import re
import shlex
import subprocess

import pybind11
from setuptools import Extension, setup

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def readers():
    """The sources of python/CMakeLists.txt's bsdfmix_readers_pic (one list, kept there)."""

    with open(os.path.join(HERE, "CMakeLists.txt"), encoding="utf-8") as f:
        text = f.read()
    found = re.findall(r"\$\{CMAKE_SOURCE_DIR\}/(host/[\w/]+\.cpp)", text)
    if not found:
        raise SystemExit("setup.py: python/CMakeLists.txt names no host/ source for the readers")
    return found


READERS = readers()


def hdf5_flags():
    """HDF5's include and library folders: pkg-config's `hdf5`, else Debian's serial build."""
    try:
        out = subprocess.run(["pkg-config", "--cflags", "--libs", "hdf5"], check=True, capture_output=True,
                             text=True).stdout
    except (OSError, subprocess.CalledProcessError):
        out = "-I/usr/include/hdf5/serial -L/usr/lib/x86_64-linux-gnu/hdf5/serial -lhdf5"
    words = shlex.split(out)
    return ([w[2:] for w in words if w.startswith("-I")], [w[2:] for w in words if w.startswith("-L")],
            [w[2:] for w in words if w.startswith("-l")] or ["hdf5"])


def missing_sources():
    """The readers' sources that are not beside this folder (an sdist or a copied python/)."""
    return [s for s in READERS if not os.path.isfile(os.path.join(ROOT, s))]


if missing_sources():
    raise SystemExit("setup.py: %s not found: install from a bsdfmix checkout (pip install ./python), "
                     "not from a copy of python/ alone" % missing_sources()[0])

BUILD = os.environ.get("BSDFMIX_PY_BUILD", os.path.join(HERE, "build"))
os.makedirs(BUILD, exist_ok=True)
inc, libdirs, libs = hdf5_flags()
module = Extension(
    "bsdfmix",
    sources=[os.path.join(HERE, "bsdfmix_module.cpp")] + [os.path.join(ROOT, s) for s in READERS],
    include_dirs=[os.path.join(ROOT, "host"), os.path.join(ROOT, "include"), pybind11.get_include()] + inc,
    library_dirs=libdirs,
    runtime_library_dirs=libdirs,
    libraries=libs,
    extra_compile_args=["-std=c++17", "-O2", "-fvisibility=hidden"],
    language="c++",
)

setup(
    name="bsdfmix",
    version="0.1.0",
    description="Evaluate and sample bsdfmix's Gaussian mixture stand-ins of BSDF tables",
    ext_modules=[module],
    python_requires=">=3.9",
    install_requires=["numpy"],
    zip_safe=False,
    # BSDFMIX_PY_BUILD: where the objects and the metadata go (default python/build), so a test
    # builds outside the tree; two compilers at a time.
    options={"build": {"build_base": BUILD}, "egg_info": {"egg_base": BUILD}, "build_ext": {"parallel": 2}},
)
