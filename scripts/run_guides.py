#!/usr/bin/python3
"""Runs the guides' commands, as a new user would type them.

    /usr/bin/python3 scripts/run_guides.py --root . --build build [--guides docs/guide_fit.md ...]
        [--alone README.md]

The guides are read in order, in one scratch folder that links the project's `build`,
`data`, `configs`, `include`, `examples`, `scripts` and `python` (so `out/` is the
scratch folder's own); each `--alone` page gets a scratch folder of its own. Fenced blocks are acted on by their language:

- ```sh: each line runs in bash (`set -e`), from the scratch folder;
- ```yaml, ```cpp, ```python whose first line is a comment naming a path: under `out/`
  (`# out/mine/paper.yaml`) written there; under `examples/` (`// examples/cpp/albedo.cpp`)
  checked to be that file, line for line, so a program shown is the program shipped;
- ```python without such a line: run with /usr/bin/python3.

Other blocks are read, not run. A failing command stops the run with its guide, line
and output, and a non-zero exit.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

GUIDES = ["docs/guide_fit.md", "docs/guide_renderer.md", "docs/guide_estimators.md"]
LINKED = ["data", "configs", "include", "examples", "scripts", "python", "kernels", "bench"]
PATH_COMMENT = re.compile(r"^\s*(?:#|//)\s*((?:out|examples)/[\w./-]+)\s*$")


def blocks(path):
    """(language, first line number, lines) of each fenced block."""
    out, lang, start, body = [], None, 0, []
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            fence = re.match(r"^```(\w*)\s*$", line)
            if fence and lang is None:
                lang, start, body = fence.group(1) or "text", n + 1, []
            elif line.startswith("```") and lang is not None:
                out.append((lang, start, body))
                lang = None
            elif lang is not None:
                body.append(line.rstrip("\n"))
    if lang is not None:
        raise SystemExit(f"{path}:{start}: fenced block never closed")
    return out


def run(cmd, cwd, where, shell):
    print(f"[{where}] {cmd if shell else ' '.join(cmd)}", flush=True)
    r = subprocess.run(cmd, cwd=cwd, shell=shell, executable="/bin/bash" if shell else None,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.stdout.write(r.stdout[-4000:])
        raise SystemExit(f"{where}: exit {r.returncode}")
    return r.stdout


def act(guide, lang, start, body, work):
    where = f"{guide}:{start}"
    named = PATH_COMMENT.match(body[0]) if body else None
    if named and named.group(1).startswith("examples/"):
        with open(os.path.join(work, named.group(1)), encoding="utf-8") as f:
            shipped = f.read().rstrip("\n").split("\n")
        if shipped != body:
            diff = next(i for i in range(max(len(body), len(shipped)))
                        if i >= len(body) or i >= len(shipped) or body[i] != shipped[i])
            raise SystemExit(f"{guide}:{start + diff}: the block differs from {named.group(1)} at its line {diff + 1}")
        print(f"[{where}] is {named.group(1)}", flush=True)
        return 0
    if named and lang in ("yaml", "cpp", "python", "text"):
        path = os.path.join(work, named.group(1))
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(body) + "\n")
        print(f"[{where}] wrote {named.group(1)}", flush=True)
        return 0
    if lang == "sh":
        script = "set -e\n" + "\n".join(body)
        run(script, work, where, shell=True)
        return len([l for l in body if l.strip() and not l.lstrip().startswith("#")])
    if lang == "python":
        path = os.path.join(work, f"guide_snippet_{start}.py")
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(body) + "\n")
        run(["/usr/bin/python3", path], work, where, shell=False)
        return 1
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=".")
    ap.add_argument("--build", default="build")
    ap.add_argument("--guides", nargs="*", default=GUIDES)
    ap.add_argument("--alone", nargs="*", default=[], help="pages run each in a scratch folder of their own")
    ap.add_argument("--keep", help="run in this folder (kept) instead of a temporary one")
    a = ap.parse_args()
    root, build = os.path.abspath(a.root), os.path.abspath(a.build)
    if not os.path.exists(os.path.join(build, "bsdfmix")):
        raise SystemExit(f"{build}/bsdfmix: no such file (build the project first)")
    total = 0
    for group in [[page] for page in a.alone] + [a.guides]:
        with tempfile.TemporaryDirectory(prefix="guides_") as tmp:
            work = os.path.abspath(a.keep) if a.keep else tmp
            os.makedirs(work, exist_ok=True)
            for name in LINKED + ["build"]:
                link, target = os.path.join(work, name), build if name == "build" else os.path.join(root, name)
                if not os.path.lexists(link):
                    os.symlink(target, link)
            for guide in group:
                ran = sum(act(guide, *b, work) for b in blocks(os.path.join(root, guide)))
                if ran == 0:
                    raise SystemExit(f"{guide}: no command to run (a guide's commands go in ```sh blocks)")
                total += ran
    print(f"guides: {total} commands ran, all passed")


if __name__ == "__main__":
    main()
