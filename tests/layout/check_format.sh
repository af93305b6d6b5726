#!/usr/bin/env bash
# Every C++ source of the project is clang-format clean (the root .clang-format).
# usage: check_format.sh CLANG_FORMAT REPO_ROOT. Prints the offending lines, exit 1 on any.
set -euo pipefail
clang_format=$1 root=$2
cd "$root"
files=$(find core ui app tests -name '*.cpp' -o -name '*.h' | sort)
if ! out=$(echo "$files" | xargs "$clang_format" --dry-run --Werror 2>&1) || [ -n "$out" ]; then
  echo "$out" | head -40
  echo "not clang-format clean: run clang-format -i on the files above" >&2
  exit 1
fi
echo "$(echo "$files" | wc -l) files clang-format clean"
