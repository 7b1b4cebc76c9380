#!/bin/sh
# Make docs/animate/SCENE.png for every bundled scene: its animated page
# (`hamel simulate SCENE --animate`), opened in headless Chromium at half its duration.
# Run from the repository's root after `cargo build --release`.
set -eu
out=docs/animate
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for scene in scenes/*.toml; do
    name=$(basename "$scene" .toml)
    t_end=$(sed -n 's/^t_end *= *\([0-9.e+-]*\).*/\1/p' "$scene")
    half=$(python3 -c "print(${t_end:-1} / 2)")
    ./target/release/hamel simulate "$scene" --animate "$work/$name.html" \
        --output "$work/$name.csv" 2>/dev/null || echo "$scene: the run stopped early (its page shows what was computed)"
    chromium --headless --no-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader \
        --user-data-dir="$work/profile" --virtual-time-budget=3000 --window-size=960,600 \
        --screenshot="$out/$name.png" "file://$work/$name.html#t=$half" 2>/dev/null
    echo "$out/$name.png: t = $half"
done
