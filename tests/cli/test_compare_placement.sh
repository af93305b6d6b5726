#!/usr/bin/env bash
# scripts/compare-placement at one small budget on cornell: a row per method (a NAME:OBJECTIVE
# method as greedy with that objective) with every column,
# the reference's noise, the leaking fraction and the scene's SH floor among them, and no plots
# (PLOTS=0); the floor captured once per scene; on two-rooms without the floor (FLOOR=0).
# Usage: test_compare_placement.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
PROBESTUDIO="$cli" SCENES=cornell METHODS="uniform greedy:energy" QUERIES=64 REFERENCE_SPP=256 \
  BAKE_SPP=64 PLOTS=0 EVAL_CACHE="$tmp/cache" \
  "$root/scripts/compare-placement" "$tmp/p.csv" 16 >"$tmp/log" 2>&1 || { cat "$tmp/log"; exit 1; }
python3 - "$tmp/p.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert [r["method"] for r in rows] == ["uniform", "greedy:energy"], rows
for r in rows:
    assert list(r) == ["scene", "method", "budget", "probes", "place_seconds", "rel_rmse", "p95",
                       "max", "reference_noise", "rel_rmse_std_error", "leaking_fraction",
                       "leaking_outside_hull", "outside_hull", "sh_floor", "rms_stops",
                       "p90_stops", "beyond_third_stop", "reference_noise_stops"], r
    assert all(r[k] for k in r), r
    assert 0 <= float(r["leaking_fraction"]) <= 1, r
    assert 0 <= float(r["leaking_outside_hull"]) <= float(r["leaking_fraction"]), r
    assert 0 < float(r["outside_hull"]) < 1, r
    # 256 samples on cornell: noisy, but the volumes are wrong by more than the reference is.
    assert 0 < float(r["reference_noise"]) < float(r["rel_rmse"]) < 1.5, r
    assert 0 < float(r["rel_rmse_std_error"]) < float(r["rel_rmse"]), r
    assert abs(int(r["probes"]) - 16) <= 3, r  # the uniform grid's count is coarse at 16
    # The scene's SH floor, from the first row's eval, in every row (at 64 spp, mostly noise).
    assert float(r["sh_floor"]) > 0 and r["sh_floor"] == rows[0]["sh_floor"], r
    # The perceptual error in stops: measured over eval seeds 7 to 11, RMS 2.62 to 3.21 and p90
    # 4.37 to 5.30 stops for both methods (16 probes, 64 queries); the bounds are about 1.5 times
    # the largest.
    assert 0 < float(r["p90_stops"]) < 8 and 0 < float(r["rms_stops"]) < 5, r
    assert 0 <= float(r["beyond_third_stop"]) <= 1, r
PY
[ ! -e "$tmp/p-error-vs-probes.png" ]
# The floor is captured once per scene (its first row's eval), through a probestudio that logs
# its arguments; every row of a scene holds its floor.
printf '#!/usr/bin/env bash\nprintf "%%s\\n" "$*" >>"%s"\nexec "%s" "$@"\n' "$tmp/calls" "$cli" \
  >"$tmp/logged-probestudio"
chmod +x "$tmp/logged-probestudio"
PROBESTUDIO="$tmp/logged-probestudio" SCENES="cornell two-rooms" METHODS=uniform QUERIES=64 \
  REFERENCE_SPP=16 BAKE_SPP=16 PLOTS=0 EVAL_CACHE="$tmp/cache" \
  "$root/scripts/compare-placement" "$tmp/f.csv" 16 32 >"$tmp/log" 2>&1 || { cat "$tmp/log"; exit 1; }
[ "$(grep -c '^eval .* --floor-spp 16$' "$tmp/calls")" = 2 ] || { cat "$tmp/calls"; exit 1; }
[ "$(grep -c '^eval ' "$tmp/calls")" = 4 ]
python3 - "$tmp/f.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert [r["scene"] for r in rows] == ["cornell"] * 2 + ["two-rooms"] * 2, rows
for a, b in (rows[0:2], rows[2:4]):
    assert float(a["sh_floor"]) > 0 and a["sh_floor"] == b["sh_floor"], (a, b)
assert rows[0]["sh_floor"] != rows[2]["sh_floor"], rows
PY
PROBESTUDIO="$cli" SCENES=two-rooms METHODS=uniform QUERIES=256 REFERENCE_SPP=16 BAKE_SPP=16 \
  PLOTS=0 EVAL_CACHE="$tmp/cache" FLOOR=0 \
  "$root/scripts/compare-placement" "$tmp/c.csv" 16 >"$tmp/log" 2>&1 || { cat "$tmp/log"; exit 1; }
python3 - "$tmp/c.csv" <<'PY'
import csv, sys
row = list(csv.DictReader(open(sys.argv[1])))[0]
assert row["sh_floor"] == "", row  # FLOOR=0
assert 0 <= float(row["leaking_fraction"]) <= 1, row
PY
