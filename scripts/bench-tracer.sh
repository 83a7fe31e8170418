#!/usr/bin/env bash
# camsim's path tracer against Mitsuba 3 (scalar_rgb) on the Cornell box: image parity and
# samples per second, both measured in this one run on this machine. Sets up .venv-mitsuba
# (pinned Mitsuba and NumPy from PyPI) the first time. Arguments go to scripts/bench_tracer.py
# (--spp, --replicas, --threads, --speed-spp, --json FILE).
set -euo pipefail
cd "$(dirname "$0")/.."
requirements=scripts/bench-tracer-requirements.txt
stamp=.venv-mitsuba/camsim-requirements.txt
if ! { [ -x .venv-mitsuba/bin/python ] && cmp -s "$requirements" "$stamp"; }; then
  python3 -m venv --clear .venv-mitsuba
  .venv-mitsuba/bin/python -m pip install --disable-pip-version-check --quiet -r "$requirements"
  cp "$requirements" "$stamp"
fi
cargo build --quiet --release --bin camsim
.venv-mitsuba/bin/python scripts/bench_tracer.py "$@"
