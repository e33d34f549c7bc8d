#!/usr/bin/env bash
# Installs what trajdb.spark needs to run in Spark local mode, and prints the venv's python:
#   PY=$(scripts/install_spark.sh)
#  * a Java 17+ runtime: the one on PATH (or JAVA_HOME), else apt-get installs
#    openjdk-17-jre-headless; without apt (or root / sudo) it stops and says what to install;
#  * a venv (TRAJDB_SPARK_VENV, default ~/.cache/trajdb-spark-venv) with requirements-spark.txt
#    (pyspark, pyarrow, pandas, duckdb; pinned).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV="${TRAJDB_SPARK_VENV:-$HOME/.cache/trajdb-spark-venv}"

java_major() {
  local j="java"
  [ -n "${JAVA_HOME:-}" ] && [ -x "$JAVA_HOME/bin/java" ] && j="$JAVA_HOME/bin/java"
  command -v "$j" > /dev/null || { echo 0; return; }
  "$j" -version 2>&1 | sed -n 's/.*version "\([0-9]*\).*/\1/p' | head -1
}

if [ "$(java_major)" -lt 17 ] 2>/dev/null || [ -z "$(java_major)" ]; then
  echo "install_spark: no Java 17+ runtime found; installing openjdk-17-jre-headless" >&2
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  if ! command -v apt-get > /dev/null || { [ -n "$SUDO" ] && ! command -v sudo > /dev/null; } \
     || ! { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq openjdk-17-jre-headless > /dev/null; }; then
    echo "install_spark: could not install Java. Spark 4 needs a Java 17 or 21 runtime: install one" >&2
    echo "  (Debian/Ubuntu: apt-get install openjdk-17-jre-headless; macOS: brew install openjdk@17;" >&2
    echo "  elsewhere: https://adoptium.net) and put it on PATH or set JAVA_HOME, then run this again." >&2
    exit 1
  fi
fi
if [ "$(java_major)" -lt 17 ]; then
  echo "install_spark: java on PATH is version $(java_major); Spark 4 needs 17 or 21 (set JAVA_HOME to one)" >&2
  exit 1
fi

if [ ! -x "$VENV/bin/python" ]; then python3 -m venv "$VENV" >&2; fi
"$VENV/bin/pip" install -q -r requirements-spark.txt >&2
echo "$VENV/bin/python"
