#!/usr/bin/python3
"""Checks the package's Markdown: every relative link names a file that exists, every #anchor a heading of
its file, and every quoted README heading a script or source names ("README's "Models and data"", "see
README, Usage") is one of README's headings.

  scripts/check_docs.py [ROOT]      ROOT: the repository (default: this script's ..)

Prints each broken reference as FILE:LINE: what; exit 0 when there is none, 1 otherwise.
"""
import os
import re
import sys

LINK = re.compile(r'\[[^\]]*\]\(([^)\s]+)\)')
HEADING = re.compile(r'^(#{1,6})\s+(.*?)\s*#*\s*$')
FENCE = re.compile(r'^\s*(```|~~~)')
# References to a README heading by name in code and scripts.
README_HEADING_REFERENCES = [
    re.compile(r"README'?s? \"([^\"]+)\""),
    re.compile(r"see README, ([A-Z][A-Za-z' -]+[a-z])"),
]
SKIP_DIRS = {'.git', 'build', 'deps', 'node_modules'}


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r'`|\*', '', heading)
    text = re.sub(r'\[([^\]]*)\]\([^)]*\)', r'\1', text)  # a link in a heading: its text
    text = text.strip().lower()
    text = ''.join(c for c in text if c.isalnum() or c in ' -_')
    return text.replace(' ', '-')


def anchors(path, cache={}):
    if path not in cache:
        found, counts, in_fence = set(), {}, False
        with open(path, encoding='utf-8') as f:
            for line in f:
                if FENCE.match(line):
                    in_fence = not in_fence
                    continue
                match = None if in_fence else HEADING.match(line)
                if match:
                    base = slug(match.group(2))
                    n = counts.get(base, 0)
                    counts[base] = n + 1
                    found.add(base if n == 0 else '%s-%d' % (base, n))
        cache[path] = found
    return cache[path]


def markdown_files(root):
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
        for name in sorted(files):
            if name.endswith('.md'):
                yield os.path.join(folder, name)


def check_links(root, path):
    problems, in_fence = [], False
    with open(path, encoding='utf-8') as f:
        for number, line in enumerate(f, 1):
            if FENCE.match(line):
                in_fence = not in_fence
            if in_fence:
                continue
            for target in LINK.findall(line):
                if re.match(r'^[a-z]+:', target):  # http:, https:, mailto:
                    continue
                file_part, _, anchor = target.partition('#')
                linked = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) if file_part else path
                where = '%s:%d' % (os.path.relpath(path, root), number)
                if not os.path.exists(linked):
                    problems.append('%s: link to %s: no such file' % (where, target))
                elif anchor and linked.endswith('.md') and anchor not in anchors(linked):
                    problems.append('%s: link to %s: no heading "#%s" in %s' % (
                        where, target, anchor, os.path.relpath(linked, root)))
    return problems


def readme_headings(root):
    headings = set()
    with open(os.path.join(root, 'README.md'), encoding='utf-8') as f:
        for line in f:
            match = HEADING.match(line)
            if match:
                headings.add(match.group(2).strip().lower())
    return headings


def check_heading_references(root):
    problems, headings = [], readme_headings(root)
    for folder in ('scripts', 'src', 'include', 'launch', 'benchmark'):
        for current, dirs, files in os.walk(os.path.join(root, folder)):
            for name in sorted(files):
                path = os.path.join(current, name)
                try:
                    with open(path, encoding='utf-8') as f:
                        lines = f.readlines()
                except (UnicodeDecodeError, OSError):
                    continue
                for number, line in enumerate(lines, 1):
                    for pattern in README_HEADING_REFERENCES:
                        for name_referred in pattern.findall(line):
                            if name_referred.strip().lower() not in headings:
                                problems.append('%s:%d: README has no heading "%s"' % (
                                    os.path.relpath(path, root), number, name_referred))
    return problems


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                           os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
    problems = []
    files = list(markdown_files(root))
    for path in files:
        problems += check_links(root, path)
    problems += check_heading_references(root)
    for problem in problems:
        print(problem)
    print('%d Markdown files, %d broken references' % (len(files), len(problems)))
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
