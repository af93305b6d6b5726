#!/usr/bin/env bash
# eval's reference cache through the CLI on cornell: the first eval traces the reference and
# stores it in eval-reference-cache beside the input; a second eval, of the same volume or of
# another set placed with another method, reads it ("reference_cached": true) with identical
# numbers; --no-cache and another seed trace it; a corrupted entry is reported on stderr and
# recomputed to the same numbers.
# Usage: test_eval_cache.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
scene="$root/resources/scenes/cornell.gltf"
eval_opts=(--queries 48 --reference-spp 64 --json)

"$cli" place "$scene" --budget 16 --accept -o "$tmp/uniform.json"
"$cli" place "$scene" --method greedy --budget 16 --accept -o "$tmp/greedy.json"
"$cli" bake "$tmp/uniform.json" -o "$tmp/uniform.psv" --spp 64 --no-cache
"$cli" bake "$tmp/greedy.json" -o "$tmp/greedy.psv" --spp 64 --no-cache
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" >"$tmp/first.json"
ls "$tmp/eval-reference-cache/"*.psref >/dev/null
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" >"$tmp/second.json"
"$cli" eval "$tmp/greedy.psv" "${eval_opts[@]}" >"$tmp/greedy-cached.json"
"$cli" eval "$tmp/greedy.psv" "${eval_opts[@]}" --no-cache >"$tmp/greedy-nocache.json"
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" --seed 8 >"$tmp/seed8.json"
# --floor-spp adds the SH floor (a probe at every query) and the spp it used, and changes no
# other figure; without it neither key is there. Its own captures: another spp, another floor.
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" --floor-spp 16 >"$tmp/floor16.json"
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" --floor-spp 64 >"$tmp/floor64.json"
python3 - "$tmp/first.json" "$tmp/floor16.json" "$tmp/floor64.json" <<'PY'
import json, sys
a, b, c = (json.load(open(p)) for p in sys.argv[1:])
assert "sh_floor_rel_rmse" not in a and "floor_spp" not in a, a
assert b["floor_spp"] == 16 and c["floor_spp"] == 64, (b, c)
assert b["sh_floor_rel_rmse"] > 0 and c["sh_floor_rel_rmse"] > 0, (b, c)
assert b["sh_floor_rel_rmse"] != c["sh_floor_rel_rmse"], (b, c)
for k in a:
    if k not in ("seconds", "reference_cached"):
        assert b[k] == a[k] and c[k] == a[k], k
assert b["reference_cached"] and c["reference_cached"], (b, c)
PY
"$cli" eval "$tmp/uniform.psv" --queries 48 --reference-spp 64 --floor-spp 16 >"$tmp/floor.txt"
grep -q "^SH floor [0-9.]* (the relative RMS error of a probe at every query, captured at 16" "$tmp/floor.txt"
if "$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" --floor-spp -1 >/dev/null 2>"$tmp/floor.err"; then
  echo "eval --floor-spp -1 succeeded" >&2; exit 1
fi
grep -q "floor-spp" "$tmp/floor.err"
# Another cache folder starts empty.
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" --cache "$tmp/other-cache" >"$tmp/other.json"
[ "$(ls "$tmp/other-cache" | wc -l)" = 1 ]
# Corrupt every entry of the default folder (flip one byte in the middle).
for f in "$tmp/eval-reference-cache/"*.psref; do
  python3 - "$f" <<'PY'
import os, sys
p = sys.argv[1]
b = bytearray(open(p, "rb").read())
b[len(b) // 2] ^= 0x10
open(p, "wb").write(b)
PY
done
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" >"$tmp/repaired.json" 2>"$tmp/repaired.err"
grep -q "note: damaged reference cache entry .*CRC-32 mismatch" "$tmp/repaired.err"
"$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" >"$tmp/after.json" 2>"$tmp/after.err"
[ ! -s "$tmp/after.err" ] || ! grep -q "damaged" "$tmp/after.err"
# A cache folder that cannot be created is an error naming it.
echo x >"$tmp/a-file"
if "$cli" eval "$tmp/uniform.psv" "${eval_opts[@]}" --cache "$tmp/a-file/cache" \
    >/dev/null 2>"$tmp/bad.err"; then
  echo "eval with an uncreatable cache folder succeeded" >&2; exit 1
fi
grep -q "a-file/cache: cannot create the eval reference cache folder" "$tmp/bad.err"
# The default folder is a convenience: where it cannot be made, eval goes on without it.
mkdir "$tmp/blocked"
"$cli" bake "$tmp/uniform.json" -o "$tmp/blocked/uniform.psv" --spp 64 --no-cache
echo x >"$tmp/blocked/eval-reference-cache"
"$cli" eval "$tmp/blocked/uniform.psv" "${eval_opts[@]}" >"$tmp/blocked.json" 2>"$tmp/blocked.err"
grep -q "note: cannot create the reference cache folder" "$tmp/blocked.err"
# A set's importance volumes are eval's domain, for the set and for its baked volume (which
# carries them in its metadata): the second eval reads the reference the first one traced.
mkdir "$tmp/boxed"
python3 - "$tmp/uniform.json" "$tmp/boxed/boxed.json" <<'PY'
import json, os, sys
s = json.load(open(sys.argv[1]))
s["importance_volumes"] = [{"name": "left", "min": [-2.5, 3.5, -2.5], "max": [0, 5, 2.5],
                            "weight": 1.0}]
s["scene"] = os.path.relpath(os.path.join(os.path.dirname(sys.argv[1]), s["scene"]),
                             os.path.dirname(sys.argv[2]))
json.dump(s, open(sys.argv[2], "w"))
PY
"$cli" eval "$tmp/boxed/boxed.json" "${eval_opts[@]}" --spp 64 >"$tmp/boxed-set.json"
"$cli" bake "$tmp/boxed/boxed.json" -o "$tmp/boxed/boxed.psv" --spp 64 --no-cache
"$cli" eval "$tmp/boxed/boxed.psv" "${eval_opts[@]}" >"$tmp/boxed-volume.json"
# A hand-edited volume whose domain box is inside out is refused, naming the file and the field.
python3 - "$tmp/boxed/boxed.psv" "$tmp/boxed/bad-domain.psv" <<'PY'
import struct, sys, zlib
b = open(sys.argv[1], "rb").read()[:-4]
assert b.count(b'"min":[-2.5') == 1
b = b.replace(b'"min":[-2.5', b'"min":[ 2.5')  # same length: min x 2.5 > max x 0
open(sys.argv[2], "wb").write(b + struct.pack("<I", zlib.crc32(b)))
PY
if "$cli" eval "$tmp/boxed/bad-domain.psv" "${eval_opts[@]}" >/dev/null 2>"$tmp/bad-domain.err"; then
  echo "eval of a volume with an inside-out domain succeeded" >&2; exit 1
fi
grep -q "bad-domain.psv: metadata.domain\[0\]: expected min <= max on every axis" "$tmp/bad-domain.err"
# The plain-text output says where the reference came from.
"$cli" eval "$tmp/uniform.psv" --queries 48 --reference-spp 64 | grep -q "reference from the cache"

python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
e = {n: json.load(open(f"{tmp}/{n}.json")) for n in
     ("first", "second", "greedy-cached", "greedy-nocache", "seed8", "other", "repaired", "after",
      "blocked", "boxed-set", "boxed-volume")}
cached = {n: v["reference_cached"] for n, v in e.items()}
assert cached == {"first": False, "second": True, "greedy-cached": True,
                  "greedy-nocache": False, "seed8": False, "other": False,
                  "repaired": False, "after": True, "blocked": False, "boxed-set": False,
                  "boxed-volume": True}, cached
keys = ("probes", "queries", "rel_rmse", "p95_rel_error", "max_rel_error", "leaking_fraction")
same = lambda a, b: all(e[a][k] == e[b][k] for k in keys)
assert same("first", "second") and same("first", "other"), (e["first"], e["second"])
assert same("first", "repaired") and same("first", "after"), (e["first"], e["repaired"])
assert same("first", "blocked"), (e["first"], e["blocked"])
assert same("greedy-cached", "greedy-nocache"), (e["greedy-cached"], e["greedy-nocache"])
assert e["seed8"]["rel_rmse"] != e["first"]["rel_rmse"], e["seed8"]
print("eval reference cache ok: rel_rmse %.4f, cached eval %.3f s against %.3f s traced" %
      (e["first"]["rel_rmse"], e["second"]["seconds"], e["first"]["seconds"]))
PY
