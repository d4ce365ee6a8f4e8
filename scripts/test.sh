#!/usr/bin/env bash
# Every test: set up, then the Rust tests (unit, property, integration, CLI end to end) and the
# ParaView plugin tests (pvbatch under Xvfb, compared with baseline images).
#   bash scripts/test.sh
# The two suites run side by side once everything is compiled: many of their tests wait (1 kHz
# sessions that sleep between ticks, devices on loopback, pvbatch starting, Xvfb), and one after
# the other they took ~20 minutes on a 2-core machine. The plugin's output follows the Rust
# tests' whole, not interleaved.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

cd "$DENTSIM_ROOT"
status=0
cargo test --release --workspace --no-run --quiet || status=1
plugin_log="$(mktemp -t dentsim-plugin-tests.XXXXXX)"
trap 'rm -f "$plugin_log"' EXIT
ctest --test-dir "$DENTSIM_PLUGIN_BUILD" --output-on-failure >"$plugin_log" 2>&1 &
plugin=$!
cargo test --release --workspace --no-fail-fast || status=1
plugin_status=0
wait "$plugin" || plugin_status=$?
echo "---- ParaView plugin tests (ctest, run beside the Rust tests) ----"
cat "$plugin_log"
[ "$plugin_status" -eq 0 ] || status=1
exit $status
