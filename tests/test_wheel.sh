#!/usr/bin/env bash
# The binary wheel (issue 29 §1): scripts/build_wheel.sh builds it; it installs into a FRESH venv
# with no Rust and no compiler reachable (cargo, rustc, cc, gcc, c++, ld... on PATH are shims that
# record any call but a bare --version probe, and CC/CXX=false; the test fails if anything called one), HOME is a scratch
# folder; then from the installed wheel: `trajdb --help`, `python -m trajdb --help`, `trajdb params`,
# per-command --help, `trajdb demo` (must pass), `LOAD trajdb` by name in Python with DuckDB 2.0
# and 1.5 (the wheel's site-packages/.duckdb_extensions when its version folder is that DuckDB's,
# else a link in ~/.cache/trajdb), DuckDB's
# progress bar off in a log, and the DuckDB command line (the duckdb-cli package from PyPI):
# `trajdb install-cli`, then `LOAD trajdb` by name, and a file trajdb did not write left alone.
# Prints the wheel size and the install times (the local wheel with duckdb from a local
# wheelhouse, and the download of duckdb from PyPI).
#
# usage: tests/test_wheel.sh [path/to/trajdb.duckdb_extension]   (without it: scripts/build_extension.sh builds one)
set -euo pipefail
cd "$(dirname "$0")/.."
REPO="$PWD"
W="$(mktemp -d)"
trap 'rm -rf "$W"' EXIT
PASS=0
ok() { PASS=$((PASS + 1)); echo "ok   $*"; }
fail() { echo "FAIL: $*" >&2; echo "$PASS passed, 1 failed"; exit 1; }

# 1. the wheel (the only step with Rust)
if [ -n "${1:-}" ]; then
  WHL="$(scripts/build_wheel.sh --extension "$1" --out "$W/dist")"
else
  WHL="$(scripts/build_wheel.sh --out "$W/dist")"
fi
SIZE=$(python3 -c "import os,sys; print(f'{os.path.getsize(sys.argv[1]) / 1e6:.1f}')" "$WHL")
ok "wheel $(basename "$WHL"): $SIZE MB"

# 2. duckdb (2.0 and 1.5) and the duckdb-cli package from PyPI into a local wheelhouse: the only download
PY="$(python3 -c 'import sys; print(sys.executable)')"
"$PY" -m venv "$W/venv"
V="$W/venv/bin"
t0=$(date +%s.%N)
for req in "duckdb>=1.5" "duckdb==2.0.0" "duckdb==1.5.5" "duckdb-cli==1.5.6"; do
  "$V/pip" download -q --disable-pip-version-check -d "$W/wheelhouse" "$req" || fail "pip download of $req from PyPI"
done
t1=$(date +%s.%N)
DOWNLOAD=$(python3 -c "print(f'{$t1 - $t0:.1f}')")

# 3. the install, in an environment without Rust or a compiler
mkdir -p "$W/shims" "$W/home"
for tool in cargo rustc rustup cc gcc g++ c++ clang clang++ ld ld.gold ld.lld cmake make; do
  # a bare `--version` probe compiles nothing (pip asks `rustc --version` for its user agent): it fails, unrecorded
  printf '#!/bin/sh\n[ "$*" = "--version" ] && exit 1\necho "%s $*" >> "%s/forbidden.log"\nexit 1\n' "$tool" "$W" > "$W/shims/$tool"
  chmod +x "$W/shims/$tool"
done
CLEAN=(env -i "HOME=$W/home" "PATH=$V:$W/shims:/usr/bin:/bin" "CC=false" "CXX=false" "LANG=C.UTF-8" "PIP_DISABLE_PIP_VERSION_CHECK=1")
[ "$("${CLEAN[@]}" sh -c 'command -v cargo')" = "$W/shims/cargo" ] || fail "the shims do not hide cargo"
t0=$(date +%s.%N)
"${CLEAN[@]}" pip install -q --no-index --find-links "$W/wheelhouse" "$WHL" > "$W/install.log" 2>&1 \
  || { cat "$W/install.log" >&2; fail "pip install of the wheel"; }
t1=$(date +%s.%N)
INSTALL=$(python3 -c "print(f'{$t1 - $t0:.1f}')")
[ ! -e "$W/forbidden.log" ] || { cat "$W/forbidden.log" >&2; fail "the install called a compiler or Rust"; }
ok "pip install of the wheel (duckdb from the local wheelhouse, no network): ${INSTALL} s, no Rust or compiler called"
SITE="$("$V/python" -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])')"
DV="$("$V/python" -c 'import duckdb; print(duckdb.__version__)')"
SHIPPED="$("$V/python" -c 'import trajdb._wheel as w; print(w.EXTENSION)')"
[ -f "$SITE/$SHIPPED" ] && [[ "$SHIPPED" == .duckdb_extensions/v*/*/trajdb.duckdb_extension ]] \
  || fail "the extension is not at site-packages/.duckdb_extensions/<version>/<platform>/ ($SHIPPED)"
ls "$SITE"/trajdb/_trajdb* > /dev/null 2>&1 && fail "the wheel holds a Python extension module"
ok "installed: site-packages/$SHIPPED, and duckdb $DV from PyPI"

# 4. the commands from the installed wheel
cd "$W"
R() { "${CLEAN[@]}" "$@"; }
R trajdb --help > help.txt && grep -q "install-cli" help.txt && grep -q "pipeline" help.txt || fail "trajdb --help"
R python -m trajdb --help > mhelp.txt && cmp -s help.txt mhelp.txt && [ ! -e "$W/--help" ] || fail "python -m trajdb --help"
ok "trajdb --help and python -m trajdb --help: the same overview, no folder named --help"
R trajdb params > params.txt && grep -q "merge_eta" params.txt || fail "trajdb params"
ok "trajdb params: $(($(wc -l < params.txt) - 1)) parameters"
for c in pipeline demo simulate score sql functions params report install-cli; do
  R trajdb "$c" --help > "h-$c.txt" 2>&1 && grep -q "^usage: trajdb $c" "h-$c.txt" || { cat "h-$c.txt" >&2; fail "trajdb $c --help"; }
done
grep -q "merge_eta" h-pipeline.txt || fail "trajdb pipeline --help lists no parameters"
ok "trajdb COMMAND --help for pipeline demo simulate score sql functions params report install-cli"
R trajdb demo --out "$W/demo" > demo.txt 2> demo.err || { cat demo.txt demo.err >&2; fail "trajdb demo"; }
grep -q "demo PASSED" demo.txt || { cat demo.txt >&2; fail "trajdb demo did not pass"; }
grep -q "▕\|█" demo.txt demo.err && fail "DuckDB's progress bar in a log"
grep -q '^\[trajdb\] align ' demo.err || { cat demo.err >&2; fail "no plain per-stage lines on stderr"; }
ok "trajdb demo: $(grep "demo PASSED" demo.txt | cut -c1-60)...; plain stage lines, no progress bar in the log"
[ ! -e "$W/forbidden.log" ] || { cat "$W/forbidden.log" >&2; fail "running trajdb called a compiler or Rust"; }

# 5. LOAD trajdb by name in Python: duckdb 2.0 (the wheel's folder), then 1.5 (a link in ~/.cache/trajdb)
cat > "$W/byname.py" <<'PY'
import os, subprocess, sys, duckdb, trajdb
site = os.path.dirname(os.path.dirname(trajdb.__file__))
path = trajdb.extension_path()
assert path.startswith(os.path.join(site, ".duckdb_extensions")), path
con = trajdb.connect()
con.execute("LOAD trajdb")
assert con.execute("SELECT current_setting('enable_progress_bar')").fetchone()[0] in (False, "false"), "progress bar on in a log"
d = trajdb.extension_dir()
shipped = os.path.join(site, ".duckdb_extensions")
if duckdb.__version__ == os.path.basename(os.path.dirname(os.path.dirname(path)))[1:]:
    assert d == shipped, (d, shipped)
else:
    assert d.startswith(os.path.join(os.environ["HOME"], ".cache", "trajdb", "extensions")), d
plain = duckdb.connect(config={"allow_unsigned_extensions": "true"})
try:
    plain.execute("LOAD trajdb")
    print("note: plain duckdb.connect() found trajdb by name without configuration")
except duckdb.Error:
    pass  # DuckDB searches only ~/.duckdb/extensions by default (docs/install.md)
mine = duckdb.connect(config={"allow_unsigned_extensions": "true", "extension_directories": ["~/.duckdb/extensions", d]})
mine.execute("LOAD trajdb")
(where,) = mine.execute("SELECT install_path FROM duckdb_extensions() WHERE extension_name = 'trajdb' AND loaded").fetchone()
assert os.path.realpath(where) == os.path.realpath(path), (where, path)
assert mine.execute("SELECT count(*) FROM trajdb_params()").fetchone()[0] > 10
# the progress bar (DuckDB draws it on stdout after progress_bar_time, 2 s): a plain connection
# draws it into a redirected stdout; trajdb.connect() does not, for a query longer than that
def run(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
control = run("import duckdb; c = duckdb.connect(); c.execute('SET progress_bar_time = 0'); "
              "c.execute('SELECT count(*) FROM range(100000000) t(i) WHERE i % 7 = 3').fetchall()")
assert "▕" in control.stdout, "the control drew no progress bar: the test cannot see one"
got = run("import time, trajdb; c = trajdb.connect(); c.execute('SET threads = 1'); t = time.time(); "
          "c.execute('SELECT count(*) FROM range(1500000000) t(i) WHERE i % 7 = 3').fetchall(); print(f'{time.time() - t:.1f}')")
assert "▕" not in got.stdout + got.stderr, got.stdout[:200]
if float(got.stdout.split()[-1]) < 2.5:
    print(f"note: the long query took {got.stdout.split()[-1]} s, under DuckDB's 2 s before a bar: the no-bar check proves little here")
print(f"ok   duckdb {duckdb.__version__}: LOAD trajdb by name from {d} ({'the wheel' if d == shipped else 'a link in ~/.cache/trajdb'}); "
      "trajdb.connect() by name too; no progress bar on a redirected stdout")
PY
R python "$W/byname.py" || fail "LOAD trajdb by name with duckdb $DV"
PASS=$((PASS + 1))
for dv in 2.0.0 1.5.5; do
  [ "$dv" = "$DV" ] && continue
  R pip install -q --no-index --find-links "$W/wheelhouse" "duckdb==$dv" > /dev/null 2>&1 || fail "pip install duckdb==$dv (local)"
  R python "$W/byname.py" || fail "LOAD trajdb by name with duckdb $dv"
  PASS=$((PASS + 1))
done

# 6. the DuckDB command line (duckdb-cli 1.5.6 from PyPI): trajdb install-cli, then LOAD trajdb by name
R pip install -q --no-index --find-links "$W/wheelhouse" "duckdb-cli==1.5.6" > /dev/null 2>&1 || fail "pip install duckdb-cli (local)"
R duckdb -unsigned -c "LOAD trajdb" > /dev/null 2>&1 && fail "the CLI found trajdb before install-cli (test is not clean)"
R trajdb install-cli > ic.txt || fail "trajdb install-cli"
CLI_FILE="$W/home/.duckdb/extensions/v1.5.6/linux_amd64/trajdb.duckdb_extension"
grep -q "^installed: $CLI_FILE" ic.txt && cmp -s "$CLI_FILE" "$SITE/$SHIPPED" \
  || { cat ic.txt >&2; fail "install-cli did not copy the extension to $CLI_FILE"; }
R duckdb -unsigned -csv -noheader -c "LOAD trajdb; SELECT extension_version FROM duckdb_extensions() WHERE extension_name = 'trajdb' AND loaded" \
  > cli.txt 2>&1 && grep -qx "v0.1.0" cli.txt || { cat cli.txt >&2; fail "duckdb -unsigned -c 'LOAD trajdb' after install-cli"; }
R duckdb -c "LOAD trajdb" > signed.txt 2>&1 && fail "the CLI loaded an unsigned extension without -unsigned"
ok "trajdb install-cli -> $CLI_FILE; duckdb -unsigned -c 'LOAD trajdb' loads it by name (v0.1.0); without -unsigned: refused"
[ "$(R trajdb install-cli | head -1)" = "already installed: $CLI_FILE" ] || fail "install-cli a second time"
# a file trajdb wrote and nobody changed is updated; a file trajdb did not write is never replaced
cp "$SITE/$SHIPPED" "$W/newer.duckdb_extension"
printf 'x' >> "$W/newer.duckdb_extension"
[ "$("${CLEAN[@]}" TRAJDB_EXTENSION="$W/newer.duckdb_extension" trajdb install-cli | head -1)" = "updated: $CLI_FILE" ] \
  || fail "install-cli did not update its own file"
mkdir -p "$W/theirs/v1.5.6/linux_amd64" && echo "the user's own file" > "$W/theirs/v1.5.6/linux_amd64/trajdb.duckdb_extension"
R trajdb install-cli --dir "$W/theirs" > theirs.txt 2>&1 && fail "install-cli replaced a file it did not write"
grep -q "did not write it" theirs.txt && grep -qx "the user's own file" "$W/theirs/v1.5.6/linux_amd64/trajdb.duckdb_extension" \
  || { cat theirs.txt >&2; fail "install-cli over a user's file: no clear error, or the file changed"; }
R trajdb install-cli --duckdb "$W/nowhere/duckdb" > none.txt 2>&1 && fail "install-cli without a CLI"
grep -q "duckdb-version" none.txt || { cat none.txt >&2; fail "install-cli without a CLI: no hint"; }
ok "install-cli: 'already installed' the second time, updates only its own file, refuses a user's file (left as it was), names --duckdb-version when no CLI is found"
[ ! -e "$W/forbidden.log" ] || { cat "$W/forbidden.log" >&2; fail "something called a compiler or Rust"; }

echo "wheel: $(basename "$WHL"), $SIZE MB"
echo "install time: ${INSTALL} s (pip install of the local wheel with duckdb from a local wheelhouse, fresh venv); downloading duckdb (newest, 2.0.0, 1.5.5) and duckdb-cli 1.5.6 from PyPI beforehand: ${DOWNLOAD} s"
echo "$PASS passed, 0 failed"
