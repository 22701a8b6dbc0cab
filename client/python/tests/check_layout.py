"""Checks the ctypes mirrors against the Rust wire types.

Usage: python check_layout.py LAYOUT.json, where LAYOUT.json is what the Rust
test (daemon/tests/python_client.rs) wrote: for every type its iceoryx2 type
name, size, alignment and fields (name, offset, size) in order, and the
service settings. Prints each difference; exits 1 if there is any.
"""

import ctypes
import json
import sys

import fusion_client
from fusion_client import wire


def main() -> int:
    rust = json.load(open(sys.argv[1]))
    problems = []
    mirrors = {t.__name__: t for t in wire.ALL_TYPES}
    if sorted(mirrors) != sorted(rust["types"]):
        problems.append(f"types: Python {sorted(mirrors)} vs Rust {sorted(rust['types'])}")
    for name, layout in rust["types"].items():
        t = mirrors.get(name)
        if t is None:
            continue
        mine = {
            "type_name": t.type_name(),
            "size": ctypes.sizeof(t),
            "align": ctypes.alignment(t),
            "fields": [[f, getattr(t, f).offset, getattr(t, f).size] for f, _ in t._fields_],
        }
        for key in ("type_name", "size", "align", "fields"):
            if mine[key] != layout[key]:
                problems.append(f"{name}.{key}: Python {mine[key]} vs Rust {layout[key]}")
    for key, value in rust["constants"].items():
        mine = getattr(fusion_client, key, getattr(wire, key, None))
        if isinstance(mine, dict):
            # Code -> name tables: JSON has text keys.
            mine = {str(k): v for k, v in mine.items()}
        if mine != value:
            problems.append(f"{key}: Python {mine} vs Rust {value}")
    # Path-like namespaces are refused, as by the Rust client and every binary.
    for bad in (".", "..", "../x", ".hidden", "-x", "a..b"):
        try:
            fusion_client.Client(bad)
            problems.append(f"namespace {bad!r} accepted")
        except ValueError:
            pass
    for p in problems:
        print(p)
    print(f"{len(rust['types'])} types, {len(rust['constants'])} constants: {len(problems)} differences")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
