#!/usr/bin/python3
"""Words and sentence length of the reference docs.

For each page: its words (every whitespace-separated token, as `wc -w` counts them) and
the median length in words of its prose sentences. Prose leaves out fenced code, tables,
headings, HTML comments and image lines; it is split at sentence ends (., ! or ? before
a space), at blank lines and at list items.

    scripts/doc_stats.py                 every page of README.md and docs/*.md
    scripts/doc_stats.py --check 35000 20
        exits 1 when the pages (docs/studies/ left out) hold more than 35000 words in
        all, or when a page's median sentence is over 20 words
    scripts/doc_stats.py --links
        exits 1 when a relative link of README.md, bench/README.md, examples/README.md
        or docs/ (studies too) names a missing file or a heading its page lacks
"""
import argparse
import pathlib
import re
import statistics
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def prose_units(text):
    """The prose of a Markdown page as a list of paragraphs and list items."""
    text = re.sub(r"<!--.*?-->", " ", text, flags=re.S)
    units, current, fenced = [], [], False
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("```"):
            fenced = not fenced
            if current:
                units.append(" ".join(current))
                current = []
            continue
        if fenced or line.startswith("    ") and not current:
            continue
        starts_item = re.match(r"^\s*([-*+]|\d+\.)\s+", line)
        if (not stripped or stripped.startswith(("#", "|", "![")) or starts_item):
            if current:
                units.append(" ".join(current))
                current = []
            if starts_item:
                current = [line[starts_item.end():].strip()]
            continue
        current.append(stripped)
    if current:
        units.append(" ".join(current))
    return units


def sentences(text):
    out = []
    for unit in prose_units(text):
        for s in re.split(r"(?<=[.!?])\s+(?=[A-Z`(*\"'\[0-9])", unit):
            words = s.split()
            if words:
                out.append(len(words))
    return out


def anchor(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces as dashes."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page):
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    return {anchor(m.group(1)) for m in re.finditer(r"^#+\s+(.*)$", text, flags=re.M)}


def broken_links(root):
    pages_read = [root / "README.md", root / "bench" / "README.md", root / "examples" / "README.md"]
    pages_read += sorted((root / "docs").rglob("*.md"))
    out = []
    for page in pages_read:
        if not page.exists():
            continue
        text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
        for m in re.finditer(r"\]\(([^)\s]+)\)", text):
            target = m.group(1)
            if re.match(r"^[a-z]+:", target):
                continue
            path, _, frag = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            name = str(page.relative_to(root))
            if not dest.exists():
                out.append(f"{name}: link to {target}: no such file")
            elif frag and dest.suffix == ".md" and frag not in anchors(dest):
                out.append(f"{name}: link to {target}: no such heading")
    return out


def pages(root):
    found = [root / "README.md"] + sorted((root / "docs").glob("*.md"))
    studies = sorted((root / "docs" / "studies").glob("*.md"))
    return found, studies


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", nargs=2, type=float, metavar=("WORDS", "MEDIAN"),
                        help="fail over this many words in all or this median sentence")
    parser.add_argument("--links", action="store_true", help="check the pages' relative links instead")
    parser.add_argument("--root", default=str(ROOT), help="the project's root")
    args = parser.parse_args()
    root = pathlib.Path(args.root)
    if args.links:
        broken = broken_links(root)
        for b in broken:
            print(f"doc_stats: {b}", file=sys.stderr)
        print(f"doc_stats: {len(broken)} broken links")
        return 1 if broken else 0
    main_pages, studies = pages(root)
    total, failures = 0, []
    print(f"{'page':40s} {'words':>7s} {'sentences':>9s} {'median':>6s}")
    for page in main_pages + studies:
        text = page.read_text(encoding="utf-8")
        words = len(text.split())
        lengths = sentences(text)
        median = statistics.median(lengths) if lengths else 0.0
        name = str(page.relative_to(root))
        print(f"{name:40s} {words:7d} {len(lengths):9d} {median:6.1f}")
        if page in main_pages:
            total += words
            if args.check and median > args.check[1]:
                failures.append(f"{name}: median sentence {median:.1f} words, over {args.check[1]:g}")
    print(f"{'README.md + docs/*.md':40s} {total:7d}")
    if args.check and total > args.check[0]:
        failures.append(f"README.md + docs/*.md: {total} words, over {args.check[0]:g}")
    for f in failures:
        print(f"doc_stats: {f}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
