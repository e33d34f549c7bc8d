"""DuckDB's 512-byte extension footer, which turns trajdb's cdylib into a loadable extension.

Footer layout (read by DuckDB from the last 512 bytes): eight 32-byte zero-padded fields, in
order: unused, unused, unused, ABI type, extension version, C API version, platform, magic "4";
then 256 zero bytes where a signature would go.

We write ABI type C_STRUCT and C API version v1.2.0: C_STRUCT_UNSTABLE makes DuckDB 2.0 look
for `trajdb_init_c_api_v2`, and a newer C API version than the host's is rejected. One file
therefore loads in DuckDB 1.5 and 2.0. Used by scripts/append_footer.py and by `trajdb.load`.
"""
import platform


def default_platform():
    """DuckDB's platform name of this machine (linux_amd64, osx_arm64, ...)."""
    m = platform.machine().lower()
    arch = {"x86_64": "amd64", "amd64": "amd64", "aarch64": "arm64", "arm64": "arm64"}.get(m, m)
    osname = platform.system().lower()
    osname = {"darwin": "osx"}.get(osname, osname)
    return f"{osname}_{arch}"


def field(s):
    b = s.encode()
    if len(b) > 32:
        raise ValueError(f"footer field too long: {s!r}")
    return b + b"\0" * (32 - len(b))


def footer(ext_version, plat=None, abi="C_STRUCT", capi="v1.2.0"):
    """The 512 bytes DuckDB reads at the end of an extension file."""
    fields = [field(""), field(""), field(""), field(abi), field(ext_version), field(capi), field(plat or default_platform()), field("4")]
    out = b"".join(fields) + b"\0" * 256
    assert len(out) == 512
    return out
