#!/usr/bin/env bash
# Section "pick" of tools/report.sh: what to pick per kind of scene, from the numbers the other
# sections wrote (their CSV files in $HSGPU_REPORT_DIR) and the measurements the doc pages
# state.  Runs nothing itself; a section that was not run shows as "not measured".
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
mode=${1:-full}
report_env
page=$HSGPU_REPORT_DIR/pick.md
{
  page_header "What to pick: styles, settings and timesteps per kind of scene" "$mode"
  python_plot "$(dirname "${BASH_SOURCE[0]}")/pick.py" "$HSGPU_REPORT_DIR"
} > "$page.tmp"
mv "$page.tmp" "$page"
