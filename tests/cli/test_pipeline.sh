#!/usr/bin/env bash
# The whole pipeline through the CLI on a bundled scene: place -> bake -> eval -> info -> query,
# plus capture and tetra, checking the shape and sanity of every output.
# Usage: test_pipeline.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
scene="$root/resources/scenes/cornell.gltf"

"$cli" place "$scene" --budget 40 --accept -o "$tmp/set.json"
"$cli" bake "$tmp/set.json" -o "$tmp/v.psv" --spp 128
# Re-baking the unchanged set takes every probe from the capture cache and gives the same volume.
"$cli" bake "$tmp/set.json" -o "$tmp/v2.psv" --spp 128 | grep -q "(0 captured, "
cmp "$tmp/v.psv" "$tmp/v2.psv"
# Adaptive bake: a target error instead of a fixed count; not the fixed bake's cache entries.
"$cli" bake "$tmp/set.json" -o "$tmp/v3.psv" --target-error 0.1 --max-spp 1024 |
  grep -q "([0-9]* captured, 0 from the cache).*target error 0.1 (at most 1024 spp)"
"$cli" info "$tmp/set.json" | grep -q "matches the scene"
# The bake records a visibility map per probe (volume format version 4); eval reads the volume
# through them unless --no-visibility.
"$cli" info "$tmp/v.psv" | grep -q "format version 4"
"$cli" info "$tmp/v.psv" | grep -q "visibility maps: 16x16 texels per probe"
"$cli" eval "$tmp/v.psv" --queries 64 --reference-spp 16 --no-cache --json | grep -q '"visibility": true'
"$cli" eval "$tmp/v.psv" --queries 64 --reference-spp 16 --no-cache --json --no-visibility |
  grep -q '"visibility": false'
# Least-squares fit: the same probes and tetrahedra, other values, said on stdout and recorded
# in the volume's metadata; the same bake twice gives the same file.
"$cli" bake "$tmp/set.json" -o "$tmp/vfit.psv" --spp 128 --fit --fit-points 16 \
  --fit-spp 32 >"$tmp/fit.log"
grep -q "least-squares fit: [0-9]* points at 32 spp" "$tmp/fit.log"
"$cli" bake "$tmp/set.json" -o "$tmp/vfit2.psv" --spp 128 --fit --fit-points 16 \
  --fit-spp 32 >/dev/null
cmp "$tmp/vfit.psv" "$tmp/vfit2.psv"
# Same probes, tetrahedra and hull; other irradiance at a point inside.
[ "$("$cli" info "$tmp/v.psv" | sed -n 2p)" = "$("$cli" info "$tmp/vfit.psv" | sed -n 2p)" ]
if [ "$("$cli" query "$tmp/v.psv" --at 0,2.5,0 --json)" = "$("$cli" query "$tmp/vfit.psv" --at 0,2.5,0 --json)" ]; then
  echo "FAIL: the fitted volume gives the same irradiance as the captured one"; exit 1
fi
"$cli" info "$tmp/vfit.psv" | grep -q "values fitted by least squares"
"$cli" eval "$tmp/v.psv" --queries 32 --reference-spp 256 --json --per-query "$tmp/eval.csv" >"$tmp/eval.json"
"$cli" info "$tmp/set.json" | grep -q "accepted"
"$cli" info "$tmp/v.psv" | grep -q "probe volume"
"$cli" query "$tmp/v.psv" --at 0.1,0.5,0.1 --normal 0,1,0 --json >"$tmp/q.json"
"$cli" query "$tmp/v.psv" --at 100,100,100 --json >"$tmp/qfar.json"
"$cli" capture "$scene" --at 0,0.5,0 --spp 256 --json >"$tmp/cap.json"
"$cli" capture "$root/resources/scenes/pillar-room.gltf" --at 0,1,0 --spp 64 --virtual-offset --json >"$tmp/cap-vo.json"
"$cli" capture "$scene" --at 0,0.5,0 --target-error 0.05 --max-spp 4096 --histograms --json >"$tmp/cap-adaptive.json"
printf '0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n0 0 0\n' >"$tmp/pts.txt"
"$cli" tetra "$tmp/pts.txt" -o "$tmp/tets.json"

python3 - "$tmp" <<'PY'
import json, math, sys
tmp = sys.argv[1]
s = json.load(open(f"{tmp}/set.json"))
n = len(s["probes"])
assert 36 <= n <= 44, f"budget 40 gave {n} probes"
assert s["version"] == 3 and s["units"] == "m" and len(s["scene_hash"]) == 16 and s["scene"].endswith("cornell.gltf")
e = json.load(open(f"{tmp}/eval.json"))
assert e["probes"] == n and e["queries"] == 32
for k in ("rel_rmse", "p95_rel_error", "max_rel_error", "seconds"):
    assert math.isfinite(e[k]) and e[k] >= 0, (k, e[k])
assert e["rel_rmse"] < 1.0, e
# --per-query: every query, and its errors give back the JSON's rel_rmse and leaking fraction.
import csv
rows = list(csv.DictReader(open(f"{tmp}/eval.csv")))
assert len(rows) == 32 and list(rows[0]) == ["x", "y", "z", "nx", "ny", "nz", "reference",
                                             "reference_std", "interpolated", "rel_error",
                                             "leaking", "outside", "stops"], rows[0]
num = sum((float(r["interpolated"]) - float(r["reference"])) ** 2 for r in rows)
den = sum(float(r["reference"]) ** 2 for r in rows)
assert abs(math.sqrt(num / den) - e["rel_rmse"]) < 1e-6 * e["rel_rmse"] + 1e-9, (num, den, e)
assert sum(int(r["leaking"]) for r in rows) / 32 == e["leaking_fraction"], e
# And which queries are outside the probes' hull, and of them which leak.
assert sum(int(r["outside"]) for r in rows) / 32 == e["outside_hull_fraction"], e
assert sum(int(r["leaking"]) * int(r["outside"]) for r in rows) / 32 == \
    e["leaking_outside_hull_fraction"], e
assert 0 <= e["leaking_outside_hull_fraction"] <= e["leaking_fraction"], e
# The reference's noise: the standard errors sum to the JSON's reference_rel_noise.
noise = math.sqrt(sum(float(r["reference_std"]) ** 2 for r in rows) / den)
assert abs(noise - e["reference_rel_noise"]) < 1e-4 * e["reference_rel_noise"] + 1e-9, (noise, e)
assert 0 < e["reference_rel_noise"] < 1, e
assert 0 < e["rel_rmse_std_error"] < e["rel_rmse"], e
rel = sorted(float(r["rel_error"]) for r in rows)
assert abs(rel[math.ceil(0.95 * 32) - 1] - e["p95_rel_error"]) <= 1e-5 * e["p95_rel_error"], (rel, e)
assert abs(rel[-1] - e["max_rel_error"]) <= 1e-5 * e["max_rel_error"], (rel, e)
for r in rows:
    assert abs(math.hypot(float(r["nx"]), float(r["ny"]), float(r["nz"])) - 1) < 1e-4, r
# The perceptual error: each query's stops against the JSON's floor, summarised as the JSON says.
floor = e["stops"]["floor"]
refs = sorted(float(r["reference"]) for r in rows)
assert abs(floor - 0.05 * refs[math.ceil(0.5 * 32) - 1]) <= 1e-6 * floor, (floor, refs)
stops = []
for r in rows:
    want = abs(math.log2(max(float(r["interpolated"]), floor) / max(float(r["reference"]), floor)))
    assert abs(float(r["stops"]) - want) < 1e-4 * want + 1e-5, (r, want)
    stops.append(want)
assert abs(math.sqrt(sum(x * x for x in stops) / 32) - e["stops"]["rms"]) < 1e-4, e["stops"]
assert e["stops"]["queries"] == 32 and e["regions"] == [], e
# The reference's noise in stops, from the same standard errors.
want = math.sqrt(sum((float(r["reference_std"]) / (max(float(r["reference"]), floor) * math.log(2)))
                     ** 2 for r in rows) / 32)
assert abs(e["stops"]["reference_noise"] - want) < 1e-4 * want + 1e-6, (e["stops"], want)
assert 0 < want < 5, want
stops.sort()
assert abs(stops[math.ceil(0.9 * 32) - 1] - e["stops"]["p90"]) < 1e-4, (stops, e["stops"])
assert e["stops"]["beyond_third_stop"] == sum(x >= 1 / 3 for x in stops) / 32, e["stops"]
assert e["rooms"] == [], e["rooms"]  # the Cornell box is one room: no split to report
q = json.load(open(f"{tmp}/q.json"))[0]
assert q["tet"] >= 0 and abs(sum(q["weights"]) - 1) < 1e-5
assert all(c > 0 for c in q["irradiance"]), q
far = json.load(open(f"{tmp}/qfar.json"))[0]
assert far["outside"] is True and all(c >= 0 for c in far["irradiance"]) and sum(far["irradiance"]) > 0, far
cap = json.load(open(f"{tmp}/cap.json"))[0]
assert len(cap["sh"]) == 9 and len(cap["sh_std_error"]) == 9 and cap["samples"] == 256
assert set(cap["irradiance"]) == {"+x", "-x", "+y", "-y", "+z", "-z"}
assert cap["irradiance"]["+y"][0] > 0 and 0 <= cap["validity"] <= 1
assert list(cap) == ["position", "sh", "sh_std_error", "irradiance", "validity", "samples",
                     "seconds"], list(cap)
ad = json.load(open(f"{tmp}/cap-adaptive.json"))[0]
assert ad["samples"] % 64 == 0 and 64 <= ad["samples"] <= 4096, ad["samples"]
assert len(ad["luminance_histogram"]) == 16 and abs(sum(ad["luminance_histogram"]) - 1) < 1e-9
assert len(ad["hue_histogram"]) == 12
vo = json.load(open(f"{tmp}/cap-vo.json"))[0]  # (0, 1, 0) is inside pillar-room's pillar
assert vo["validity"] >= 0.75 and vo["position"] != [0, 1, 0], vo["position"]
t = json.load(open(f"{tmp}/tets.json"))
assert t["vertex_of_input"][5] == t["vertex_of_input"][0], "duplicate merged"
assert len(t["vertices"]) == 5 and len(t["tets"]) >= 2 and len(t["neighbors"]) == len(t["tets"])
print("pipeline ok:", n, "probes, rel_rmse", round(e["rel_rmse"], 4))
PY

# Rooms told apart without importance volumes: two-rooms' two rooms, each with its own error.
two="$root/resources/scenes/two-rooms.gltf"
"$cli" place "$two" --budget 32 --accept -o "$tmp/two.json" >/dev/null
"$cli" bake "$tmp/two.json" -o "$tmp/two.psv" --spp 16 --no-cache >/dev/null
"$cli" eval "$tmp/two.psv" --queries 256 --reference-spp 16 --json --per-query "$tmp/two.csv" \
  >"$tmp/two-eval.json"
"$cli" eval "$tmp/two.psv" --queries 256 --reference-spp 16 | grep -q "^  room 2: "
# query reads the volume as eval does: eval's queries, given to query with their normals.
python3 - "$tmp" <<'PY'
import csv, sys
tmp = sys.argv[1]
rows = list(csv.DictReader(open(f"{tmp}/two.csv")))
with open(f"{tmp}/two-points.txt", "w") as p, open(f"{tmp}/two-normals.txt", "w") as n:
    for r in rows:
        p.write(f'{r["x"]} {r["y"]} {r["z"]}\n')
        n.write(f'{r["nx"]} {r["ny"]} {r["nz"]}\n')
PY
"$cli" query "$tmp/two.psv" --points "$tmp/two-points.txt" --normals "$tmp/two-normals.txt" \
  --json >"$tmp/two-query.json"
"$cli" query "$tmp/two.psv" --points "$tmp/two-points.txt" --normals "$tmp/two-normals.txt" \
  --no-visibility --json >"$tmp/two-query-bary.json"
python3 - "$tmp" <<'PY'
import csv, json, sys
tmp = sys.argv[1]
e = json.load(open(f"{tmp}/two-eval.json"))
rooms = e["rooms"]
assert [r["name"] for r in rooms] == ["room 1", "room 2"], rooms
assert abs(rooms[0]["volume_m3"] - rooms[1]["volume_m3"]) < 0.1 * rooms[1]["volume_m3"], rooms
# The rooms are x < 0 and x > 0; their queries are those of their side, and the dim one (the
# point light is in A) has the lower mean.
rows = list(csv.DictReader(open(f"{tmp}/two.csv")))
sides = [sum(float(r["x"]) < 0 for r in rows), sum(float(r["x"]) > 0 for r in rows)]
counts = sorted(r["stops"]["queries"] for r in rooms)
assert all(abs(c - s) <= 0.05 * 256 for c, s in zip(counts, sorted(sides))), (counts, sides)
means = sorted(r["mean_reference"] for r in rooms)
assert means[0] < 0.5 * means[1], rooms
print("rooms ok:", [(r["name"], r["stops"]["queries"], round(r["stops"]["rms"], 3)) for r in rooms])
# query's irradiance at eval's query points is eval's interpolated value. The CSV keeps 6
# significant digits of each position, a few micrometres here: a point that close to where the
# neighbour search starts or ends may read another blend, so 95 % must agree.
q = json.load(open(f"{tmp}/two-query.json"))
qb = json.load(open(f"{tmp}/two-query-bary.json"))
assert len(q) == len(qb) == len(rows) == 256
lum = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
agree = sum(abs(lum(a["irradiance"]) - float(r["interpolated"])) <= 1e-3 * abs(float(r["interpolated"])) + 1e-9
            for a, r in zip(q, rows))
assert agree >= 0.95 * len(rows), agree
for a, b in zip(q, qb):
    assert a["interpolant"] == "visible" and b["interpolant"] == "barycentric", (a, b)
    assert a["fallback"] in ("none", "visibility", "neighbours", "barycentric"), a
    assert len(a["probes"]) == len(a["weights"]) and abs(sum(a["weights"]) - 1) < 1e-6, a
    assert len(b["weights"]) == 4 and abs(sum(b["weights"]) - 1) < 1e-6, b
# The visibility maps change the light where a tetrahedron spans the wall between the rooms.
assert sum(abs(lum(a["irradiance"]) - lum(b["irradiance"])) > 1e-3 * lum(b["irradiance"])
           for a, b in zip(q, qb)) > 0
print("query agrees with eval at", agree, "of 256 points")
PY
