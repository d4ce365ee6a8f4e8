#!/usr/bin/env bash
# Coverage-guided fuzzing of one reader on stable Rust: libFuzzer (Debian's clang 14 runtime),
# Rust instrumented with -Cpasses=sancov-module, the vdb crate's C++ with
# -fsanitize=address,fuzzer-no-link.
#   scripts/fuzz.sh TARGET MINUTES        (MINUTES 0: build only)  TARGET: vdb vdb_unguarded tissue_toml path_csv
#                                                 device_spec session_log scan
# Needs: apt-get install clang-14 libclang-rt-14-dev. Runs at nice 19. The working corpus grows
# in target/fuzz-corpus/TARGET (seeded from fuzz/corpus/TARGET); crashers land in
# target/fuzz-artifacts/TARGET (keep real ones in fuzz/crashers/TARGET: the test run replays
# them). vdb_unguarded reads in-process without the child guard: it finds what OpenVDB's reader
# crashes on, so it keeps going after a crash (-fork=1 -ignore_crashes=1).
set -euo pipefail
target=${1:?target}; minutes=${2:?minutes}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
rt=$(ls -d /usr/lib/llvm-14/lib/clang/*/lib/linux | head -1)
export CC=clang-14 CXX=clang++-14
export CXXFLAGS="-fsanitize=address,fuzzer-no-link -fno-omit-frame-pointer"
export CUSTOM_LIBFUZZER_PATH="$rt/libclang_rt.fuzzer-x86_64.a"
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks \
-Clinker=clang-14 -Clink-arg=-fsanitize=address -Clink-arg=-fuse-ld=bfd"
export CARGO_TARGET_DIR="$root/target/fuzz"
triple=x86_64-unknown-linux-gnu
nice -n 19 cargo build --release --target $triple --features libfuzzer -p dentsim-fuzz --bins
[ "$minutes" -gt 0 ] || exit 0  # MINUTES 0: build only
corpus="$root/target/fuzz-corpus/$target"; artifacts="$root/target/fuzz-artifacts/$target"
mkdir -p "$corpus" "$artifacts"
extra=()
# KEEP_GOING=1: the same for any target (to count crashers in a reader not fixed yet).
if [ "$target" = vdb_unguarded ] || [ "${KEEP_GOING:-0}" = 1 ]; then
  extra=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
fi
# The child guard's address-space cap is off under ASan (its shadow memory): cap allocations.
export ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1:max_allocation_size_mb=1024
nice -n 19 "$CARGO_TARGET_DIR/$triple/release/fuzz_$target" "${extra[@]}" \
  -max_total_time=$((minutes * 60)) -rss_limit_mb=3072 -timeout=30 -print_final_stats=1 \
  -artifact_prefix="$artifacts/" "$corpus" "fuzz/corpus/$target"
