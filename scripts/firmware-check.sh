#!/usr/bin/env bash
# The firmware cores built for real cores, warning-free: optics-core and isp-core for
# thumbv7em-none-eabihf (Cortex-M4F/M7F), thumbv8m.main-none-eabihf (Cortex-M33) and
# aarch64-unknown-none, each with `-D warnings` and clippy `-D warnings`.
#
# rustup cannot add a target on a machine without its network, but Debian's own Rust
# (rustc-web, with the standard library's source in rust-web-src) cross-compiles for any target
# LLVM knows through `-Z build-std=core`, which RUSTC_BOOTSTRAP=1 lets a stable compiler take.
# In CI (CI=true) the packages are installed when missing; on another machine without them the
# check is skipped, loudly, and says how to run it. The recipe is in ARCHITECTURE.md.
set -euo pipefail
cd "$(dirname "$0")/.."

targets=(thumbv7em-none-eabihf thumbv8m.main-none-eabihf aarch64-unknown-none)
packages=(rustc-web cargo-web rust-web-src rust-web-clippy)

have_toolchain() {
  [ -x /usr/bin/rustc ] && [ -x /usr/bin/cargo ] && [ -x /usr/bin/cargo-clippy ] &&
    [ -d /usr/lib/rustlib/src/rust/library/core ]
}

if ! have_toolchain; then
  if [ "${CI:-}" = "true" ]; then
    echo "installing Debian's cross-compiling Rust: ${packages[*]}"
    sudo_if_needed=()
    [ "$(id -u)" -eq 0 ] || sudo_if_needed=(sudo)
    "${sudo_if_needed[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo_if_needed[@]}" apt-get install -y -qq \
      --no-install-recommends "${packages[@]}" >/dev/null
  else
    cat >&2 <<MSG

################################################################################
# FIRMWARE CHECKS SKIPPED: Debian's cross-compiling Rust is not installed, so
# optics-core and isp-core were NOT built for ${targets[*]}.
# To run them: apt-get install --no-install-recommends ${packages[*]}
# (CI installs them itself and fails if they do not build warning-free.)
################################################################################

MSG
    exit 0
  fi
fi

debian_cargo() {
  PATH="/usr/bin:$PATH" RUSTC=/usr/bin/rustc RUSTDOC=/usr/bin/rustdoc RUSTC_BOOTSTRAP=1 \
    CARGO_TARGET_DIR="$PWD/target/firmware" /usr/bin/cargo "$@"
}
echo "with $(/usr/bin/rustc --version)"
for target in "${targets[@]}"; do
  RUSTFLAGS="-D warnings" debian_cargo build --release --locked -Z build-std=core \
    --target "$target" -p optics-core -p isp-core
  debian_cargo clippy --release --locked -Z build-std=core --target "$target" \
    -p optics-core -p isp-core -- -D warnings
  echo "$target: optics-core and isp-core build and pass clippy without a warning"
done
