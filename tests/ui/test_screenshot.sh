#!/usr/bin/env bash
# Screenshot test of the editor under Xvfb with Mesa's software GL (label "ui").
# usage: test_screenshot.sh EDITOR CHECKER SOURCE_DIR ARTIFACT_DIR
set -euo pipefail
editor=$1 checker=$2 src=$3 artifacts=$4
scene="$src/resources/scenes/two-rooms.gltf"
[ -f "$scene" ] || { echo "SKIP   : test_screenshot.sh: $scene not present"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export LIBGL_ALWAYS_SOFTWARE=1
run() { xvfb-run -a -s "-screen 0 1280x1024x24" "$editor" "$@"; }

run "$scene" --screenshot "$tmp/shot.png" --save-probes "$tmp/set.json"
# A probe set as the argument opens it with its scene: its own probes, no proposal, clean.
run "$tmp/set.json" --screenshot "$tmp/argset.png"
grep -q "\"probeSetPath\": \"$tmp/set.json\"" "$tmp/argset.png.json" ||
  { echo "FAIL: a probe set as the argument was not opened as the set"; exit 1; }
grep -q '"modified": false' "$tmp/argset.png.json" ||
  { echo "FAIL: a probe set just opened is marked unsaved"; exit 1; }
# The same view without probes, for the checker's before/after comparison.
run "$scene" --screenshot "$tmp/bare.png" --no-probes
mkdir -p "$artifacts"
cp "$tmp/shot.png" "$artifacts/editor-two-rooms.png"
cp "$tmp/shot.png.json" "$artifacts/editor-two-rooms.png.json"
"$checker" "$tmp/shot.png" "$tmp/bare.png"

# The saved probe set (with its quick SH) and the lighting overlays: gradient glyphs, the
# luminance-distance slice around probe 1, the test object; the same view without overlays.
run "$scene" --probes "$tmp/set.json" --select 1 --overlays glyphs,slice,test-object \
  --screenshot "$tmp/overlays.png"
run "$scene" --probes "$tmp/set.json" --select 1 --screenshot "$tmp/base.png"
run "$scene" --probes "$tmp/set.json" --overlays preview,tets --screenshot "$tmp/preview.png"
# The removed --no-leak-cuts is refused (exit 1) with what replaced it.
if run "$scene" --no-leak-cuts --screenshot "$tmp/nocuts.png" 2>"$tmp/nocuts.err"; then
  echo "FAIL: --no-leak-cuts was accepted"; exit 1
fi
grep -q -- "--no-leak-cuts: removed; .*visibility maps" "$tmp/nocuts.err" ||
  { echo "FAIL: --no-leak-cuts: unexpected message:"; cat "$tmp/nocuts.err"; exit 1; }
# Two importance volumes (weight 3: orange, 0.5: blue) added to the saved set, with the window.
sed 's/"importance_volumes": \[\]/"importance_volumes": [{"name": "doorway", "min": [-1, 0.2, -1.2], "max": [1, 2.4, 1.2], "weight": 3}, {"name": "far corner", "min": [3.5, 0.2, 1.5], "max": [5.8, 1.5, 3.8], "weight": 0.5}]/' \
  "$tmp/set.json" > "$tmp/volumes.json"
grep -q doorway "$tmp/volumes.json" || { echo "FAIL: could not add importance volumes"; exit 1; }
run "$scene" --probes "$tmp/volumes.json" --screenshot "$tmp/volumes.png" \
  --window-screenshot "$tmp/volumes-window.png"
run "$scene" --probes "$tmp/set.json" --screenshot "$tmp/novolumes.png"
cp "$tmp/volumes-window.png" "$artifacts/editor-two-rooms-volumes-window.png"
for f in overlays base preview volumes; do
  cp "$tmp/$f.png" "$artifacts/editor-two-rooms-$f.png"
  cp "$tmp/$f.png.json" "$artifacts/editor-two-rooms-$f.png.json"
done
"$checker" --overlays "$tmp/overlays.png" "$tmp/base.png"
# The domain of interest's shell (View > Domain of interest) against the same view.
run "$scene" --probes "$tmp/set.json" --select 1 --overlays domain --screenshot "$tmp/domain.png"
"$checker" --domain "$tmp/domain.png" "$tmp/base.png"
"$checker" --volumes "$tmp/volumes.png" "$tmp/novolumes.png"

# Probes stay visible however far the view: in a small viewport the same set's probes are drawn
# at least 9 px in radius (accepted; candidates 0.7 of that), Viewport::kMinProbeRadiusPx. In flat
# colours, so that a sphere lit as brightly as the floor behind it still shows its width.
run "$scene" --probes "$tmp/set.json" --size 320x240 --overlays flat --screenshot "$tmp/small.png"
run "$scene" --probes "$tmp/set.json" --size 320x240 --overlays flat --no-probes \
  --screenshot "$tmp/smallbare.png"
cp "$tmp/small.png" "$artifacts/editor-two-rooms-small.png"
cp "$tmp/small.png.json" "$artifacts/editor-two-rooms-small.png.json"
"$checker" --min-radius 9 "$tmp/small.png" "$tmp/smallbare.png"

# A file that fails to load: one line on stderr, exit 1, no screenshot.
if run "$tmp/missing.gltf" --screenshot "$tmp/none.png" 2> "$tmp/err.txt"; then
  echo "FAIL: a missing scene exited 0"; exit 1
fi
grep -q "missing.gltf" "$tmp/err.txt" || { echo "FAIL: error does not name the file"; cat "$tmp/err.txt"; exit 1; }
[ ! -e "$tmp/none.png" ] || { echo "FAIL: wrote a screenshot for a missing scene"; exit 1; }
echo "test_screenshot: OK"
