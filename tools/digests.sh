#!/usr/bin/env bash
# The digest of every command's outputs on the bundled fixtures, one line a file: a refactoring
# that leaves behaviour unchanged leaves this list unchanged.
#
#   tools/digests.sh [SKIN] > before.txt      # SKIN: the binary (default: a release build)
#   ... change ...
#   tools/digests.sh [SKIN] > after.txt && diff before.txt after.txt
#
# The runs write into a temporary folder, removed at the end; nothing in the tree is touched.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -ge 1 ]; then
  SKIN=$(realpath "$1")
else
  cargo build --release -q -p skin-cli
  SKIN=$PWD/target/release/skin
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
F=$PWD/fixtures
q() { "$SKIN" "$@" >/dev/null 2>&1 || { echo "failed: skin $*" >&2; exit 1; }; }

q run "$F/session/run.toml" --log "$F/session/session.candump.log" -o "$TMP/session" -q --mcap "$TMP/mcap/session.mcap"
q run "$F/arm/run.toml" --log "$F/arm/touch.candump.log" -o "$TMP/arm" -q
q flatten "$F/forearm/layout.json" -o "$TMP/flatten/forearm_map.json" --svg "$TMP/flatten/forearm_map.svg"
q image "$F/forearm/touches.txt" --map "$TMP/flatten/forearm_map.json" -o "$TMP/image"
q stitch --layout "$F/arm/layout.json" --poses "$F/arm/poses.json" -o "$TMP/stitch" "$F/arm/touch.txt"
q segment --model "$F/models/handseg.onnx" "$TMP"/session/touches/*.png -o "$TMP/segment"
q replay --busmap "$F/forearm/busmap.toml" --layout "$F/forearm/layout.json" "$F/forearm/touches.candump.log" -o "$TMP/replay/frames.csv"
q calibrate "$F/hex_patch/probes.csv" --truth "$F/hex_patch/layout.json" -o "$TMP/calibrate/layout.json"

cd "$TMP"
# Timing lines are the only text that changes from run to run; images are taken byte for byte.
find . -type f ! -name .skin-lock | LC_ALL=C sort | while read -r f; do
  case "$f" in
    *.png) d=$(sha256sum < "$f") ;;
    *) d=$(grep -a -v -i -E 'elapsed|wall|[0-9] ?(ms|s) (a|per) frame|frames/s' "$f" | sha256sum) ;;
  esac
  printf '%s  %s\n' "${d:0:16}" "$f"
done
