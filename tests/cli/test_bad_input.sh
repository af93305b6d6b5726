#!/usr/bin/env bash
# Bad input to the CLI: each case gives one clear line on stderr naming the file and the problem,
# a non-zero exit, and no crash (exit code 1, not a signal).
# Usage: test_bad_input.sh PROBESTUDIO REPO_ROOT
set -u
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
fail=0

expect_error() {  # expect_error "expected text" cmd...
  local expected="$1"; shift
  "$@" >"$tmp/out" 2>"$tmp/err"
  local code=$?
  local lines; lines=$(wc -l <"$tmp/err")
  if [ "$code" -ne 1 ] || ! grep -qF -- "$expected" "$tmp/err" || [ "$lines" -ne 1 ]; then
    echo "FAIL: $* -> exit $code, stderr ($lines lines):"; cat "$tmp/err"
    echo "  expected one line containing: $expected"
    fail=1
  else
    echo "ok: $(cat "$tmp/err")"
  fi
}

# Scenes
expect_error "$tmp/missing.gltf: file not found" "$cli" place "$tmp/missing.gltf" -o "$tmp/s.json"
head -c 300 /dev/urandom >"$tmp/random.gltf"
expect_error "$tmp/random.gltf" "$cli" place "$tmp/random.gltf" -o "$tmp/s.json"
echo "this is not a gltf file" >"$tmp/text.glb"
expect_error "$tmp/text.glb" "$cli" capture "$tmp/text.glb" --at 0,0,0 --json
expect_error "meshes[0].primitives[0]: index" "$cli" place "$root/tests/data/gltf/index-out-of-range.gltf" -o "$tmp/s.json"
test ! -e "$tmp/s.json" || { echo "FAIL: a failed place wrote its output"; fail=1; }

# Probe sets
cat >"$tmp/future.json" <<'JSON'
{"format": "probestudio.probeset", "version": 42, "scene": "x.gltf", "probes": []}
JSON
expect_error "$tmp/future.json: version: version 42 is newer than this build reads" "$cli" bake "$tmp/future.json" -o "$tmp/v.psv"
expect_error "$tmp/future.json: version" "$cli" info "$tmp/future.json"
cat >"$tmp/short.json" <<'JSON'
{"format": "probestudio.probeset", "version": 1, "scene": "x.gltf",
 "probes": [{"id": 1, "position": [1, 2], "state": "accepted"}]}
JSON
expect_error "probes[0].position: expected 3 numbers, got 2" "$cli" info "$tmp/short.json"

m="$root/tests/data/malformed"
expect_error "$m/ps-overflow-number.json: not valid JSON" "$cli" info "$m/ps-overflow-number.json"
expect_error "$m/vol-bad-magic.psv: magic: not a ProbeStudio volume" "$cli" info "$m/vol-bad-magic.psv"
expect_error "$m/vol-huge-probe-count.psv: header: counts" "$cli" query "$m/vol-huge-probe-count.psv" --at 0,0,0
expect_error "--spp: 100000000 samples per probe is above the limit" "$cli" bake "$m/ps-empty.json" -o "$tmp/v.psv" --spp 100000000
expect_error "--fit-points, --fit-spp, --fit-regularization: give --fit too" "$cli" bake "$m/ps-empty.json" -o "$tmp/v.psv" --fit-points 8
"$cli" place "$root/resources/scenes/cornell.gltf" --method uniform --budget 16 --accept -o "$tmp/c8.json" >/dev/null
expect_error "--fit-regularization: expected a positive number" "$cli" bake "$tmp/c8.json" -o "$tmp/v.psv" --fit --fit-regularization -1
expect_error "--fit-points: expected 1 to 4096 points per probe, got 0" "$cli" bake "$m/ps-empty.json" -o "$tmp/v.psv" --fit --fit-points 0
expect_error "--fit-points, --fit-spp, --fit-regularization: give --fit too" "$cli" bake "$tmp/c8.json" -o "$tmp/v.psv" --fit-regularization 0.01
# A flat importance volume: refused before the capture, naming the fit.
python3 - "$tmp/c8.json" "$tmp/c8-flat.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["importance_volumes"] = [{"name": "flat", "min": [0, 1, 0], "max": [1, 1, 1], "weight": 1}]
json.dump(s, open(sys.argv[2], "w"))
PY
expect_error "fit: the importance volumes have no volume" "$cli" bake "$tmp/c8-flat.json" -o "$tmp/v.psv" --fit --no-cache
test ! -e "$tmp/v.psv" || { echo "FAIL: a failed bake wrote its output"; fail=1; }
expect_error "--queries: 2000000000 is above the limit" "$cli" eval "$m/ps-empty.json" --queries 2000000000
expect_error "budget: expected at most 1000000 probes (the limit), got 2000000000" "$cli" place "$root/resources/scenes/cornell.gltf" --budget 2000000000 -o "$tmp/s.json"

# Volumes and parameters
printf 'PSVOLUM1\001\000' >"$tmp/trunc.psv"
expect_error "$tmp/trunc.psv: " "$cli" query "$tmp/trunc.psv" --at 0,0,0
printf '0 0 0\n1 0 0\n0 1 0\n1 1 0\n' >"$tmp/flat.txt"
expect_error "$tmp/flat.txt: need at least 4 points not all in one plane" "$cli" tetra "$tmp/flat.txt" -o "$tmp/t.json"
printf '0 0 0\n1 0 nan\n' >"$tmp/nan.txt"
expect_error "$tmp/nan.txt: line 2" "$cli" tetra "$tmp/nan.txt" -o "$tmp/t.json"
expect_error "--method: unknown method \"magic\"" "$cli" place "$root/resources/scenes/cornell.gltf" --method magic -o "$tmp/s.json"
expect_error "probes that cover the scene" "$cli" place "$root/resources/scenes/cornell.gltf" --budget 2 -o "$tmp/s.json"
expect_error "limit 50 million" "$cli" place "$root/resources/scenes/cornell.gltf" --spacing 0.0001 -o "$tmp/s.json"
expect_error "--domain: expected reachable or bounds, got 'everywhere'" "$cli" place "$root/resources/scenes/cornell.gltf" --domain everywhere -o "$tmp/s.json"
expect_error "--domain-band: expected a height in (0, 100] m" "$cli" eval "$tmp/trunc.psv" --domain-band -1
expect_error "--domain-slope: expected an angle in [0, 90) degrees" "$cli" bake "$tmp/future.json" -o "$tmp/v.psv" --domain-slope 95
expect_error "--sun: expected" "$cli" capture "$root/resources/scenes/cornell.gltf" --at 0,1,0 --sun 1,2 --json
expect_error "$tmp/no-sky.hdr: environment map not found" "$cli" capture "$root/resources/scenes/cornell.gltf" --at 0,1,0 --env-map "$tmp/no-sky.hdr" --json
echo "not an image" >"$tmp/sky.exr"
expect_error "$tmp/sky.exr: not a readable environment map" "$cli" capture "$root/resources/scenes/cornell.gltf" --at 0,1,0 --env-map "$tmp/sky.exr" --json
exit $fail
