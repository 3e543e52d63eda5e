#!/usr/bin/python3
"""Checks the house against docs/architecture.md.

  /usr/bin/python3 scripts/check_rooms.py [--root DIR]

- every `#include "room/..."` of a file under host/<room>/ names its own room or one its
  row of the rooms table in docs/architecture.md allows;
- every folder under host/ has a row;
- no file under host/ is longer than 500 lines, none under host/cli/ than 250;
- include/bsdfmix/mixture.hpp includes only the C++ standard library;
- the kernels define Philox in kernels/common.cl alone;
- kernel arguments are set (`setArg`) in host/device/routine.* alone: every launch goes
  through the routine layer.
Prints one line per violation and exits 1 when there is any; prints a summary otherwise.
"""
import argparse
import pathlib
import re
import sys

MAX_LINES = {"": 500, "cli": 250}


def rooms_table(doc):
    """{room: set of rooms it may include} from the table after the `rooms:` marker."""
    lines = doc.read_text().splitlines()
    try:
        start = next(i for i, l in enumerate(lines) if l.startswith("<!-- rooms:"))
    except StopIteration:
        sys.exit(f"{doc}: no '<!-- rooms:' marker before the rooms table")
    rules = {}
    for line in lines[start + 1:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 3 or cells[0] in ("room", "") or set(cells[0]) <= set("-"):
            continue
        room = cells[0].strip("`")
        rules[room] = set() if cells[2] == "-" else set(cells[2].split())
    if not rules:
        sys.exit(f"{doc}: the rooms table has no rows")
    return rules


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=str(pathlib.Path(__file__).resolve().parent.parent))
    root = pathlib.Path(ap.parse_args().root)
    rules = rooms_table(root / "docs" / "architecture.md")
    problems, files, includes = [], 0, 0
    include_re = re.compile(r'^\s*#\s*include\s+"([a-z_0-9]+)/[^"]+"')
    for room_dir in sorted(p for p in (root / "host").iterdir() if p.is_dir()):
        room = room_dir.name
        if room not in rules:
            problems.append(f"host/{room}/: no row in docs/architecture.md's rooms table")
            continue
        limit = MAX_LINES.get(room, MAX_LINES[""])
        for f in sorted(room_dir.rglob("*")):
            if f.suffix not in (".cpp", ".hpp", ".h"):
                continue
            files += 1
            text = f.read_text().splitlines()
            rel = f.relative_to(root)
            if len(text) > limit:
                problems.append(f"{rel}: {len(text)} lines, over the {limit} of host/{room}/")
            for n, line in enumerate(text, 1):
                m = include_re.match(line)
                if not m:
                    continue
                includes += 1
                other = m.group(1)
                if other != room and other not in rules[room]:
                    problems.append(f"{rel}:{n}: host/{room}/ may not include {other}/ "
                                    f"(docs/architecture.md allows: {' '.join(sorted(rules[room])) or 'none'})")
    header = root / "include" / "bsdfmix" / "mixture.hpp"
    for n, line in enumerate(header.read_text().splitlines(), 1):
        m = re.match(r'^\s*#\s*include\s+(.+)$', line)
        if m and not re.fullmatch(r"<[a-z_]+>", m.group(1).strip()):
            problems.append(f"{header.relative_to(root)}:{n}: {m.group(1).strip()} is not a C++ standard header")
    philox_def = re.compile(r"^\s*(inline\s+)?uint4\s+philox\w*\s*\(")
    for cl in sorted((root / "kernels").glob("*.cl")):
        if cl.name == "common.cl":
            continue
        for n, line in enumerate(cl.read_text().splitlines(), 1):
            if philox_def.match(line):
                problems.append(f"{cl.relative_to(root)}:{n}: Philox is defined in kernels/common.cl alone")
    set_arg = re.compile(r"\bsetArg\s*\(")
    for f in sorted((root / "host").rglob("*")):
        if f.suffix not in (".cpp", ".hpp", ".h") or f.parent.name == "device" and f.stem == "routine":
            continue
        for n, line in enumerate(f.read_text().splitlines(), 1):
            if set_arg.search(line):
                problems.append(f"{f.relative_to(root)}:{n}: kernel arguments are set through Routine "
                                f"(host/device/routine.hpp) alone")
    for p in problems:
        print(p)
    if problems:
        print(f"check_rooms: {len(problems)} problem(s)")
        return 1
    print(f"check_rooms: {len(rules)} rooms, {files} files, {includes} includes across rooms or within: all as "
          f"docs/architecture.md says")
    return 0


if __name__ == "__main__":
    sys.exit(main())
