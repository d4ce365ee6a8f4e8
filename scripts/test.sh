#!/usr/bin/env bash
# Every test: set up, then the Rust tests (unit, property, integration, CLI end to end) and the
# ParaView plugin tests (pvbatch under Xvfb, compared with baseline images).
#   bash scripts/test.sh
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

cd "$DENTSIM_ROOT"
status=0
dentsim_log "building the Rust tests"
cargo test --release --workspace --no-run --quiet || status=1
dentsim_log "the Rust tests"
cargo test --release --workspace --no-fail-fast || status=1
dentsim_log "Rust tests done; the plugin's tests"
ctest --test-dir "$DENTSIM_PLUGIN_BUILD" --output-on-failure || status=1
dentsim_log "tests done"
exit $status
