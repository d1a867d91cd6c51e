#!/usr/bin/env bash
# Re-vendor three.js into static/vendor/three/: ./static/vendor/update.sh [version]
# Installs the npm package in a temp dir and copies only the entry files the
# page imports plus every file they import by relative path, keeping the
# package's layout so the relative imports still resolve.
set -euo pipefail

VERSION="${1:-0.187.0}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
DEST="$HERE/three"
ENTRIES=(
  build/three.module.js
  examples/jsm/loaders/GLTFLoader.js
  examples/jsm/controls/OrbitControls.js
  examples/jsm/environments/RoomEnvironment.js
)

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
(cd "$TMP" && npm init -y >/dev/null && npm install --no-audit --no-fund --ignore-scripts "three@$VERSION" >/dev/null)
SRC="$TMP/node_modules/three"

rm -rf "$DEST"
mkdir -p "$DEST"
cp "$SRC/LICENSE" "$DEST/LICENSE"

# Breadth-first walk over relative imports ('./x.js', '../y.js').
queue=("${ENTRIES[@]}")
declare -A seen=()
while ((${#queue[@]})); do
  rel="${queue[0]}"
  queue=("${queue[@]:1}")
  [[ -n "${seen[$rel]:-}" ]] && continue
  seen[$rel]=1
  mkdir -p "$DEST/$(dirname "$rel")"
  cp "$SRC/$rel" "$DEST/$rel"
  while read -r dep; do
    [[ -z "$dep" ]] && continue
    next="$(realpath -m --relative-to="$SRC" "$SRC/$(dirname "$rel")/$dep")"
    queue+=("$next")
  done < <(grep -oE "from '\.{1,2}/[^']+'" "$SRC/$rel" | sed -E "s/from '(.*)'/\1/" || true)
done

echo "vendored three@$VERSION:"
(cd "$DEST" && find . -type f | sort)
