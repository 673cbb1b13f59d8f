#!/usr/bin/python3
"""Flips bytes inside the data of a geosynth checkpoint, never its structure.

usage: ckpt_flip.py FILE SEED [NBYTES]

The data are the stored bytes of every dataset (each chunk of a chunked
dataset, the extent of a contiguous one, /geosynth/config included), found
with h5py; NBYTES (default 3) bytes at random offsets inside one randomly
chosen dataset are XORed with a random non-zero value. Metadata (superblock,
object headers, chunk indexes) is left alone: that is the silent-corruption
case libhdf5's own metadata checksums do not cover. Prints what it changed.
"""
import random
import sys

import h5py


def data_ranges(path):
    ranges = []

    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        d = obj.id
        if obj.chunks:
            for i in range(d.get_num_chunks()):
                ci = d.get_chunk_info(i)
                if ci.size:
                    ranges.append((name, ci.byte_offset, ci.size))
        else:
            off = d.get_offset()
            if off is not None and d.get_storage_size():
                ranges.append((name, off, d.get_storage_size()))

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return ranges


def main():
    path, seed = sys.argv[1], int(sys.argv[2])
    nbytes = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    rng = random.Random(seed)
    ranges = data_ranges(path)
    if not ranges:
        sys.exit(f"{path}: no dataset data found")
    name, off, size = rng.choice(ranges)
    with open(path, "r+b") as f:
        for _ in range(nbytes):
            at = off + rng.randrange(size)
            f.seek(at)
            b = f.read(1)[0]
            f.seek(at)
            f.write(bytes([b ^ rng.randrange(1, 256)]))
            print(f"flipped byte {at} of {path} (dataset /{name}, {size} bytes at {off})")


if __name__ == "__main__":
    main()
