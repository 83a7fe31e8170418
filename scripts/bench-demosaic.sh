#!/usr/bin/env bash
# camsim's demosaicing methods and OpenCV's, measured back to back on this machine (single
# thread), so speeds can be quoted as ratios. Needs .venv (scripts/test-all.sh makes it).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --quiet --release --bin camsim
echo "== camsim (dataset, method, bits, CPSNR dB, Mpix/s)"
for set in data/kodak data/mcmaster; do ./target/release/camsim bench demosaic --dataset "$set" 2>/dev/null; done
echo "== OpenCV $(.venv/bin/python -c 'import cv2; print(cv2.__version__)'), cv2.setNumThreads(1)"
.venv/bin/python scripts/bench_opencv_demosaic.py data/kodak data/mcmaster
