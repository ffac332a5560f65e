#!/usr/bin/env bash
# Writes $HSGPU_REPORT_DIR/README.md: the report's pages, each with its title and the line that
# says when and how it was made; then the pages made on another machine (a folder of their own
# with a README that says how).
set -euo pipefail
dir=${HSGPU_REPORT_DIR:?}

# row <page path relative to $dir> <what it measures>
row() {
  local page=$dir/$1 title made mode
  title=$(sed -n '1s/^# //p' "$page")
  made=$(grep -m1 -o 'on [0-9-]* [0-9:]* UTC' "$page" | sed 's/^on //')
  mode=$(grep -m1 -o '([a-z]* mode)' "$page" | tr -d '()')
  echo "| [$title]($1) | $2 | $made, $mode |"
}

{
  echo "# Speed against error: the report"
  echo
  echo "Made by \`bash tools/report.sh\` (\`--quick\` for a short version); each page says when, on"
  echo "what hardware and in which mode it was made.  The raw numbers are the CSV files beside the"
  echo "pages."
  echo
  echo "| page | what it measures | made |"
  echo "|---|---|---|"
  for s in seed granular gravity pick; do
    [ -f "$dir/$s.md" ] || continue
    case $s in
      seed) what="the seed paper's benchmark, whole: ms per step against N, CPU and GPU" ;;
      granular) what="fix hardsphere against LAMMPS's GRANULAR styles: error against wall time" ;;
      gravity) what="pair_style gravity: force error against time per step, per precision" ;;
      pick) what="what to pick, per kind of scene" ;;
    esac
    row "$s.md" "$what"
  done
  for sub in "$dir"/*/; do
    [ -f "$sub/README.md" ] || continue
    name=$(basename "$sub")
    for s in seed granular gravity pick; do
      [ -f "$sub/$s.md" ] || continue
      gpu=$(grep -m1 -o 'GPU: [^;]*' "$sub/$s.md" | sed 's/^GPU: //')
      row "$name/$s.md" "the same section on $gpu ([how it was made]($name/README.md))"
    done
  done
} > "$dir/README.md"
