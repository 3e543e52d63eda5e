"""The machine a study ran on, as the bench CSVs record it."""
import os


def cpu_model():
    """The CPU model from /proc/cpuinfo, with commas as semicolons (a CSV cell), or "unknown"."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip().replace(",", ";")
    except OSError:
        pass
    return "unknown"


def logical_cpus():
    return os.cpu_count() or 1
