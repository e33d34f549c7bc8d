#!/usr/bin/env python3
"""Turn the cdylib into a loadable DuckDB extension by appending DuckDB's 512-byte footer.

Footer layout (read by DuckDB from the last 512 bytes): eight 32-byte zero-padded fields, in
order: unused, unused, unused, ABI type, extension version, C API version, platform, magic "4";
then 256 zero bytes where a signature would go.

We write ABI type C_STRUCT and C API version v1.2.0: C_STRUCT_UNSTABLE makes DuckDB 2.0 look
for `trajdb_init_c_api_v2`, and a newer C API version than the host's is rejected.

usage: python3 scripts/append_footer.py IN.so OUT.duckdb_extension [--version V] [--platform P]
"""
import argparse
import platform
import shutil


def default_platform():
    m = platform.machine().lower()
    arch = {"x86_64": "amd64", "amd64": "amd64", "aarch64": "arm64", "arm64": "arm64"}.get(m, m)
    osname = platform.system().lower()
    osname = {"darwin": "osx"}.get(osname, osname)
    return f"{osname}_{arch}"


def field(s):
    b = s.encode()
    if len(b) > 32:
        raise SystemExit(f"footer field too long: {s!r}")
    return b + b"\0" * (32 - len(b))


def footer(ext_version, plat, abi="C_STRUCT", capi="v1.2.0"):
    fields = [field(""), field(""), field(""), field(abi), field(ext_version), field(capi), field(plat), field("4")]
    out = b"".join(fields) + b"\0" * 256
    assert len(out) == 512
    return out


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
