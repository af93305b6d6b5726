#!/usr/bin/env bash
# The generated level (scripts/make_level.py): the same parameters give the same bytes; every box
# is closed, outward-facing and apart from the others; the small level loads, places (greedy),
# bakes and evaluates end to end on the default (reachable) domain at its rule's cell; bad
# parameters, a scene with no room for a probe and a budget the dense field cannot hold each say
# so clearly.
# Usage: test_level.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
gen=(python3 "$root/scripts/make_level.py")
sky=(--env 0.2,0.25,0.35)

# Deterministic: .glb twice, .gltf + .bin twice, a two-storey level with stairwells and cross
# corridors twice; another seed gives another level.
"${gen[@]}" --preset small -o "$tmp/a.glb" | tee "$tmp/gen.txt"
"${gen[@]}" --preset small -o "$tmp/b.glb" >/dev/null
cmp "$tmp/a.glb" "$tmp/b.glb"
"${gen[@]}" --preset small -o "$tmp/a.gltf" >/dev/null
mkdir "$tmp/again"
"${gen[@]}" --preset small -o "$tmp/again/a.gltf" >/dev/null
cmp "$tmp/a.gltf" "$tmp/again/a.gltf"
cmp "$tmp/a.bin" "$tmp/again/a.bin"
"${gen[@]}" --width 45 --depth 32 --floors 2 --seed 5 -o "$tmp/m.glb" | tee "$tmp/gen-m.txt"
"${gen[@]}" --width 45 --depth 32 --floors 2 --seed 5 -o "$tmp/m2.glb" >/dev/null
cmp "$tmp/m.glb" "$tmp/m2.glb"
"${gen[@]}" --preset small --seed 2 -o "$tmp/c.glb" >/dev/null
if cmp -s "$tmp/a.glb" "$tmp/c.glb"; then echo "FAIL: seeds 1 and 2 give the same level"; exit 1; fi
grep -Eq "^wrote .*: 26 x 14 m, 3.8 m high, 1 storeys, [4-9] rooms, 0 stairwells, [0-9]+ triangles" "$tmp/gen.txt"
grep -Eq ", 2 storeys, [0-9]+ rooms, [1-9] stairwells, " "$tmp/gen-m.txt"
grep -q "^sky: --env 0.2,0.25,0.35$" "$tmp/gen.txt"
# --lamps-per-room N: N lamps in each room, the same building (its triangle count is unchanged).
"${gen[@]}" --preset small --lamps-per-room 2 -o "$tmp/lamps.glb" | tee "$tmp/gen-lamps.txt"
rooms=$(sed -nE 's/.* ([0-9]+) rooms,.*/\1/p' "$tmp/gen-lamps.txt")
tris=$(sed -nE 's/.* ([0-9]+) triangles,.*/\1/p' "$tmp/gen.txt")
grep -q " $tris triangles, $((2 * rooms + 1)) point lights and a sun" "$tmp/gen-lamps.txt"

# Every box: 12 triangles wound counter-clockwise from outside, their normals the stored ones and
# pointing away from the box's centre; each mesh's directed edges pair up (closed); no two
# boxes overlap. The lights: a sun and point lights inside the building.
python3 - "$tmp/a.glb" "$tmp/m.glb" "$tmp/a.gltf" <<'PY'
import array, collections, json, os, struct, sys

def load(path):
    if path.endswith(".gltf"):
        doc = json.load(open(path))
        blob = open(os.path.join(os.path.dirname(path), doc["buffers"][0]["uri"]), "rb").read()
        return doc, blob
    d = open(path, "rb").read()
    magic, version, total = struct.unpack("<III", d[:12])
    assert magic == 0x46546C67 and version == 2 and total == len(d), path
    jl, jt = struct.unpack("<II", d[12:20])
    assert jt == 0x4E4F534A and jl % 4 == 0
    doc = json.loads(d[20:20 + jl])
    bl, bt = struct.unpack("<II", d[20 + jl:28 + jl])
    assert bt == 0x004E4942 and 28 + jl + bl == len(d)
    return doc, d[28 + jl:28 + jl + bl]

for path in sys.argv[1:]:
    doc, blob = load(path)
    assert doc["buffers"][0]["byteLength"] == len(blob), path

    def acc(i, code):
        a = doc["accessors"][i]
        v = doc["bufferViews"][a["bufferView"]]
        out = array.array(code)
        out.frombytes(blob[v["byteOffset"]:v["byteOffset"] + v["byteLength"]])
        if sys.byteorder != "little":
            out.byteswap()
        return out

    boxes, tris = [], 0
    for m in doc["meshes"]:
        p = m["primitives"][0]
        P = acc(p["attributes"]["POSITION"], "f")
        N = acc(p["attributes"]["NORMAL"], "f")
        I = acc(p["indices"], "I")
        assert len(I) % 36 == 0 and len(P) == len(I) // 36 * 72 == len(N), m["name"]
        vert = lambda k: (P[3 * k], P[3 * k + 1], P[3 * k + 2])
        edges = collections.Counter()
        for b in range(len(I) // 36):
            vs = [vert(k) for k in range(24 * b, 24 * b + 24)]
            centre = [sum(v[a] for v in vs) / 24 for a in range(3)]
            boxes.append((tuple(min(v[a] for v in vs) for a in range(3)),
                          tuple(max(v[a] for v in vs) for a in range(3))))
            for t in range(12):
                ks = I[36 * b + 3 * t:36 * b + 3 * t + 3]
                a, c, e = (vert(k) for k in ks)
                u = [c[q] - a[q] for q in range(3)]
                w = [e[q] - a[q] for q in range(3)]
                n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
                stored = (N[3 * ks[0]], N[3 * ks[0] + 1], N[3 * ks[0] + 2])
                assert sum(n[q] * stored[q] for q in range(3)) > 0, (path, m["name"], b, t)
                mid = [(a[q] + c[q] + e[q]) / 3 - centre[q] for q in range(3)]
                assert sum(mid[q] * stored[q] for q in range(3)) > 0, (path, m["name"], b, t)
                for x, y in ((a, c), (c, e), (e, a)):
                    edges[(x, y)] += 1
            tris += 12
        for (x, y), k in edges.items():
            assert edges.get((y, x), 0) == k, (path, m["name"], "open edge", x, y)
    cells = collections.defaultdict(list)
    for i, (lo, hi) in enumerate(boxes):
        for cx in range(int(lo[0] // 2), int(hi[0] // 2) + 1):
            for cy in range(int(lo[1] // 2), int(hi[1] // 2) + 1):
                for cz in range(int(lo[2] // 2), int(hi[2] // 2) + 1):
                    cells[(cx, cy, cz)].append(i)
    for ids in cells.values():
        for x in range(len(ids)):
            for y in range(x + 1, len(ids)):
                A, B = boxes[ids[x]], boxes[ids[y]]
                assert not all(A[0][q] < B[1][q] - 1e-4 and B[0][q] < A[1][q] - 1e-4
                               for q in range(3)), (path, "overlap", A, B)
    lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
    assert lights[0]["type"] == "directional" and len(lights) >= 2, path
    lo = [min(b[0][a] for b in boxes) for a in range(3)]
    hi = [max(b[1][a] for b in boxes) for a in range(3)]
    for node in doc["nodes"]:
        if "translation" in node:
            assert all(lo[a] < node["translation"][a] < hi[a] for a in range(3)), node
    print(path, tris, "triangles in", len(boxes), "closed boxes,", len(lights), "lights")
PY

# It loads: a point in the corridor is valid and lit, one inside the north outer wall is not.
printf '13 1.8 7\n13 1.8 0.15\n' >"$tmp/pts.txt"
"$cli" capture "$tmp/a.glb" --points "$tmp/pts.txt" --spp 128 "${sky[@]}" >"$tmp/cap.json"
python3 - "$tmp/cap.json" <<'PY'
import json, sys
corridor, wall = json.load(open(sys.argv[1]))
assert corridor["validity"] > 0.9 and corridor["irradiance"]["+y"][0] > 0, corridor
assert wall["validity"] < 0.5, wall
PY

# Place (greedy), bake and eval of the small level (the time is printed;
# speed is measured in benchmarks, not here).
start=$SECONDS
"$cli" place "$tmp/a.glb" --method greedy --budget 32 --field-depth 1 --field-spp 32 \
  --probe-spp 32 --held-out 32 --accept "${sky[@]}" -o "$tmp/set.json" | tee "$tmp/place.out"
"$cli" bake "$tmp/set.json" -o "$tmp/v.psv" --spp 128
"$cli" eval "$tmp/v.psv" --queries 128 --reference-spp 256 --json >"$tmp/eval.json"
took=$((SECONDS - start))
echo "small level: place, bake and eval in $took s"
# The default domain (no --domain): the reachable space at the rule's 0.25 m cell, no note.
grep -Eq "^reachable domain: .*\(interior; .*\), 0\.25 m cells, " "$tmp/place.out" ||
  { echo "FAIL: place's default domain is not the reachable space at 0.25 m"; exit 1; }
if grep -q "coarser than" "$tmp/place.out"; then echo "FAIL: a coarser cell on the small level"; exit 1; fi
python3 - "$tmp" <<'PY'
import json, math, sys
tmp = sys.argv[1]
s = json.load(open(f"{tmp}/set.json"))
# The covering (a probe in each room, the hull's corners), then greedy to the budget.
greedy = [p for p in s["probes"] if p["method"] == "greedy"]
covering = [p for p in s["probes"] if p["method"] == "coverage"]
assert len(covering) >= 8 and len(greedy) + len(covering) == len(s["probes"]) == 32, s["probes"]
assert s["rig"]["sky_radiance"] == [0.2, 0.25, 0.35], s["rig"]
for p in s["probes"]:  # in the building (a window's opening too), between floor and ceiling
    x, y, z = p["position"]
    assert 0 < x < 26 and 0.3 < y < 3.5 and 0 < z < 14, p
e = json.load(open(f"{tmp}/eval.json"))
assert e["probes"] >= len(s["probes"]) and e["queries"] == 128, e
# 128 queries resolve rel_rmse poorly on this level (0.22 to 1.58 over placement and eval seeds
# 1 to 4, its heavy tail near the lamps), its RMS in stops well (1.02 to 1.19): the bound is
# on the stops, about 1.7 times the largest seen.
assert math.isfinite(e["rel_rmse"]) and e["rel_rmse"] > 0, e
assert 0 < e["stops"]["rms"] < 2.0, e
PY

# Regional greedy on the small level: exactly the budget, the same bytes run after run, every
# region with probes.
start=$SECONDS
for run in 1 2; do
  "$cli" place "$tmp/a.glb" --method greedy --budget 48 --regions 4 --field-depth 1 \
    --field-spp 32 --probe-spp 32 --held-out 32 --swap-passes 1 "${sky[@]}" \
    -o "$tmp/regional$run.json" >"$tmp/regional$run.out" 2>&1
done
took=$((SECONDS - start))
echo "small level: regional greedy twice in $took s"
cmp "$tmp/regional1.json" "$tmp/regional2.json" || { echo "FAIL: regional greedy differs between runs"; exit 1; }
grep -q "greedy: 4 regions of the dense field" "$tmp/regional1.out" || { cat "$tmp/regional1.out"; exit 1; }
python3 - "$tmp/regional1.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
greedy = [p for p in s["probes"] if p["method"] == "greedy"]
covering = [p for p in s["probes"] if p["method"] == "coverage"]
assert len(greedy) + len(covering) == len(s["probes"]) == 48, len(s["probes"])
assert len({tuple(p["position"]) for p in s["probes"]}) == 48, "a position twice"
PY

fail=0
expect_error() {  # expect_error "expected text" cmd...: exit 1, one line on stderr naming it
  local expected="$1"; shift
  local code=0
  "$@" >"$tmp/out" 2>"$tmp/err" || code=$?
  if [ "$code" -ne 1 ] || ! grep -qF -- "$expected" "$tmp/err" || [ "$(wc -l <"$tmp/err")" -ne 1 ]; then
    echo "FAIL: $* -> exit $code: $(cat "$tmp/err")"; fail=1
  fi
}
expect_error "--floors: expected 1 to 20, got 0" "${gen[@]}" --floors 0 -o "$tmp/x.glb"
expect_error "--width: expected 12 to 1000 m, got 5" "${gen[@]}" --width 5 -o "$tmp/x.glb"
expect_error "--depth: expected 12.8 to 400 m, got nan" "${gen[@]}" --depth nan -o "$tmp/x.glb"
expect_error "--seed: expected 0 to 2^63 - 1, got -1" "${gen[@]}" --seed -1 -o "$tmp/x.glb"
expect_error "--output: expected a .glb or .gltf file name, got \"$tmp/x.obj\"" "${gen[@]}" -o "$tmp/x.obj"
expect_error "--output: the folder \"$tmp/missing\" does not exist" "${gen[@]}" -o "$tmp/missing/x.glb"
test ! -e "$tmp/x.glb" || { echo "FAIL: a refused level was written"; fail=1; }

# A scene with no room for a probe (one solid block filling its bounds) is refused at once
# instead of searching ever finer grids, by every method.
python3 - "$root/scripts" "$tmp/solid.gltf" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import make_scenes
b = make_scenes.GltfBuilder("solid")
b.material("w", [0.8, 0.8, 0.8])
b.box("block", [-2, 0, -2], [2, 3, 2], "w")
b.write(sys.argv[2])
PY
for method in uniform greedy; do
  start=$SECONDS
  expect_error "$tmp/solid.gltf: no valid space for probes: 8000 random points of the scene's bounds are all inside geometry" \
    "$cli" place "$tmp/solid.gltf" --method "$method" --budget 16 "${sky[@]}" -o "$tmp/x.json"
  [ $((SECONDS - start)) -lt 30 ] || { echo "FAIL: $method took $((SECONDS - start)) s to refuse"; fail=1; }
done
test ! -e "$tmp/x.json" || { echo "FAIL: a refused place wrote its output"; fail=1; }

# A greedy budget beyond the dense field's samples (beside the 16 covering probes) is refused before any
# trial, naming them.
expect_error "--budget: expected at most 185 probes: the dense field has 169 samples to place new probes on" \
  "$cli" place "$tmp/a.glb" --method greedy --budget 400 --field-depth 0 --field-spp 16 \
  --held-out 0 --probe-spp 16 --swap-passes 0 "${sky[@]}" -o "$tmp/over.json"
test ! -e "$tmp/over.json" || { echo "FAIL: a refused budget wrote its output"; fail=1; }
expect_error '--regions: expected auto, off or a region count from 2 to 4096, got "many"' \
  "$cli" place "$tmp/a.glb" --method greedy --budget 64 --regions many "${sky[@]}" -o "$tmp/over.json"
expect_error "--regions: 16 regions need at least 8 new probes each; the budget leaves 64" \
  "$cli" place "$tmp/a.glb" --method greedy --budget 64 --regions 16 "${sky[@]}" -o "$tmp/over.json"
exit $fail
