#!/bin/sh
# The printed equations of every seed model, as images for docs/models/*.md (issue 22):
#   hamel derive models/NAME.toml --eta CHOICE --format latex  ->  pdflatex  ->  first page as PNG.
# Needs a release build of hamel, pdflatex (texlive-latex-base) and pdftoppm (poppler-utils).
# Run from the repository root: sh docs/models/render.sh
set -eu
hamel=${HAMEL:-target/release/hamel}
out=docs/models/figures
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for pair in knife:paper vertical_knife:paper bar_blade:paper bar_wheels:paper \
            unicycle_rider:velocities rolling_disk:velocities remark22:paper \
            chaplygin_sleigh:paper_style snakeboard:velocities whipple_bicycle:benchmark; do
    name=${pair%%:*}
    eta=${pair#*:}
    "$hamel" derive "models/$name.toml" --eta "$eta" --format latex --output "$tmp/$name.tex"
    (cd "$tmp" && pdflatex -interaction=nonstopmode -halt-on-error "$name.tex" >/dev/null)
    pdftoppm -png -r 90 -f 1 -l 1 -singlefile "$tmp/$name.pdf" "$out/${name}_printed"
    echo "$out/${name}_printed.png ($name, $eta)"
done
