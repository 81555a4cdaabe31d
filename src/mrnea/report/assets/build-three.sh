#!/usr/bin/env bash
# Rebuild three-subset.min.js: the part of three.js the report's 3D view uses (entry.js lists it),
# one minified classic script that defines the global MRNEA_THREE. Pinned versions; run it only
# to upgrade three.js, then commit the output, its sha256 and LICENSE-three.txt.
# Needs node + npm (npm registry only); esbuild's binary comes in its npm package.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
npm init -y >/dev/null
npm install --no-audit --no-fund --silent three@0.187.0 esbuild@0.28.2
cp "$here/entry.js" .
npx esbuild entry.js --bundle --minify --format=iife --global-name=MRNEA_THREE \
  --legal-comments=none --target=es2020 --outfile="$here/three-subset.min.js"
cp node_modules/three/LICENSE "$here/LICENSE-three.txt"
if grep -q -e '</script' -e '<!--' "$here/three-subset.min.js"; then
  echo "three-subset.min.js holds '</script' or '<!--': it cannot be inlined" >&2; exit 1
fi
sha256sum "$here/three-subset.min.js"
