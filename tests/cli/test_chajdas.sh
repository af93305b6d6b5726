#!/usr/bin/env bash
# probestudio place --method chajdas: provenance and scores, aggressiveness merging more, bad
# options.
# Usage: test_chajdas.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
scene="$root/resources/scenes/pillar-room.gltf"
field=(--field-depth 1 --field-spp 32)

"$cli" place "$scene" --method chajdas "${field[@]}" -o "$tmp/c1.json" | tee "$tmp/out.txt"
grep -q "candidate clusters" "$tmp/out.txt"
"$cli" place "$scene" --method chajdas "${field[@]}" -o "$tmp/c1b.json" >/dev/null
cmp "$tmp/c1.json" "$tmp/c1b.json"  # deterministic for a seed
"$cli" place "$scene" --method chajdas --aggressiveness 2 "${field[@]}" -o "$tmp/c2.json"
"$cli" place "$scene" --method chajdas --aggressiveness 0.5 "${field[@]}" -o "$tmp/c05.json"
"$cli" place "$scene" --method chajdas --budget 30 "${field[@]}" -o "$tmp/cb.json"
python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
c1 = json.load(open(f"{tmp}/c1.json"))
assert c1["placement"]["method"] == "chajdas"
methods = {p["method"] for p in c1["probes"]}
assert methods == {"chajdas", "coverage"}, methods
assert all(p["score"] >= 1 for p in c1["probes"] if p["method"] == "chajdas"), "cluster sizes"
for p in c1["probes"]:  # inside the room, outside the pillar
    x, y, z = p["position"]
    assert -4 < x < 4 and 0 < y < 3 and -4 < z < 4 and not (-0.6 < x < 0.6 and -0.6 < z < 0.6), p
n2 = len(json.load(open(f"{tmp}/c2.json"))["probes"])
n05 = len(json.load(open(f"{tmp}/c05.json"))["probes"])
assert 1 <= n2 < n05, (n2, n05)
nb = len(json.load(open(f"{tmp}/cb.json"))["probes"])
assert 24 <= nb <= 36, f"--budget 30 gave {nb}"
print("chajdas ok:", len(c1["probes"]), "probes;", n05, "at aggressiveness 0.5,", n2, "at 2")
PY

fail=0
expect_error() {  # expect_error "expected text" cmd...
  local expected="$1"; shift
  if "$@" >"$tmp/o" 2>"$tmp/err"; then echo "FAIL: $* succeeded"; fail=1; return; fi
  grep -qF -- "$expected" "$tmp/err" || { echo "FAIL: $*: $(cat "$tmp/err")"; fail=1; }
}
expect_error "--aggressiveness: expected a positive number" "$cli" place "$scene" --method chajdas --aggressiveness 0 -o "$tmp/x.json"
expect_error "--spacing: not an option of --method chajdas" "$cli" place "$scene" --method chajdas --spacing 1 -o "$tmp/x.json"
expect_error "budget: expected at least 4 probes, got 3" "$cli" place "$scene" --method chajdas --budget 3 -o "$tmp/x.json"
test ! -e "$tmp/x.json" || { echo "FAIL: a failed place wrote its output"; fail=1; }
exit $fail
