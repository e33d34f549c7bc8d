#!/usr/bin/env bash
# Whole-pipeline accuracy and scale (issue 7): the shared DUT scenarios, then simulated
# Skövde-sized (2 cameras, ~24,000 tracks) and Mellingen-sized (3 cameras, ~48,000+ tracks) days,
# each through `trajdb pipeline` (time per stage, peak memory) and `trajdb score`.
# The `trajdb` command over stock DuckDB (python -m trajdb; peak RSS is the Python process with
# DuckDB and the extension in it).
# usage: benches/pipeline_scale.sh [WORKDIR]      (needs ../shared/data for the DUT part; PY,
#        default python3 with duckdb; TRAJDB_EXTENSION, default ./trajdb.duckdb_extension,
#        built by scripts/build_extension.sh when missing)
set -euo pipefail
cd "$(dirname "$0")/.."
export TRAJDB_EXTENSION="${TRAJDB_EXTENSION:-$PWD/trajdb.duckdb_extension}" PYTHONPATH="$PWD/python${PYTHONPATH:+:$PYTHONPATH}"
[ -f "$TRAJDB_EXTENSION" ] || scripts/build_extension.sh
PY="${PY:-python3}"
W="${1:-${TMPDIR:-/tmp}/trajdb-scale}"
mkdir -p "$W"
run() {  # name scenario_dir
    echo "== $1"
    /usr/bin/time -f "peak RSS %M KB, wall %e s" "$PY" -m trajdb pipeline --input "$2/points.parquet" --out "$W/$1.results" 2>&1 | grep -v 'report.html' || true
    "$PY" -m trajdb score "$2" --results "$W/$1.results"
}
for s in dut_intersection_3cam dut_roundabout_2cam; do
    [ -d "../shared/data/$s" ] && run "$s" "../shared/data/$s"
done
"$PY" -m trajdb simulate --cameras 2 --minutes 720 --traffic 0.9 --rate-hz 5 --seed 41 --world-rate-hz 0 --out "$W/skovde"
run skovde "$W/skovde"
"$PY" -m trajdb simulate --cameras 3 --minutes 720 --traffic 1.4 --rate-hz 5 --seed 42 --world-rate-hz 0 --out "$W/mellingen"
run mellingen "$W/mellingen"
