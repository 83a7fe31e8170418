#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this script): the oracle's Python
# environment, formatting, lints, the no_std proof, docs, and every test (including the
# differential tests against OpenCV and colour-science). Needs only the Rust toolchain and
# Python 3; sets up everything else itself.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

# The differential-test oracle: OpenCV, colour-science and colour-demosaicing at pinned versions
# from PyPI, in .venv. Made once; made again only when the requirements change.
step "oracle environment (.venv from tests/oracle/requirements.txt)"
requirements=tests/oracle/requirements.txt
stamp=.venv/camsim-requirements.txt
if [ -x .venv/bin/python ] && cmp -s "$requirements" "$stamp"; then
  echo "reusing .venv ($(.venv/bin/python --version))"
else
  command -v python3 >/dev/null || { echo "error: python3 not found; the oracle tests need Python 3 (3.10 or newer)" >&2; exit 1; }
  python3 -m venv --clear .venv || {
    echo "error: 'python3 -m venv' failed; install Python's venv module (Debian/Ubuntu: apt-get install python3-venv)" >&2
    exit 1
  }
  .venv/bin/python -m pip install --disable-pip-version-check --quiet -r "$requirements"
  cp "$requirements" "$stamp"
  echo "created .venv: $(.venv/bin/python -m pip freeze --disable-pip-version-check | tr '\n' ' ')"
fi
export CAMSIM_ORACLE_PYTHON="$PWD/.venv/bin/python"

# The tuning peers (rpi-ctt, emva1288, colour-checker-detection) and the lens peer (optiland)
# in .venv-tune: the tuning peers want OpenCV 4, which cannot share .venv with the oracle's
# OpenCV 5. Every package is pinned in the
# file and installed with --no-deps (their opencv-python requirement is met by the headless
# wheel's cv2). Made once; made again only when the requirements change.
step "tuning and lens peers' environment (.venv-tune from tests/oracle/tune-peers-requirements.txt)"
tune_requirements=tests/oracle/tune-peers-requirements.txt
tune_stamp=.venv-tune/camsim-requirements.txt
if [ -x .venv-tune/bin/python ] && cmp -s "$tune_requirements" "$tune_stamp"; then
  echo "reusing .venv-tune ($(.venv-tune/bin/python --version))"
else
  python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' || {
    echo "error: the tuning peers (rpi-ctt) need Python 3.11 or newer; python3 is $(python3 --version)" >&2
    exit 1
  }
  python3 -m venv --clear .venv-tune
  .venv-tune/bin/python -m pip install --disable-pip-version-check --quiet --no-deps -r "$tune_requirements"
  cp "$tune_requirements" "$tune_stamp"
  echo "created .venv-tune: $(.venv-tune/bin/python -m pip freeze --disable-pip-version-check | tr '\n' ' ')"
fi
export CAMSIM_TUNE_PYTHON="$PWD/.venv-tune/bin/python"

export CAMSIM_REQUIRE_ORACLE=1

# CI builds everything once from a clean clone: incremental compilation's bookkeeping only
# costs there. A developer's repeated runs keep it.
if [ "${CI:-}" = "true" ]; then
  export CARGO_INCREMENTAL=0
fi

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

step "firmware targets (Cortex-M4F/M7F, Cortex-M33, AArch64: build and clippy, warnings are errors)"
bash scripts/firmware-check.sh

step "docs (cargo doc, warnings are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --locked

step "tests (cargo test --workspace, with doctests)"
cargo test --workspace --locked

# The Python package (python/): built by maturin into the oracle's environment (an editable
# install, in cargo profile `python`: the tests' optimisation), then its pytest suite, which
# compares it with rawpy and with the `camsim` command that `cargo test` built above.
step "Python package (maturin develop into .venv, pytest python/tests)"
(cd python && VIRTUAL_ENV="$PWD/../.venv" ../.venv/bin/maturin develop --locked --profile python --quiet)
CAMSIM_BIN="${CARGO_TARGET_DIR:-$PWD/target}/debug/camsim" .venv/bin/python -m pytest -q -p no:cacheprovider \
  --doctest-modules python/tests python/camsim/optics.py
