#!/usr/bin/python3
"""Lists the functions of host/, kernels/ and python/ longer than a limit.

A function's length is its lines from the line of its name to its closing brace, lambdas
and local classes inside it included. C++ (.cpp, .hpp) and OpenCL C (.cl) are read with
comments and literals blanked; a brace at namespace or class level whose head ends like a
signature (a closing parenthesis, const, override, noexcept, a trailing return type or a
constructor's initializer list) opens a function.

    scripts/check_functions.py            the 30 longest, with the count over 100 lines
    scripts/check_functions.py --max 100  exits 1 when any function is over 100 lines
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
FOLDERS = ("host", "kernels", "python")
SUFFIXES = (".cpp", ".hpp", ".cl", ".h")


def blank(text):
    """Comments and string or character literals as spaces, newlines kept."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not text[i - 1].isalnum()):
            k = text.find("(", i)
            delim = ")" + text[i + 2:k] + '"'
            j = text.find(delim, k)
            j = n if j < 0 else j + len(delim)
            out.append('""' + re.sub(r"[^\n]", " ", text[i + 2:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (j - i - 1) + (c if j < n else ""))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


SIGNATURE_END = re.compile(
    r"(\)|\})\s*((const|override|final|noexcept|mutable|volatile|&&?|try)\s*|noexcept\s*\([^)]*\)\s*)*$")
SCOPE_HEAD = re.compile(r"^(template\s*<.*>\s*)?(class|struct|union|enum|namespace)\b|^extern\b|^namespace$")


def functions(text):
    """(name, first line, last line) of every function in a blanked source."""
    found, stack, head_start = [], [], 0
    line_of = lambda pos: text.count("\n", 0, pos) + 1
    for pos, c in enumerate(text):
        in_function = any(kind == "function" for kind, _, _ in stack)
        if c == ";" and not in_function:
            head_start = pos + 1
        elif c == "{":
            if in_function:
                stack.append(("block", pos, None))
                continue
            head = " ".join(text[head_start:pos].split())
            if re.search(r"\b(\w+)\s*\(", head) and not SCOPE_HEAD.search(head) and (
                    SIGNATURE_END.search(head) or re.search(r"\)\s*->[^()]*$", head)):
                name_match = re.search(r"([~\w:]+(?:operator\S*)?)\s*\(", head)
                name = name_match.group(1) if name_match else "?"
                first = line_of(head_start + len(text[head_start:pos]) - len(text[head_start:pos].lstrip()))
                stack.append(("function", first, name))
            elif re.search(r"\)\s*:", head) and re.search(r"\w$", head) or "=" in head.split("(")[0]:
                stack.append(("data", pos, None))
                continue
            else:
                stack.append(("scope", pos, None))
            head_start = pos + 1
        elif c == "}" and stack:
            kind, first, name = stack.pop()
            if kind == "function":
                found.append((name, first, line_of(pos)))
            if kind in ("function", "scope"):
                head_start = pos + 1
    return found


def scan(root):
    rows = []
    for folder in FOLDERS:
        for path in sorted((root / folder).rglob("*")):
            if path.suffix not in SUFFIXES or not path.is_file():
                continue
            for name, first, last in functions(blank(path.read_text(encoding="utf-8"))):
                rows.append((last - first + 1, str(path.relative_to(root)), first, name))
    return sorted(rows, reverse=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--max", type=int, help="exit 1 when a function is longer than this")
    parser.add_argument("--root", default=str(ROOT), help="the project's root")
    args = parser.parse_args()
    rows = scan(pathlib.Path(args.root))
    limit = args.max if args.max is not None else 100
    over = [r for r in rows if r[0] > limit]
    shown = over if args.max is not None else rows[:30]
    for length, path, line, name in shown:
        print(f"{length:5d}  {path}:{line}  {name}")
    print(f"check_functions: {len(over)} of {len(rows)} functions over {limit} lines")
    return 1 if args.max is not None and over else 0


if __name__ == "__main__":
    sys.exit(main())
