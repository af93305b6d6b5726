#!/usr/bin/env bash
# Crash recovery end to end (label "ui"): a real editor under Xvfb proposes candidates and
# accepts them (unsaved work), autosaves, and is killed with SIGKILL; the next start recovers it.
# usage: test_recovery.sh EDITOR SOURCE_DIR
set -euo pipefail
editor=$1 src=$2
scene="$src/resources/scenes/two-rooms.gltf"
[ -f "$scene" ] || { echo "SKIP   : test_recovery.sh: $scene not present"; exit 0; }
tmp=$(mktemp -d)
pid=
cleanup() {
  if [ -n "$pid" ]; then kill -9 "$pid" 2> /dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
export LIBGL_ALWAYS_SOFTWARE=1
rec="$tmp/recovery"

# The session that crashes: started in the background; its own pid is written to a file.
xvfb-run -a -s "-screen 0 1280x1024x24" sh -c \
  '"$1" "$2" --accept-proposal --recovery-dir "$3" --autosave-ms 200 & echo $! > "$4"; wait' \
  sh "$editor" "$scene" "$rec" "$tmp/pid" > "$tmp/crashed.log" 2>&1 &
for _ in $(seq 1 600); do
  if ls "$rec"/session-*.probes.json > /dev/null 2>&1; then break; fi
  sleep 0.1
done
ls "$rec"/session-*.probes.json > /dev/null 2>&1 || {
  echo "FAIL: no autosave within 60 s"
  cat "$tmp/crashed.log"
  exit 1
}
sleep 0.5  # let the write that made the file finish (it is atomic: a rename)
pid=$(cat "$tmp/pid")
kill -9 "$pid"
wait || true
pid=
ls "$rec"/session-*.probes.json > /dev/null || { echo "FAIL: the crash removed the file"; exit 1; }

# The next start recovers it.
xvfb-run -a -s "-screen 0 1280x1024x24" "$editor" --recovery-dir "$rec" --recover \
  --screenshot "$tmp/recovered.png" 2> "$tmp/recover.log" || {
  echo "FAIL: recovery"
  cat "$tmp/recover.log"
  exit 1
}
python3 - "$tmp/recovered.png.json" << 'PY'
import json, sys
d = json.load(open(sys.argv[1]))
n = len(d["probes"])
assert n >= 20, f"recovered {n} probes"
assert d["modified"], "the recovered work must be marked unsaved"
accepted = sum(p["state"] == "accepted" for p in d["probes"])
assert accepted >= 20, f"recovered {accepted} accepted probes"
print(f"recovered {n} probes, marked unsaved")
PY
if ls "$rec"/session-*.probes.json > /dev/null 2>&1; then
  echo "FAIL: recovery files left behind"
  exit 1
fi
echo "test_recovery: OK"
