#!/usr/bin/env bash
# Build the binary wheel dist/trajdb-<version>-py3-none-<platform>.whl: the `trajdb` Python package
# (python/trajdb) and the ready loadable extension, like DuckDB's own extension wheels: the file
# goes to site-packages/.duckdb_extensions/<DuckDB version>/<DuckDB platform>/trajdb.duckdb_extension.
# Installing it needs no Rust and no compiler (tests/test_wheel.sh); only this script builds.
#
# usage: scripts/build_wheel.sh [--extension FILE] [--duckdb-version v2.0.0] [--out DIR]
#   --extension FILE   package this trajdb.duckdb_extension (default: build it, scripts/build_extension.sh)
#   --duckdb-version   the version folder the file is installed under (default v2.0.0). The file loads
#                      in DuckDB 1.5 and 2.0 alike (C API v1.2.0); for another version than this one,
#                      trajdb.connect() / trajdb.extension_dir() link it into ~/.cache/trajdb, and
#                      `trajdb install-cli` copies it for the DuckDB command line.
#   --out DIR          where the wheel goes (default: dist)
# The platform tag is the lowest manylinux_2_N that covers the glibc symbol versions the file needs
# (linux_<arch> if none is found; macosx_11_0_<arch> on macOS).
set -euo pipefail
cd "$(dirname "$0")/.."
EXT="" DUCKDB_VERSION="v2.0.0" OUT="dist"
while [ $# -gt 0 ]; do
  case "$1" in
    --extension) EXT="$2"; shift 2 ;;
    --duckdb-version) DUCKDB_VERSION="$2"; shift 2 ;;
    --out) OUT="$2"; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "build_wheel.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
if [ -z "$EXT" ]; then
  echo "[build_wheel] building the extension (scripts/build_extension.sh)" >&2
  scripts/build_extension.sh >&2
  EXT=trajdb.duckdb_extension
fi
[ -f "$EXT" ] || { echo "build_wheel.sh: no extension file $EXT" >&2; exit 1; }
mkdir -p "$OUT"
python3 - "$EXT" "$DUCKDB_VERSION" "$OUT" <<'PY'
"""Writes the wheel with zipfile (PEP 427): no setuptools, no build backend, reproducible times."""
import base64, csv, hashlib, io, os, platform, re, stat, sys, zipfile

ext, duckdb_version, out = sys.argv[1:]
if not duckdb_version.startswith("v"):
    duckdb_version = "v" + duckdb_version
sys.path.insert(0, os.path.join("python", "trajdb"))
from footer import default_platform  # noqa: E402  (the package's module, without importing duckdb)

pyproject = open("pyproject.toml").read()
field = lambda k: re.search(rf'^{k} = "(.*)"', pyproject, re.M).group(1)  # noqa: E731
name, version, summary, requires_python = field("name"), field("version"), field("description"), field("requires-python")
deps = re.findall(r'"([^"]+)"', re.search(r"^dependencies = \[(.*)\]", pyproject, re.M).group(1))
init = open("python/trajdb/__init__.py").read()
assert f'__version__ = "{version}"' in init, "python/trajdb/__init__.py's __version__ differs from pyproject.toml"

data = open(ext, "rb").read()
tail = data[-512:]
plat_field = tail[6 * 32:7 * 32].rstrip(b"\0").decode()
duck_plat = default_platform()
assert tail[7 * 32:7 * 32 + 1] == b"4" and plat_field == duck_plat, f"{ext}: no DuckDB footer for {duck_plat} (scripts/append_footer.py)"

machine = {"amd64": "x86_64", "arm64": "aarch64"}.get(duck_plat.split("_", 1)[1], platform.machine())
if sys.platform == "darwin":
    tag_plat = f"macosx_11_0_{'arm64' if machine == 'aarch64' else machine}"
else:
    glibc = sorted({int(m) for m in re.findall(rb"GLIBC_2\.(\d+)", data)})
    tag_plat = f"manylinux_2_{glibc[-1]}_{machine}" if glibc else f"linux_{machine}"
tag = f"py3-none-{tag_plat}"
dist_info, data_dir = f"{name}-{version}.dist-info", f"{name}-{version}.data"
ext_rel = f".duckdb_extensions/{duckdb_version}/{duck_plat}/trajdb.duckdb_extension"

files = []  # (name in the wheel, bytes)
for fn in sorted(os.listdir("python/trajdb")):
    if fn.endswith(".py") and fn != "_wheel.py":
        files.append((f"trajdb/{fn}", open(os.path.join("python/trajdb", fn), "rb").read()))
files.append(("trajdb/_wheel.py", (
    '"""Written by scripts/build_wheel.sh: where this wheel installed the extension (relative to site-packages)."""\n'
    f'EXTENSION = "{ext_rel}"\nDUCKDB_VERSION = "{duckdb_version}"\nPLATFORM = "{duck_plat}"\n').encode()))
files.append((f"{data_dir}/platlib/{ext_rel}", data))
meta = [f"Metadata-Version: 2.1", f"Name: {name}", f"Version: {version}", f"Summary: {summary}",
        f"License: MIT", f"Requires-Python: {requires_python}"] + [f"Requires-Dist: {d}" for d in deps]
files.append((f"{dist_info}/METADATA", ("\n".join(meta) + "\n\n" + open("docs/install.md").read()).encode()))
files.append((f"{dist_info}/WHEEL", (f"Wheel-Version: 1.0\nGenerator: trajdb scripts/build_wheel.sh\n"
                                     f"Root-Is-Purelib: false\nTag: {tag}\n").encode()))
files.append((f"{dist_info}/entry_points.txt", b"[console_scripts]\ntrajdb = trajdb.cli:main\n"))
files.append((f"{dist_info}/top_level.txt", b"trajdb\n"))
files.append((f"{dist_info}/LICENSE", open("LICENSE", "rb").read()))

def digest(b):
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(b).digest()).rstrip(b"=").decode()

record = io.StringIO()
w = csv.writer(record, lineterminator="\n")
for fn, b in files:
    w.writerow([fn, digest(b), len(b)])
w.writerow([f"{dist_info}/RECORD", "", ""])
files.append((f"{dist_info}/RECORD", record.getvalue().encode()))

path = os.path.join(out, f"{name}-{version}-{tag}.whl")
with zipfile.ZipFile(path + ".tmp", "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
    for fn, b in files:
        info = zipfile.ZipInfo(fn, date_time=(1980, 1, 1, 0, 0, 0))
        info.compress_type = zipfile.ZIP_DEFLATED
        info.external_attr = (stat.S_IFREG | 0o644) << 16
        z.writestr(info, b)
os.replace(path + ".tmp", path)
print(path)
print(f"[build_wheel] {path}: {os.path.getsize(path) / 1e6:.1f} MB ({tag}; extension {len(data) / 1e6:.1f} MB at site-packages/{ext_rel})",
      file=sys.stderr)
PY
