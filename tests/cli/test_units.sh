#!/usr/bin/env bash
# Scene units: two-rooms in centimetres and millimetres (scripts/make_scenes.py --unit-copies),
# read with --units, give the metre scene's probes scaled by 100 and 1000 (place), the same
# volume in their unit (bake) and the same error and rooms (eval) without --units repeated; the
# unit hint appears for a scene whose size says cm or mm and for no scene in metres; a malformed
# unit is refused naming the flag or the file's field.
# Usage: test_units.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
python3 "$root/scripts/make_scenes.py" --unit-copies "$tmp/scenes" >/dev/null
m="$tmp/scenes/two-rooms.gltf"; cm="$tmp/scenes/two-rooms-cm.gltf"; mm="$tmp/scenes/two-rooms-mm.gltf"

# The hint: one line for the mm and cm copies read as metres, none with --units, none for the
# metre scene, none for the generated 200 m level (14 m tall).
"$cli" capture "$mm" --at 0,1500,0 --spp 16 >/dev/null 2>"$tmp/hint-mm.txt"
cat "$tmp/hint-mm.txt"
[ "$(wc -l <"$tmp/hint-mm.txt")" -eq 1 ]
grep -q "^warning: .*two-rooms-mm.gltf is 12500 units across and 3400 tall; if it is in millimetres, pass --units mm$" "$tmp/hint-mm.txt"
"$cli" capture "$cm" --at 0,150,0 --spp 16 >/dev/null 2>"$tmp/hint-cm.txt"
grep -q "two-rooms-cm.gltf is 1250 units across and 340 tall; if it is in centimetres, pass --units cm$" "$tmp/hint-cm.txt"
for run in "$m --at 0,1.5,0" "$mm --at 0,1500,0 --units mm" "$cm --at 0,150,0 --units cm"; do
  # shellcheck disable=SC2086
  "$cli" capture $run --spp 16 >/dev/null 2>"$tmp/quiet.txt"
  if [ -s "$tmp/quiet.txt" ]; then echo "FAIL: unexpected stderr for $run:"; cat "$tmp/quiet.txt"; exit 1; fi
done
python3 "$root/scripts/make_level.py" --preset full -o "$tmp/level.glb" >/dev/null
"$cli" capture "$tmp/level.glb" --at 10,1.5,10 --spp 4 >/dev/null 2>"$tmp/level.txt"
if grep -q "units" "$tmp/level.txt"; then echo "FAIL: the level in metres is flagged"; cat "$tmp/level.txt"; exit 1; fi

# capture: --at and "position" in the scene's unit; the same light at the same place.
"$cli" capture "$m" --at -3,1.2,0.5 --spp 64 --seed 3 >"$tmp/cap-m.json"
"$cli" capture "$mm" --units mm --at -3000,1200,500 --spp 64 --seed 3 >"$tmp/cap-mm.json"

# place: uniform and greedy with a small budget, in metres, mm (also as --units 0.001) and cm.
uni=(--method uniform --budget 64 --accept)
gre=(--method greedy --budget 12 --field-depth 1 --field-spp 32 --held-out 32 --swap-passes 0 --accept)
"$cli" place "$m" "${uni[@]}" -o "$tmp/u-m.json" >/dev/null
"$cli" place "$mm" --units mm "${uni[@]}" -o "$tmp/u-mm.json" >/dev/null
"$cli" place "$mm" --units 0.001 "${uni[@]}" -o "$tmp/u-mm2.json" >/dev/null
"$cli" place "$cm" --units cm "${uni[@]}" -o "$tmp/u-cm.json" >/dev/null
"$cli" place "$m" "${gre[@]}" -o "$tmp/g-m.json" >/dev/null
"$cli" place "$mm" --units mm "${gre[@]}" -o "$tmp/g-mm.json" >/dev/null
"$cli" info "$tmp/u-mm.json" | grep -q "in units mm"
python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
def positions(name):
    s = json.load(open(f"{tmp}/{name}.json"))
    return s, [p["position"] for p in s["probes"]]
for a, b, k in (("u-m", "u-mm", 1000), ("u-m", "u-mm2", 1000), ("u-m", "u-cm", 100), ("g-m", "g-mm", 1000)):
    sa, pa = positions(a)
    sb, pb = positions(b)
    assert sa["units"] == "m" and sb["units"] == ("mm" if k == 1000 else "cm"), (sa["units"], sb["units"])
    assert sb["placement"] == sa["placement"], (sa["placement"], sb["placement"])  # spacing_m in metres
    assert len(pa) == len(pb), (a, b, len(pa), len(pb))
    # Relative to the coordinate, or to 1 m where a coordinate is nearer 0.
    dev = max(abs(y - k * x) / max(abs(k * x), k) for p, q in zip(pa, pb) for x, y in zip(p, q))
    print(f"place {b} vs {a} x {k}: {len(pa)} probes, max relative deviation {dev:.3g}")
    assert dev < 1e-6, dev
c = {n: json.load(open(f"{tmp}/cap-{n}.json"))[0] for n in ("m", "mm")}
assert c["mm"]["position"] == [-3000, 1200, 500], c["mm"]["position"]
for axis, e in c["m"]["irradiance"].items():
    f = c["mm"]["irradiance"][axis]
    assert all(abs(x - y) <= 1e-3 * max(abs(x), 1e-3) for x, y in zip(e, f)), (axis, e, f)
PY

# bake and eval read the unit the set was saved with: no --units downstream.
"$cli" bake "$tmp/u-m.json" --spp 256 --no-cache -o "$tmp/m.psv" >/dev/null
"$cli" bake "$tmp/u-mm.json" --spp 256 --no-cache -o "$tmp/mm.psv" >/dev/null 2>"$tmp/bake-mm.txt"
if [ -s "$tmp/bake-mm.txt" ]; then echo "FAIL: bake of the mm set warns"; cat "$tmp/bake-mm.txt"; exit 1; fi
"$cli" info "$tmp/mm.psv" | grep -q "in units mm"
ev=(--queries 256 --reference-spp 256 --seed 11 --no-cache --json)
"$cli" eval "$tmp/m.psv" "${ev[@]}" >"$tmp/e-m.json"
"$cli" eval "$tmp/mm.psv" "${ev[@]}" --per-query "$tmp/q-mm.csv" >"$tmp/e-mm.json"
# query: a point in mm in the mm volume is the point in metres in the metre volume.
"$cli" query "$tmp/m.psv" --at -3,1.2,0.5 --json >"$tmp/q-m.json"
"$cli" query "$tmp/mm.psv" --at -3000,1200,500 --json >"$tmp/q-mm.json"
python3 - "$tmp" <<'PY'
import json, struct, sys
tmp = sys.argv[1]
e = {n: json.load(open(f"{tmp}/e-{n}.json")) for n in ("m", "mm")}
print(f"eval rel_rmse m {e['m']['rel_rmse']:.6f}, mm {e['mm']['rel_rmse']:.6f}; stops "
      f"{e['m']['stops']['rms']:.6f}, {e['mm']['stops']['rms']:.6f}; rooms "
      f"{len(e['m']['rooms'])}, {len(e['mm']['rooms'])}")
assert abs(e["m"]["rel_rmse"] - e["mm"]["rel_rmse"]) <= 1e-3 * e["m"]["rel_rmse"], e
assert abs(e["m"]["stops"]["rms"] - e["mm"]["stops"]["rms"]) <= 1e-3 * e["m"]["stops"]["rms"]
assert len(e["m"]["rooms"]) == len(e["mm"]["rooms"]) == 2, (e["m"]["rooms"], e["mm"]["rooms"])
# The volume file holds positions in the scene's unit (version 4 header: 36 bytes).
def psv_positions(name):
    b = open(f"{tmp}/{name}.psv", "rb").read()
    P = struct.unpack_from("<I", b, 16)[0]
    return struct.unpack_from(f"<{3 * P}f", b, 36)
pm, pmm = psv_positions("m"), psv_positions("mm")
dev = max(abs(y - 1000 * x) / max(abs(1000 * x), 1000) for x, y in zip(pm, pmm))
print(f"volume positions mm vs m x 1000: max relative deviation {dev:.3g}")
assert len(pm) == len(pmm) and dev < 1e-6, dev
# --per-query positions in mm: inside the mm scene's bounds.
rows = [l.split(",") for l in open(f"{tmp}/q-mm.csv").read().splitlines()[1:]]
assert max(abs(float(r[0])) for r in rows) > 100, "per-query x is not in mm"
q = {n: json.load(open(f"{tmp}/q-{n}.json"))[0] for n in ("m", "mm")}
# (The two bakes may number their tetrahedra differently; the weights and light are the same.)
assert all(abs(a - b) < 1e-4 for a, b in zip(q["m"]["weights"], q["mm"]["weights"])), q
assert all(abs(a - b) <= 1e-4 * max(abs(a), 1e-3) for a, b in zip(q["m"]["irradiance"], q["mm"]["irradiance"])), q
PY

# Malformed units: the flag, a unit that contradicts the set's, and the file's field.
expect_error() {  # expect_error TEXT COMMAND...
  local text="$1"; shift
  if "$@" >"$tmp/out.txt" 2>"$tmp/err.txt"; then echo "FAIL: accepted: $*"; exit 1; fi
  grep -qF -- "$text" "$tmp/err.txt" || { echo "FAIL: expected \"$text\", got:"; cat "$tmp/err.txt"; exit 1; }
}
expect_error '--units: expected "m", "cm", "mm" or a positive number of metres per unit, got "furlong"' \
  "$cli" place "$m" --units furlong "${uni[@]}" -o "$tmp/x.json"
expect_error '--units: expected "m", "cm", "mm" or a positive number of metres per unit, got "-1"' \
  "$cli" capture "$m" --units=-1 --at 0,1,0
expect_error "--units: is cm, but $tmp/u-mm.json was saved in units \"mm\"" \
  "$cli" bake "$tmp/u-mm.json" --units cm -o "$tmp/x.psv"
sed 's/"units": "mm"/"units": "parsec"/' "$tmp/u-mm.json" >"$tmp/bad.json"
expect_error "$tmp/bad.json: units: expected \"m\", \"cm\", \"mm\" or a positive number of metres per unit, got \"parsec\"" \
  "$cli" bake "$tmp/bad.json" -o "$tmp/x.psv"
echo "units: OK"
