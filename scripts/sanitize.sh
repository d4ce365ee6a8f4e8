#!/usr/bin/env bash
# Runs the vdb crate's tests with its C++ bridge (cpp/vdb and the cxx glue) built under
# AddressSanitizer and UndefinedBehaviorSanitizer (clang 14; Rust itself is not instrumented).
#   scripts/sanitize.sh [extra cargo test args]
# Needs: apt-get install clang-14 libclang-rt-14-dev. TBB's headers are not instrumented
# (scripts/sanitize-ignore.txt says why). Prints the number of sanitizer reports and
# fails if there is any (or a test fails). OpenVDB itself is Debian's uninstrumented build: ASan
# still checks every allocation and free it makes through the intercepted allocator.
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
export CC=clang-14 CXX=clang++-14
export CXXFLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer \
-fsanitize-ignorelist=$root/scripts/sanitize-ignore.txt"
export RUSTFLAGS="-Clinker=clang++-14 -Clink-arg=-fsanitize=address,undefined"
export CARGO_TARGET_DIR="$root/target/sanitize"
# Leaks: OpenVDB keeps its type registries for the process's life; not checked here.
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:halt_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
log="$CARGO_TARGET_DIR/sanitize.log"
mkdir -p "$CARGO_TARGET_DIR"
nice -n 19 cargo test --release --target x86_64-unknown-linux-gnu -p dentsim-vdb "$@" 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
asan=$(grep -c "ERROR: AddressSanitizer" "$log")
ubsan=$(grep -c "runtime error:" "$log")
echo "sanitizer reports: AddressSanitizer $asan, UndefinedBehaviorSanitizer $ubsan (log: $log)"
[ "$status" -eq 0 ] && [ "$asan" -eq 0 ] && [ "$ubsan" -eq 0 ]
