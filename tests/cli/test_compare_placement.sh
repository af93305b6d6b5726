#!/usr/bin/env bash
# scripts/compare-placement at one small budget on cornell: a row per method with every column,
# the reference's noise among them, and no plots (PLOTS=0).
# Usage: test_compare_placement.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"; root="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
PROBESTUDIO="$cli" SCENES=cornell METHODS="uniform greedy" QUERIES=64 REFERENCE_SPP=256 \
  BAKE_SPP=64 PLOTS=0 EVAL_CACHE="$tmp/cache" \
  "$root/scripts/compare-placement" "$tmp/p.csv" 16 >"$tmp/log" 2>&1 || { cat "$tmp/log"; exit 1; }
python3 - "$tmp/p.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert [r["method"] for r in rows] == ["uniform", "greedy"], rows
for r in rows:
    assert list(r) == ["scene", "method", "budget", "probes", "place_seconds", "rel_rmse", "p95",
                       "max", "reference_noise", "rel_rmse_std_error"], r
    assert all(r[k] for k in r), r
    # 256 samples on cornell: noisy, but the volumes are wrong by more than the reference is.
    assert 0 < float(r["reference_noise"]) < float(r["rel_rmse"]) < 1.5, r
    assert 0 < float(r["rel_rmse_std_error"]) < float(r["rel_rmse"]), r
    assert abs(int(r["probes"]) - 16) <= 3, r  # the uniform grid's count is coarse at 16
PY
[ ! -e "$tmp/p-error-vs-probes.png" ]
