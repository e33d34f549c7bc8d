#!/usr/bin/env python3
"""Turn the cdylib into a loadable DuckDB extension by appending DuckDB's 512-byte footer
(the layout and why C_STRUCT / v1.2.0: python/trajdb/footer.py, shared with the Python package).

usage: python3 scripts/append_footer.py IN.so OUT.duckdb_extension [--version V] [--platform P]
"""
import argparse
import os
import shutil
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python", "trajdb"))
from footer import default_platform, footer  # noqa: E402  (the package's module, without importing duckdb)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--version", default="v0.1.0")
    ap.add_argument("--platform", default=default_platform())
    a = ap.parse_args()
    shutil.copyfile(a.src, a.dst)
    with open(a.dst, "ab") as f:
        f.write(footer(a.version, a.platform))
    print(f"wrote {a.dst} ({a.platform}, C API v1.2.0, C_STRUCT, {a.version})")


if __name__ == "__main__":
    main()
