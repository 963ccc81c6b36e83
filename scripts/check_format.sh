#!/bin/bash
# Checks that every tracked C++ file is formatted as .clang-format says (Debian bookworm's
# clang-format 14, installed by scripts/setup.sh); --fix formats them instead. CTest test_format.
#   bash scripts/check_format.sh [--fix]
set -eo pipefail
cd "$(dirname "$0")/.."
command -v clang-format > /dev/null || { echo "check_format.sh: clang-format is not installed (bash scripts/setup.sh)" >&2; exit 2; }
mapfile -t files < <(git ls-files --cached --others --exclude-standard '*.cpp' '*.h')
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
  exit 0
fi
report="$(mktemp)"
trap 'rm -f "$report"' EXIT
if ! clang-format --dry-run -Werror "${files[@]}" 2> "$report"; then
  grep "error:" "$report" | cut -d: -f1 | sort | uniq -c | sed 's/^/  /'
  echo "check_format.sh: the files above differ from .clang-format (bash scripts/check_format.sh --fix)" >&2
  exit 1
fi
echo "check_format.sh: ${#files[@]} C++ files formatted as .clang-format says"
