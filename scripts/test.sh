#!/usr/bin/env bash
# Installs dependencies, builds, checks formatting and runs every test (unit, CLI, end to end).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
git ls-files '*.cc' '*.h' | xargs clang-format --dry-run --Werror
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build
ctest --test-dir build --output-on-failure -j2
