#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this script): formatting, lints, the no_std
# proof, docs, and every test. Needs only the Rust toolchain; sets up anything else itself.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

step "formatting (cargo fmt --check)"
cargo fmt --all -- --check

step "lints (cargo clippy --all-targets -D warnings)"
cargo clippy --workspace --all-targets --locked -- -D warnings

# optics-core and isp-core linked into a #![no_std] #![no_main] binary in a cargo invocation of
# its own (a workspace build would unify features and could hide a std leak). A std leak fails
# to link ("duplicate lang item panic_impl"), an allocation fails to compile ("no global memory
# allocator"); running it checks the answers it computes.
step "no_std, heap-free proof (tests/nostd)"
CARGO_TARGET_DIR="$PWD/target/nostd" cargo build --release --locked --manifest-path tests/nostd/Cargo.toml
./target/nostd/release/camsim-nostd-check
echo "camsim-nostd-check: optics-core and isp-core linked without std or an allocator, answers correct"

step "docs (cargo doc, warnings are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --locked

step "tests (cargo test --workspace, with doctests)"
cargo test --workspace --locked
