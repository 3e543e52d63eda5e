"""Finds the Python module `bsdfmix` (examples/README.md) for the scripts, benchmarks and examples.

    sys.path.insert(0, "<repo>/scripts"); import bsdfmix_import; bsdfmix = bsdfmix_import.load()

Looks in $BSDFMIX_MODULE_DIR (the folder holding bsdfmix.cpython-*.so) when set, else in
<repo>/build/python, the folder scripts/setup builds it in. Exits with one line saying how to
build it when it is not there.
"""
import os
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def load():
    where = os.environ.get("BSDFMIX_MODULE_DIR") or str(ROOT / "build" / "python")
    if where not in sys.path:
        sys.path.insert(0, where)
    try:
        import bsdfmix
    except ImportError as e:
        sys.exit(f"{pathlib.Path(sys.argv[0]).name}: the Python module bsdfmix is not in {where} ({e}): build it "
                 f"with scripts/setup or `cmake --build build --target bsdfmix_python`, or set BSDFMIX_MODULE_DIR "
                 f"to the folder holding it")
    return bsdfmix
