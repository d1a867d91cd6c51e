#!/usr/bin/env bash
# Re-vendor the page's libraries: ./static/vendor/update.sh [three-version] [uplot-version]
# Installs the pinned npm packages in a temp dir. three.js: copies only the
# entry files the page imports plus every file they import by relative path,
# keeping the package's layout so the relative imports still resolve. uPlot:
# its ES module build, its stylesheet and its licence.
set -euo pipefail

VERSION="${1:-0.187.0}"
UPLOT_VERSION="${2:-1.6.32}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
DEST="$HERE/three"
ENTRIES=(
  build/three.module.js
  examples/jsm/loaders/GLTFLoader.js
  examples/jsm/controls/OrbitControls.js
  examples/jsm/controls/TransformControls.js
  examples/jsm/modifiers/SimplifyModifier.js
  examples/jsm/environments/RoomEnvironment.js
)

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
(cd "$TMP" && npm init -y >/dev/null && npm install --no-audit --no-fund --ignore-scripts \
  "three@$VERSION" "uplot@$UPLOT_VERSION" >/dev/null)
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

UPLOT_SRC="$TMP/node_modules/uplot"
UPLOT_DEST="$HERE/uplot"
rm -rf "$UPLOT_DEST"
mkdir -p "$UPLOT_DEST"
cp "$UPLOT_SRC/LICENSE" "$UPLOT_SRC/dist/uPlot.esm.js" "$UPLOT_SRC/dist/uPlot.min.css" "$UPLOT_DEST/"
echo "vendored uplot@$UPLOT_VERSION:"
(cd "$UPLOT_DEST" && find . -type f | sort)
