#!/usr/bin/env bash
# Road-user identity across recordings unlike ours (issue 14): the shared scenes plus simulated
# days over frame rate, camera count, clock offset, position noise, traffic and a pedestrian
# crowd, and (issue 26) waiting groups, cyclists, clock drift, offsets of hours, an epoch, time-stamp
# jitter, mixed frame rates, UTM-sized frames and combinations of them, each run with the DEFAULT command (no per-scenario parameters), then `trajdb score`.
# One line per scenario: worst camera pair (rotation, translation, clock offset error), IDF1,
# objects exactly reconstructed, within-camera link precision and break recall, cross-camera
# match F1. With PER_CLASS=1 the per-class identity rows follow each line.
# usage: benches/identity_grid.sh [OUT_DIR]   (the `trajdb` command over stock DuckDB: PY, default
#        python3 with duckdb; TRAJDB_EXTENSION, default ./trajdb.duckdb_extension from scripts/build_extension.sh)
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
export TRAJDB_EXTENSION="${TRAJDB_EXTENSION:-$ROOT/trajdb.duckdb_extension}" PYTHONPATH="$ROOT/python${PYTHONPATH:+:$PYTHONPATH}"
T="${PY:-python3} -m trajdb"
OUT="${1:-/tmp/trajdb-grid}"
DATA="$(cd "$(dirname "$0")/../.." && pwd)/shared/data"
row() { # name dir
  # worst camera pair: rotation (deg), translation (m), clock drift error (ppm), clock error (ms,
  # worst over the recording); then IDF1, HOTA, exact, link precision, break recall, match F1
  s=$($T score "$2" --results "$2/r")
  w=$(echo "$s" | head -1 | grep -oE "[0-9.]+ deg|[0-9.]+ m|[0-9.]+ ppm|[0-9.]+ ms" | tr '\n' ' ')
  id=$(echo "$s" | sed -n '/road users/,/^matches/p' | grep -m1 "^  all" | awk '{print "IDF1 "$2" HOTA "$9" exact "$3" linkP "$5" breakR "$6}')
  m=$(echo "$s" | tail -1 | awk '{print "matchF1 "$4}')
  printf "%-78s %-38s %s %s\n" "$1" "$w" "$id" "$m"
  if [ -n "$PER_CLASS" ]; then echo "$s" | sed -En '/^road users/,/^(merged|matches)/{/^(road|merged|matches|  class|  all)/!p}'; fi
}
for sc in dut_intersection_3cam dut_roundabout_2cam; do
  mkdir -p $OUT/$sc
  $T pipeline --input $DATA/$sc/points.parquet --out $OUT/$sc/r 2>/dev/null >/dev/null
  ln -sfn $DATA/$sc/points.parquet $OUT/$sc/points.parquet; for f in cameras.csv truth.csv world.csv; do ln -sfn $DATA/$sc/$f $OUT/$sc/$f; done
  row "$sc" $OUT/$sc
done
GRID=(
  "--cameras 3 --rate-hz 2" "--cameras 3 --rate-hz 5" "--cameras 3 --rate-hz 10" "--cameras 3 --rate-hz 25"
  "--cameras 2 --rate-hz 10" "--cameras 7 --rate-hz 10"
  "--cameras 3 --rate-hz 10 --noise-sigma 0.05" "--cameras 3 --rate-hz 10 --noise-sigma 0.3"
  "--cameras 3 --rate-hz 10 --clock-offset-max 0.1" "--cameras 3 --rate-hz 10 --clock-offset-max 0.3"
  "--cameras 5 --rate-hz 25 --clock-offset-max 0.5" "--cameras 7 --rate-hz 2 --clock-offset-max 0.5"
  "--cameras 3 --rate-hz 10 --traffic 3"
  "--cameras 3 --rate-hz 10 --pedestrians 10" "--cameras 7 --rate-hz 2 --pedestrians 10 --noise-sigma 0.05,0.3 --clock-offset-max 0.5"
)
for args in "${GRID[@]}"; do
  d=$OUT/$(echo $args | tr -d ' -' | tr ',' '_'); rm -rf $d
  $T simulate --minutes 5 --seed 1 $args --out $d >/dev/null 2>&1
  $T pipeline --input $d/points.parquet --out $d/r 2>/dev/null >/dev/null
  row "simulate --minutes 5 --seed 1 $args" $d
done
# Issue 26: what the world makes (docs/simulate.md): one cell per degradation, then combined
# "torture" cells. Each cell names its own minutes.
GRID26=(
  "--minutes 5 --cameras 3 --rate-hz 10 --waiting-groups 2"
  "--minutes 5 --cameras 3 --rate-hz 10 --waiting-groups 4 --pedestrians 5"
  "--minutes 5 --cameras 3 --rate-hz 10 --cyclists 5"
  "--minutes 30 --cameras 3 --rate-hz 10 --clock-drift-ppm 100"
  "--minutes 30 --cameras 3 --rate-hz 10 --clock-drift-ppm 300"
  "--minutes 5 --cameras 3 --rate-hz 10 --clock-offset-max 60"
  "--minutes 5 --cameras 3 --rate-hz 10 --clock-offset-max 3600"
  "--minutes 5 --cameras 3 --rate-hz 10 --clock-offset-max 0.5 --clock-epoch 1.78e9"
  "--minutes 5 --cameras 3 --rate-hz 25 --time-jitter-s 0.01"
  "--minutes 5 --cameras 8 --rate-hz 2,5,7.5,10,12.5,15,25,30"
  "--minutes 5 --cameras 3 --rate-hz 10 --origin utm"
  "--minutes 5 --cameras 3 --rate-hz 25 --noise-sigma 0.4"
  "--minutes 10 --cameras 5 --rate-hz 2,7.5,12.5,25,30 --clock-drift-ppm 200 --clock-offset-max 3600 --origin utm --waiting-groups 2 --noise-sigma 0.05,0.4"
  "--minutes 30 --cameras 4 --rate-hz 5,10,15,30 --clock-drift-ppm 300 --clock-offset-max 86400 --clock-epoch 1.78e9 --time-jitter-s 0.01 --cyclists 3 --noise-sigma 0.1,0.3"
  "--minutes 5 --cameras 7 --rate-hz 2,5,10,25 --pedestrians 10 --waiting-groups 4 --clock-offset-max 60 --origin utm --noise-sigma 0.05,0.3"
)
# Issue 38: what roadside cameras make (docs/simulate.md): each camera sees another point of a
# road user (viewpoint bias), a ground-plane calibration error, occlusion in crowds; one cell each,
# then torture cells combining them with drift, mixed rates and waiting crowds (run after the
# cells of issue 26, by the same loop).
GRID38=(
  "--minutes 5 --cameras 3 --rate-hz 10 --viewpoint-bias 0.5,0.1"
  "--minutes 5 --cameras 3 --rate-hz 10 --viewpoint-bias 1.5,0.3"
  "--minutes 5 --cameras 3 --rate-hz 10 --ground-plane-error 0.02"
  "--minutes 5 --cameras 3 --rate-hz 10 --waiting-groups 4 --pedestrians 5 --occlusion 0.02"
  "--minutes 10 --cameras 4 --rate-hz 5,10,15,25 --viewpoint-bias 1.2,0.2 --ground-plane-error 0.015 --clock-drift-ppm 200 --clock-offset-max 60 --waiting-groups 2"
  "--minutes 5 --cameras 5 --rate-hz 2,10,25 --viewpoint-bias 1.5,0.3 --ground-plane-error 0.02 --occlusion 0.02 --waiting-groups 4 --pedestrians 5 --noise-sigma 0.05,0.3"
  # a busy crossing whose pedestrians are cut into pieces mid-view (session 4: a uniform
  # hypothesis sample left two camera pairs 2 s off; waiting crowds under heavy occlusion)
  "--minutes 5 --cameras 3 --rate-hz 10 --pedestrians 10 --occlusion 0.05"
  "--minutes 5 --cameras 3 --rate-hz 10 --waiting-groups 8 --pedestrians 10 --occlusion 0.05"
)
for args in "${GRID26[@]}" "${GRID38[@]}"; do
  d=$OUT/$(echo $args | tr -d ' -' | tr ',' '_'); rm -rf $d
  $T simulate --seed 1 $args --out $d >/dev/null 2>&1
  $T pipeline --input $d/points.parquet --out $d/r 2>/dev/null >/dev/null
  row "simulate --seed 1 $args" $d
done
