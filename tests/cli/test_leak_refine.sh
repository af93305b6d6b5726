#!/usr/bin/env bash
# Leak refinement through the CLI on two-rooms (a thin wall between a lit and a sunlit room):
# place adds "leak" probes unless --no-leak-refine; bake refines by default; eval reports
# leaking_fraction, lower after refinement, and lower again with the leak cuts (bake's default;
# --no-leak-cuts leaves Sukys's refinement alone); info reports the cuts.
# Usage: test_leak_refine.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
scene="$root/resources/scenes/two-rooms.gltf"

"$cli" place "$scene" --spacing 1.2 --accept -o "$tmp/refined.json" | tee "$tmp/place.txt"
grep -q "leak refinement added" "$tmp/place.txt"
"$cli" place "$scene" --spacing 1.2 --accept --no-leak-refine -o "$tmp/plain.json"
"$cli" bake "$tmp/plain.json" -o "$tmp/plain.psv" --spp 128 --no-leak-refine
"$cli" bake "$tmp/plain.json" -o "$tmp/baked-refined.psv" --spp 128 | tee "$tmp/bake.txt"
grep -q "leak refinement added" "$tmp/bake.txt"
grep -q "leak cuts: " "$tmp/bake.txt"
"$cli" bake "$tmp/plain.json" -o "$tmp/sukys.psv" --spp 128 --no-leak-cuts | tee "$tmp/bake-sukys.txt"
if grep -q "leak cuts: " "$tmp/bake-sukys.txt"; then echo "cuts with --no-leak-cuts" >&2; exit 1; fi
"$cli" eval "$tmp/plain.psv" --queries 1024 --reference-spp 16 --json >"$tmp/e-plain.json"
"$cli" eval "$tmp/sukys.psv" --queries 1024 --reference-spp 16 --json >"$tmp/e-sukys.json"
"$cli" eval "$tmp/baked-refined.psv" --queries 1024 --reference-spp 16 --json >"$tmp/e-refined.json"
"$cli" info "$tmp/baked-refined.psv" | tee "$tmp/info.txt"
grep -q "leak cuts: .* planes" "$tmp/info.txt"
"$cli" info "$tmp/sukys.psv" >"$tmp/info-sukys.txt"
if grep -q "leak cuts" "$tmp/info-sukys.txt"; then echo "info reports cuts it has not" >&2; exit 1; fi

python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
plain = json.load(open(f"{tmp}/plain.json"))["probes"]
refined = json.load(open(f"{tmp}/refined.json"))["probes"]
assert all(p["method"] == "uniform" for p in plain), "no leak probes with --no-leak-refine"
leak = [p for p in refined if p["method"] == "leak"]
assert len(leak) > 0 and len(refined) == len(plain) + len(leak), (len(plain), len(refined))
assert all(p["score"] >= 1 for p in leak)
ep = json.load(open(f"{tmp}/e-plain.json"))
es = json.load(open(f"{tmp}/e-sukys.json"))
er = json.load(open(f"{tmp}/e-refined.json"))
assert er["probes"] == es["probes"] > ep["probes"] == len(plain), (ep, es, er)
assert 0 < ep["leaking_fraction"] <= 1, ep
assert es["leaking_fraction"] < ep["leaking_fraction"], (ep, es)
assert er["leaking_fraction"] < es["leaking_fraction"] / 5, (es, er)
print("leak refinement ok: +%d probes in place, leaking_fraction %.4f -> %.4f (Sukys) -> %.4f "
      "(cuts)" % (len(leak), ep["leaking_fraction"], es["leaking_fraction"],
                  er["leaking_fraction"]))
PY
