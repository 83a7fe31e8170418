#!/usr/bin/env python3
"""Packs what fuzz runs found into fuzz/found/TARGET.bin, which the test suite replays.

After `cargo +nightly fuzz run TARGET corpus/TARGET seeds/TARGET` and
`cargo +nightly fuzz cmin TARGET corpus/TARGET` (from fuzz/), run from the repository root:
    python3 scripts/pack-fuzz-corpus.py TARGET [TARGET ...]
Each input is stored as a 4-byte little-endian length and its bytes, in file-name order, so the
packed file is reproducible and one file in git rather than thousands.
"""
import pathlib
import struct
import sys

root = pathlib.Path(__file__).resolve().parent.parent
for target in sys.argv[1:]:
    corpus = root / "fuzz" / "corpus" / target
    files = sorted(p for p in corpus.iterdir() if p.is_file())
    out = root / "fuzz" / "found" / f"{target}.bin"
    out.parent.mkdir(exist_ok=True)
    with out.open("wb") as f:
        for p in files:
            data = p.read_bytes()
            f.write(struct.pack("<I", len(data)))
            f.write(data)
    print(f"{out.relative_to(root)}: {len(files)} inputs, {out.stat().st_size} bytes")
