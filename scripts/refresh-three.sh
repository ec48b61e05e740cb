#!/usr/bin/env bash
# Refreshes the pendant's vendored three.js (src/http/pendant/vendor/three/) from the npm
# registry: the package `three` at the pinned version (or the one given), bundled by esbuild
# (also from the registry) into one minified ES module holding only what the page imports
# (vendor/three/entry.js lists it), with three's LICENSE and the version beside it.
#   bash scripts/refresh-three.sh            # the pinned version
#   bash scripts/refresh-three.sh 0.188.0    # another one (then commit the result)
set -euo pipefail
cd "$(dirname "$0")/.."
version="${1:-0.187.0}"
esbuild_version="0.25.12"
out="src/http/pendant/vendor/three"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

cp "$out/entry.js" "$work/entry.js"
(
  cd "$work"
  npm init -y > /dev/null
  npm install --silent --no-audit --no-fund "three@$version" "esbuild@$esbuild_version" > /dev/null
  npx --no-install esbuild entry.js --bundle --minify --format=esm --legal-comments=inline \
    --target=es2020 --outfile=three.min.js
)
{
  echo "/* three.js $version (https://threejs.org), MIT licence: see LICENSE beside this file."
  echo "   Bundled by scripts/refresh-three.sh from the npm package; only what entry.js exports. */"
  cat "$work/three.min.js"
} > "$out/three.min.js"
cp "$work/node_modules/three/LICENSE" "$out/LICENSE"
echo "$version" > "$out/VERSION"
echo "three $version: $(wc -c < "$out/three.min.js") bytes in $out/three.min.js"
