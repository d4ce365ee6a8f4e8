#!/usr/bin/env bash
# The main job: set up, run the demo on the built-in phantom, and render it with ParaView.
#   bash scripts/demo.sh [OUT]      (OUT defaults to ./out)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

out="${1:-$DENTSIM_ROOT/out}"
"$CARGO_TARGET_DIR/release/dentsim" demo --out "$out"
xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch "$DENTSIM_ROOT/plugin/scripts/render_tissues.py" "$out"
echo "outputs in $out:"
ls -1 "$out"
