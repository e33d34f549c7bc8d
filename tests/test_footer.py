#!/usr/bin/env python3
"""Checks the metadata footer that scripts/append_footer.py writes (and that DuckDB reads).

usage: python3 tests/test_footer.py [trajdb.duckdb_extension]
Without an argument, checks a footer appended to a dummy payload."""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
from append_footer import footer  # noqa: E402


def fields(tail):
    assert len(tail) == 512
    f = [tail[32 * k:32 * (k + 1)].rstrip(b"\0").decode() for k in range(8)]
    assert tail[256:] == b"\0" * 256, "signature area must be zero"
    return f


def check(tail):
    f = fields(tail)
    assert f[0:3] == ["", "", ""], f
    assert f[3] == "C_STRUCT", f"ABI type {f[3]!r}: C_STRUCT_UNSTABLE fails on DuckDB 2.0"
    assert f[4].startswith("v"), f"extension version {f[4]!r}"
    assert f[5] == "v1.2.0", f"C API version {f[5]!r}"
    assert "_" in f[6], f"platform {f[6]!r}"
    assert f[7] == "4", f"magic {f[7]!r}"
    return f


def main():
    if len(sys.argv) > 1:
        with open(sys.argv[1], "rb") as fh:
            fh.seek(-512, os.SEEK_END)
            f = check(fh.read())
    else:
        f = check(footer("v0.1.0", "linux_amd64"))
        with tempfile.TemporaryDirectory() as d:
            src, dst = os.path.join(d, "x.so"), os.path.join(d, "x.duckdb_extension")
            open(src, "wb").write(b"payload")
            subprocess.run([sys.executable, os.path.join(HERE, "..", "scripts", "append_footer.py"), src, dst], check=True,
                           stdout=subprocess.DEVNULL)
            data = open(dst, "rb").read()
            assert data[:7] == b"payload" and len(data) == 7 + 512
            check(data[-512:])
    print(f"footer ok: {f[3]} {f[5]} {f[6]} {f[4]}\n1 passed, 0 failed")


if __name__ == "__main__":
    main()
