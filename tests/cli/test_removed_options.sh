#!/usr/bin/env bash
# Options whose feature was removed are still parsed, only to be refused: exit code 1 (as for any
# bad parameter), one line on stderr naming the option and what replaced it, and no output file.
# Usage: test_removed_options.sh PROBESTUDIO REPO_ROOT
set -u
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
scene="$root/resources/scenes/cornell.gltf"
fail=0

expect_refused() {  # expect_refused OPTION "expected text" cmd...
  local option="$1" expected="$2"; shift 2
  "$@" >"$tmp/out" 2>"$tmp/err"
  local code=$?
  local lines; lines=$(wc -l <"$tmp/err")
  if [ "$code" -ne 1 ] || [ "$lines" -ne 1 ] || ! grep -qF -- "$option: removed; " "$tmp/err" ||
     ! grep -qF -- "$expected" "$tmp/err"; then
    echo "FAIL: $* -> exit $code, stderr ($lines lines):"; cat "$tmp/err"
    echo "  expected one line with \"$option: removed; \" and \"$expected\""
    fail=1
  else
    echo "ok: $(cat "$tmp/err")"
  fi
  if [ -e "$tmp/out.json" ] || [ -e "$tmp/v.psv" ]; then
    echo "FAIL: $* wrote its output"; fail=1
  fi
}

for option in --leak-refine --no-leak-refine; do
  expect_refused "$option" "visibility maps and their neighbour search" \
    "$cli" place "$scene" --budget 8 "$option" -o "$tmp/out.json"
  expect_refused "$option" "coverage-first placement" \
    "$cli" place "$scene" --budget 8 "$option" -o "$tmp/out.json"
done

# bake refuses before it reads the probe set (which need not exist).
for option in --leak-refine --no-leak-refine --no-leak-cuts --leak-cuts-only --leak-cut-probes; do
  expect_refused "$option" "visibility maps" "$cli" bake "$tmp/none.json" "$option" -o "$tmp/v.psv"
  expect_refused "$option" "neighbouring tetrahedra's probes that see it" \
    "$cli" bake "$tmp/none.json" "$option" -o "$tmp/v.psv"
done
expect_refused --over-cut-weight "visibility maps" \
  "$cli" bake "$tmp/none.json" --over-cut-weight 0.25 -o "$tmp/v.psv"

# They are not offered in --help.
for sub in place bake; do
  if "$cli" "$sub" --help | grep -qE -- "--(no-)?leak|--over-cut"; then
    echo "FAIL: $sub --help lists a removed leak option"; fail=1
  fi
done

exit $fail
