#!/bin/sh
# Rebuild three.bundle.min.js, the three.js that hamel's animated pages carry inline: the
# core and the orbit controls of three@$THREE from the npm registry, bundled by esbuild as one
# classic script that sets window.THREE (a page opened from disk cannot import modules by
# name). Pinned: after a rebuild, PIN holds the new versions and hash, and
# `cargo test -p hamel-view` checks the committed bundle against it.
set -eu
THREE=0.187.0
ESBUILD=0.28.2
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
echo '{"name": "hamel-three-vendor", "private": true, "version": "0.0.0"}' > package.json
npm install --no-audit --no-fund "three@$THREE" "esbuild@$ESBUILD" > /dev/null
cp "$here/entry.js" .
npx esbuild entry.js --bundle --minify --format=iife --legal-comments=none \
    --outfile="$here/three.bundle.min.js"
cp node_modules/three/LICENSE "$here/LICENSE"
hash=$(sha256sum "$here/three.bundle.min.js" | cut -d' ' -f1)
printf 'three %s\nesbuild %s\nsha256 %s\n' "$THREE" "$ESBUILD" "$hash" > "$here/PIN"
echo "three.bundle.min.js: three $THREE, sha256 $hash"
