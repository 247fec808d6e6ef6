#!/usr/bin/env bash
# The quick start's test job: install, build, run the default test set (label `e2e` excluded).
#   scripts/test.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh" "$build" -DBUILD_TESTING=ON
ctest --test-dir "$build" --output-on-failure -j2 -LE e2e
