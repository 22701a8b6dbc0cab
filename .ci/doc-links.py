#!/usr/bin/env python3
"""Checks rendered rustdoc HTML for links that do not resolve.

Usage: doc-links.py DOC_DIR (e.g. target/doc/fusion_client)

A link rustdoc could not resolve is left as text (`[<code>name</code>]`, `[name]`
where the source had an intra-doc link) or as an href that is a Rust path
(`fusion_shared::service::X`); a resolved one may still point at a page that was
not generated (an item of an undocumented crate). Blanket implementations
(documented by their own crates, e.g. tracing's `Instrument`) are not checked.
Exits 1 and lists every finding, or 0.
"""
import html
import os
import re
import sys

root = sys.argv[1]
problems = []
for dirpath, _, files in os.walk(root):
    for name in files:
        if not name.endswith(".html"):
            continue
        path = os.path.join(dirpath, name)
        text = open(path, encoding="utf-8").read()
        text = text.split('id="blanket-implementations"')[0]
        blocks = re.findall(r'<div class="docblock[^"]*">(.*?)</div>', text, re.S)
        for block in blocks:
            # Code blocks (examples) may hold brackets of their own.
            prose = re.sub(r"<pre.*?</pre>", "", block, flags=re.S)
            for m in re.finditer(r"\[<code>([^<]*)</code>\]", prose):
                problems.append(f"{path}: unresolved link [`{html.unescape(m.group(1))}`]")
            for m in re.finditer(r'href="([^"#]*)(#[^"]*)?"', prose):
                target = html.unescape(m.group(1))
                if not target or target.startswith(("http://", "https://", "mailto:")):
                    continue
                if "::" in target or not os.path.exists(os.path.normpath(os.path.join(dirpath, target))):
                    problems.append(f"{path}: dead link {target}")
for p in sorted(set(problems)):
    print(p)
if problems:
    print(f"{len(set(problems))} unresolved or dead links in {root}", file=sys.stderr)
    sys.exit(1)
print(f"doc links: every link in {root} resolves")
