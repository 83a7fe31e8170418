#!/usr/bin/env bash
# The firmware cores on real cores:
# 1. optics-core, isp-core, isp-ffi (the C API) and firmware-cases pass clippy `-D warnings`
#    (rustc's warnings among them) for thumbv7em-none-eabihf (Cortex-M4F/M7F),
#    thumbv8m.main-none-eabihf (Cortex-M33) and aarch64-unknown-none;
# 2. the firmware examples (firmware/cortex-m, firmware/aarch64), which build all four for each
#    target with `-D warnings` (firmware-cases links isp-ffi without `std`, as a firmware
#    would), run every firmware case (the C API's among them) under QEMU on mps2-an386 (Cortex-M4F), mps2-an505 (Cortex-M33) and virt
#    (Cortex-A53), and each checksum equals the host's for the same
#    frame and configuration (firmware-cases' host-checksums example; the workspace test
#    tests/tests/firmware_cases.rs ties those to `camsim isp`'s development).
# The runs' SysTick counts land in target/firmware/qemu-*.txt for scripts/firmware-budget.py.
#
# rustup cannot add a target on a machine without its network, but Debian's own Rust
# (rustc-web, with the standard library's source in rust-web-src) cross-compiles for any target
# LLVM knows through `-Z build-std`, which RUSTC_BOOTSTRAP=1 lets a stable compiler take;
# rust-web-llvm's rust-lld (lld-22) links, and Debian's qemu-system-arm emulates the boards.
# In CI (CI=true) the packages are installed when missing; on another machine without them the
# checks are skipped, loudly, and the banner says how to run them. The recipe is in
# ARCHITECTURE.md ("Firmware targets").
set -euo pipefail
cd "$(dirname "$0")/.."

targets=(thumbv7em-none-eabihf thumbv8m.main-none-eabihf aarch64-unknown-none)
packages=(rustc-web cargo-web rust-web-src rust-web-clippy rust-web-llvm lld-22 qemu-system-arm)
# Emulated boards: QEMU, its machine, the core it models, the firmware's target and crate.
boards=(
  "qemu-system-arm mps2-an386 Cortex-M4F thumbv7em-none-eabihf firmware/cortex-m"
  "qemu-system-arm mps2-an505 Cortex-M33 thumbv8m.main-none-eabihf firmware/cortex-m"
  "qemu-system-aarch64 virt Cortex-A53 aarch64-unknown-none firmware/aarch64"
)
sizes=(64x48 128x96)

have_toolchain() {
  [ -x /usr/bin/rustc ] && [ -x /usr/bin/cargo ] && [ -x /usr/bin/cargo-clippy ] &&
    [ -d /usr/lib/rustlib/src/rust/library/core ] && [ -x /usr/bin/rust-lld ] &&
    command -v ld.lld-22 >/dev/null && command -v qemu-system-arm >/dev/null
}

if ! have_toolchain; then
  if [ "${CI:-}" = "true" ]; then
    echo "installing Debian's cross-compiling Rust and QEMU: ${packages[*]}"
    sudo_if_needed=()
    [ "$(id -u)" -eq 0 ] || sudo_if_needed=(sudo)
    "${sudo_if_needed[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo_if_needed[@]}" apt-get install -y -qq \
      --no-install-recommends "${packages[@]}" >/dev/null
  else
    cat >&2 <<MSG

################################################################################
# FIRMWARE CHECKS SKIPPED: Debian's cross-compiling Rust or QEMU is not installed,
# so optics-core and isp-core were NOT built for ${targets[*]}
# and the firmware example did NOT run on the emulated Cortex-M4 and Cortex-M33.
# To run them: apt-get install --no-install-recommends ${packages[*]}
# (CI installs them itself and fails if anything differs from the host.)
################################################################################

MSG
    exit 0
  fi
fi

debian_cargo() {
  PATH="/usr/bin:$PATH" RUSTC=/usr/bin/rustc RUSTDOC=/usr/bin/rustdoc RUSTC_BOOTSTRAP=1 \
    CARGO_TARGET_DIR="$PWD/target/firmware" /usr/bin/cargo "$@"
}
echo "with $(/usr/bin/rustc --version) and $(qemu-system-arm --version | head -1)"
# Clippy only: the libraries' code generation for each target is the firmware binaries' build
# below (a separate library build took 2-2.5 minutes a target in CI and proved nothing more).
for target in "${targets[@]}"; do
  # isp-ffi without its `std` feature: the C API as a Rust firmware links it.
  debian_cargo clippy --release --locked -Z build-std=core --target "$target" \
    --no-default-features -p optics-core -p isp-core -p isp-ffi -p firmware-cases -- -D warnings
  echo "$target: optics-core, isp-core, isp-ffi and firmware-cases pass clippy without a warning"
done

# The firmware binaries: compiler_builtins from source too, with its memcpy/memset (no libc).
build_std=(-Z build-std=core,compiler_builtins -Z build-std-features=compiler-builtins-mem)
host_checksums=target/firmware/host-checksums.txt
mkdir -p target/firmware
cargo run --release --locked --quiet -p firmware-cases --example host-checksums -- "${sizes[@]}" \
  >"$host_checksums"
for board in "${boards[@]}"; do
  read -r qemu machine core target crate <<<"$board"
  manifest="$crate/Cargo.toml"
  cargo fmt --manifest-path "$manifest" -- --check
  RUSTFLAGS="-D warnings" debian_cargo build --release --locked "${build_std[@]}" \
    --manifest-path "$manifest" --target "$target"
  debian_cargo clippy --release --locked "${build_std[@]}" --manifest-path "$manifest" \
    --target "$target" -- -D warnings
  binary="target/firmware/$target/release/$(basename "$(sed -n 's/^name = "\(.*\)"/\1/p' "$manifest" | head -1)")"
  machine_args=(-M "$machine")
  # `-M virt` adds a network card by default, whose option ROM (efi-virtio.rom) is in
  # ipxe-qemu, a package `--no-install-recommends` leaves out: the firmware needs no network.
  [ "$machine" = virt ] && machine_args+=(-cpu cortex-a53 -nic none)
  log="target/firmware/qemu-$machine.txt"
  status=0
  timeout 600 "$qemu" "${machine_args[@]}" -nographic -monitor none -serial none \
    -semihosting-config enable=on,target=native -icount shift=0,align=off,sleep=off \
    -kernel "$binary" >"$log" || status=$?
  if [ "$status" -ne 0 ]; then
    echo "error: the firmware on $machine ($core) exited with status $status; its output:" >&2
    cat "$log" >&2
    exit 1
  fi
  if ! diff <(grep '^case ' "$log") "$host_checksums" >&2; then
    echo "error: on $machine ($core) the firmware's checksums above differ from the host's" >&2
    exit 1
  fi
  echo "$machine ($core): all $(grep -c '^case ' "$log") checksums equal the host's (${sizes[*]})"
done

# Instruction budgets: instructions per pixel on each board (the slope between the two frame
# sizes) and start-up, beside the host's ns per pixel for the same code; the committed copy
# is docs/firmware (python3 scripts/firmware-budget.py --out docs/firmware after this script).
cargo run --release --locked --quiet -p firmware-cases --example host-checksums -- --time \
  >target/firmware/host-times.txt
python3 scripts/firmware-budget.py --logs target/firmware --host target/firmware/host-times.txt \
  --out target/firmware
