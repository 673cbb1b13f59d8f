# Seeded byte mutations of seed files (tests/e2e/hostile_inputs.sh).
import random, sys, os
# usage: mutate.py SEED N OUTDIR SRC...  -> OUTDIR/mNNNN.EXT
seed, n, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
srcs = [open(p, 'rb').read() for p in sys.argv[4:]]
exts = [os.path.splitext(p)[1] for p in sys.argv[4:]]
rng = random.Random(seed)
interesting = [b'0', b'-1', b'4294967295', b'2147483647', b'99999999', b'1e38', b'nan', b'-2147483648', b'65535', b'\n', b' ', b'3', b'255']
os.makedirs(out, exist_ok=True)
for i in range(n):
    k = rng.randrange(len(srcs)); d = bytearray(srcs[k])
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(6); p = rng.randrange(len(d)) if d else 0
        if op == 0 and d: d[p] = rng.randrange(256)
        elif op == 1: d[p:p] = rng.choice(interesting)
        elif op == 2 and d:  # replace a number-ish token
            q = p
            while q < len(d) and d[q:q+1] not in (b' ', b'\n'): q += 1
            d[p:q] = rng.choice(interesting)
        elif op == 3: d = d[:p]
        elif op == 4 and d: del d[p:p + rng.randint(1, 16)]
        elif op == 5 and d: d[p:p] = d[p:p + rng.randint(1, 64)] * rng.randint(1, 20)
    open(os.path.join(out, 'm%04d%s' % (i, exts[k])), 'wb').write(bytes(d))
