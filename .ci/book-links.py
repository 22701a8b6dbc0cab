#!/usr/bin/env python3
"""Checks the user guide for dead links.

Usage: book-links.py BOOK_DIR README

BOOK_DIR is the HTML that `mdbook build docs` wrote (target/book): every relative
link of every page must name a file of the book and, with a `#fragment`, an id in
that page. README is the repository's README.md: its relative links must name
files of the repository and, into a Markdown page, a heading of it.
Exits 1 and lists every dead link, or 0.
"""
import html
import os
import re
import sys

book, readme = sys.argv[1], sys.argv[2]
problems = []
ids = {}


def page_ids(path):
    if path not in ids:
        text = open(path, encoding="utf-8").read()
        ids[path] = set(re.findall(r'\bid="([^"]+)"', text))
    return ids[path]


for dirpath, _, files in os.walk(book):
    for name in files:
        if not name.endswith(".html"):
            continue
        path = os.path.join(dirpath, name)
        text = open(path, encoding="utf-8").read()
        # Only the page's own content: the theme's links are mdbook's.
        main = re.search(r"<main>(.*)</main>", text, re.S)
        for href in re.findall(r'href="([^"]+)"', main.group(1) if main else ""):
            href = html.unescape(href)
            if re.match(r"^[a-z]+:", href):
                continue
            target, _, fragment = href.partition("#")
            target_path = os.path.normpath(os.path.join(dirpath, target)) if target else path
            if not os.path.isfile(target_path):
                problems.append(f"{path}: {href}: no such page")
            elif fragment and target_path.endswith(".html") and fragment not in page_ids(target_path):
                problems.append(f"{path}: {href}: no such anchor")


def slug(heading):
    return re.sub(r"[^\w\- ]", "", heading.strip("# ").lower()).replace(" ", "-")


root = os.path.dirname(os.path.abspath(readme))
for target, fragment in re.findall(r"\]\(([^)#\s]+)(#[^)\s]*)?\)", open(readme, encoding="utf-8").read()):
    if re.match(r"^[a-z]+:", target):
        continue
    path = os.path.normpath(os.path.join(root, target))
    if not os.path.exists(path):
        problems.append(f"{readme}: {target}: no such file")
    elif fragment and path.endswith(".md"):
        headings = [slug(h) for h in open(path, encoding="utf-8").read().splitlines() if h.startswith("#")]
        if fragment[1:] not in headings:
            problems.append(f"{readme}: {target}{fragment}: no such heading")

for p in problems:
    print(p)
sys.exit(1 if problems else 0)
