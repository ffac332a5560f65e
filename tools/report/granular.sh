#!/usr/bin/env bash
# Report section "granular" (issue 11, section 2, item 2): fix hardsphere against LAMMPS's
# GRANULAR styles (pair gran/hooke, pair granular with coeff_restitution damping, fix wall/gran)
# in six scenes: a head-on pair, a ball bouncing on a floor, the falling column of
# examples/benchmarks/in.column to t = 1, the same column settled (t = 10 ... 30), a dense
# elastic fluid, and (issue 15) a collapsing column of rough spheres, whose deposit's slope is
# compared with gran/hooke/history at the same friction coefficient (in.granular_repose).
# Error against wall time, one marker series per method.
#   bash tools/report/granular.sh <quick|full>     (run by tools/report.sh, which sets HSGPU_REPORT_*)
# Writes $HSGPU_REPORT_DIR/granular.md, granular_*.png and granular_*.csv; the LAMMPS logs and
# generated inputs go to $HSGPU_REPORT_BUILD/report/granular/.
# quick: the pair, the bounce and the column (a few settings per method): 20 s on the 2-core
# development machine; full: all five scenes and all settings, the column with three more
# velocity seeds and each of its timed settings run three times (the median wall time; about
# 3 minutes of the total): about 20 minutes there (the settled column's fix hardsphere runs,
# about 6 events per sphere per step, take most of it).
# HSGPU_REPORT_GRANULAR_SCENES=pair,bounce,column,settled,fluid,repose picks scenes (for
# development; repose alone: 25 s).
# A LAMMPS error, a missing result or a value that is not finite makes it exit non-zero before
# the page is written.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$here/lib.sh"
mode=$(report_mode "${1:-}")
report_env

work=$HSGPU_REPORT_BUILD/report/granular
rm -rf "$work"
mkdir -p "$work"
python3 "$here/granular.py" plan "$mode" "$work" "$HSGPU_ROOT" "${HSGPU_REPORT_GRANULAR_SCENES:-}" \
  > "$work/runs.tsv"
cat /proc/loadavg > "$work/load.txt" 2>/dev/null || true
total=$(wc -l < "$work/runs.tsv")
say "granular: $total LAMMPS runs ($mode mode), logs in $work"
i=0
while IFS=$'\t' read -r id input args; do
  i=$((i + 1))
  read -r -a argv <<< "$args"
  start=$SECONDS
  if ! lmp_run "$work/$id.log" "$input" "${argv[@]}" < /dev/null > "$work/$id.screen" 2>&1; then
    echo "granular: LAMMPS failed in run $id ($input ${args}); the end of its log:" >&2
    tail -n 15 "$work/$id.log" >&2 || true
    cat "$work/$id.screen" >&2 || true
    exit 1
  fi
  echo "   [$i/$total] $id: $(loop_time "$work/$id.log") s loop, $((SECONDS - start)) s in all"
done < "$work/runs.tsv"

cat /proc/loadavg >> "$work/load.txt" 2>/dev/null || true
python_plot "$here/granular.py" analyse "$work" "$HSGPU_REPORT_DIR"
page=$HSGPU_REPORT_DIR/granular.md
{
  page_header "Against GRANULAR: fix hardsphere and LAMMPS's soft spheres" "$mode"
  cat "$work/body.md"
} > "$page.tmp"
mv "$page.tmp" "$page"
say "granular: wrote $page"
