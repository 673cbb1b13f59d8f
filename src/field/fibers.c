/* Long objects (fibers) rebuilt whole from the source's fibers: the
 * field.complete_objects path for an example whose inside mostly runs
 * through the source along one axis (gs_field_fibers_rebuild, called by
 * src/field/synth.c complete_objects).
 *
 * The pieces the synthesis copied meet misaligned by about a sample, and the
 * seams along the fibers (across the other axes) cut them lengthwise into
 * slivers: fibers.ini 128^3 before the blend, 73% of the inscribed-sphere
 * centres were 1-sample slivers; after it the fibers are thinner than the
 * source's (inscribed radius p50 1.41, the source's 1.73). A whole fiber
 * cannot come from one place (the output is longer than the source), but it
 * can be chained from whole source fibers. The output is cut into slabs
 * half the last block thick along the axis (where the last iteration's
 * pieces meet along it); a part is a component of the source's inside
 * within a slab moved by an offset (FIB_ENDS longer at each end). Every
 * inside sample of the synthesized field votes for the part its provenance
 * names (target slab, offset, the component holding the copied sample).
 * The fibers are then rebuilt as tracks, slab by slab along the axis:
 * - a track continues its source fiber at the same offset into the next
 *   slab (the same source samples: no joint at all) while the source has
 *   that slab and the fiber stays off the source's faces across the axis;
 * - else it switches to a part whose first cross-section covers the
 *   track's last one (intersection over union at least FIB_IOU), moved
 *   there: per source fiber, the voted part of the slab (moved by up to
 *   FIB_SHIFT samples across; the first in the order below) or else its
 *   best such cross-section anywhere in the source (aligned by centroids,
 *   then up to 1 sample); the least used source fiber first (samples
 *   pasted per sample of it), voted parts first among equals; with none
 *   the track ends (a fiber end inside the output);
 * - the voted parts no track took start new tracks where they may go, in
 *   order of the share of their inside voted (a part the synthesis copied
 *   whole before one it copied a sliver of), each as the least used source
 *   fiber that may go there too (its part at the source slice nearest the
 *   voted one's, centred on it; the voted fiber first among equals), then
 *   continued back towards the low face the same way (a fiber the
 *   synthesis starts mid-box is made whole backwards too).
 * The least used fiber first: the synthesis copies some source fibers far
 * more often than others (FIBERS 48^3 example seed 2: the two thinnest long
 * fibers 28 times their volume, the thickest 4, six fibers never), and
 * tracks that followed the votes alone were thinner than the source
 * (48^3 -> 96^3 seed 2: inscribed radii KS 0.208 against the source,
 * share of centres at least the source's p50 0.314 against 0.522; with it
 * KS 0.012, share 0.512).
 * A part is refused where more than FIB_OVER of its core (its samples within
 * the slab) lands on another track's core (a continuation), more than
 * FIB_NEAR on or next to one across (a switch), or, for a new fiber, more
 * than FIB_NEAR within FIB_GAP samples of one across (the source's fibers
 * are at least 2 samples apart in a cross-section, 4 at the 10th percentile,
 * 5 at the median; fibers.ini 32^3: with a gap of 1, 48^3 -> 96^3 had 14%
 * more fibers per cross-section than the source, with 3 3%; with the least
 * used fibers a gap of 3 gave volume fractions 0.148, 0.142, 0.145 against
 * the sources' 0.135, 0.124, 0.133 (seeds 1-3), 4 (the 10th percentile)
 * 0.126, 0.131, 0.131). Parts are pasted FIB_ENDS longer at each end (0:
 * crossing share 0.930, 0.957, 0.957 against 0.941, 0.957, 0.968 with 1).
 * Before (8708428), parts were pasted most votes first wherever at most a
 * third of them lay on earlier parts: the same fiber came twice side by side
 * from neighbouring offsets (double blobs) and half the parts were refused
 * (fibers broken): fibers.ini 128^3 seed 1, inscribed p50 2.00 against the
 * source's 1.73, 199 interior components, crossing share 0.598 against
 * 0.999; 48^3 -> 96^3, p50 2.00 (1.73), 44 interior components (none),
 * crossing 0.631 (0.967); with the tracks p50 1.73, 1, 0.967.
 * A paste is the part's inside and the outside within 3 samples of it, as a
 * union (the lower level wins); every other sample is as far outside as the
 * levels go (the output's redistancing makes it a distance field). It reads
 * the target, the provenance and the source, the same on every rank. */
#include <stdlib.h>
#include <string.h>
#include "field_impl.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"

#define FIB_ENDS 1      /* a part's samples beyond its slab at each end */
#define FIB_SHIFT 2     /* alignment of a voted part: up to this many samples across */
#define FIB_XS 128      /* samples of a track's last cross-section kept */
#define FIB_WIN 64      /* side of the window a cross-section is compared in */
#define FIB_IOU 0.5     /* least overlap (intersection over union) of a switch */
#define FIB_NEAR 0.05   /* share of a new part's core allowed next to another core */
#define FIB_OVER 0.1    /* share of a continuation allowed on another core */
#define FIB_GAP 4       /* a new fiber's core stays farther than this from other cores */

typedef struct fib_vote {
    int64_t slab, off, src; /* target slab, packed offset, the source sample copied */
} fib_vote;

typedef struct fib_part {
    int64_t votes, inside, slab, off, seed; /* seed: a source sample of the part */
} fib_part;

/* A cross-section: samples across the axis (target or source coordinates). */
typedef struct fib_xs {
    int32_t n;
    int32_t p[FIB_XS][2];
    double c[2];                  /* centroid */
} fib_xs;

typedef struct fib_track {
    int64_t o[3];                 /* offset: target sample = source sample - o */
    int64_t seed;                 /* a source sample of its last part's last core slice */
    int alive;
    fib_xs end;                   /* that slice, target coordinates across */
} fib_track;

/* A source fiber's cross-section where a part of it could start (any source fiber) */
typedef struct fib_start {
    int64_t sx, seed;             /* source slice along the axis, a sample of it */
    fib_xs xs;                    /* source coordinates across */
} fib_start;

/* A part a track may switch to. */
typedef struct fib_cand {
    int64_t o[3], seed, i;
    uint64_t use, vol;            /* its fiber's samples pasted, its samples */
    uint32_t f;
    int voted;
    double iou;
} fib_cand;

typedef struct fib_ctx {
    const gs_qfield *src;
    int64_t sn[3], tn[3], nt, ns, S, nslab;
    int axis, b[2];               /* the axis, the two across it */
    uint8_t inside[256];
    uint32_t *stamp, mark;
    int64_t *list;
    uint8_t *target, *out, *occ;  /* occ bit 0: a core, bit 1: within a sample across of one */
    int32_t *prov;
    int64_t pasted;
    uint32_t *fid, nf;            /* the source fiber (inside component) of each source sample */
    uint64_t *fvol, *fuse;        /* its samples, its samples pasted */
    int64_t *pick;                /* per fiber: a candidate start (fib_new) */
} fib_ctx;

static int cmp_fib_vote(const void *a_, const void *b_)
{
    const fib_vote *a = a_, *b = b_;
    if (a->slab != b->slab)
        return a->slab < b->slab ? -1 : 1;
    if (a->off != b->off)
        return a->off < b->off ? -1 : 1;
    return a->src < b->src ? -1 : a->src > b->src;
}

/* Slab, then the parts with the largest share of their inside voted first
 * (then the most votes, offset, seed); cut parts (no votes) last. */
static int cmp_fib_part(const void *a_, const void *b_)
{
    const fib_part *a = a_, *b = b_;
    if (a->slab != b->slab)
        return a->slab < b->slab ? -1 : 1;
    if ((a->votes < 0) != (b->votes < 0))
        return a->votes < 0 ? 1 : -1;
    if (a->votes > 0 && b->votes > 0 && a->votes * b->inside != b->votes * a->inside)
        return a->votes * b->inside > b->votes * a->inside ? -1 : 1;
    if (a->votes != b->votes)
        return a->votes > b->votes ? -1 : 1;
    if (a->off != b->off)
        return a->off < b->off ? -1 : 1;
    return a->seed < b->seed ? -1 : a->seed > b->seed;
}

/* The component of the source's inside within [lo, hi) along the axis
 * holding seed (6-neighbours, breadth first, marked with a new mark) into
 * c->list; returns its size; *cut: it reaches a face of the source across
 * the axis. */
static int64_t fib_grow(fib_ctx *c, int64_t lo, int64_t hi, int64_t seed, int *cut)
{
    const int64_t *sn = c->sn, st[3] = {1, sn[0], sn[0] * sn[1]};
    uint32_t mark = ++c->mark;
    int64_t n = 0, *list = c->list;
    *cut = 0;
    c->stamp[seed] = mark;
    list[n++] = seed;
    for (int64_t h = 0; h < n; h++) {
        int64_t v[3];
        gs_field_coords(list[h], sn, v);
        for (int a = 0; a < 3; a++)
            if (a != c->axis && (v[a] == 0 || v[a] == sn[a] - 1))
                *cut = 1;
        for (int d = 0; d < 6; d++) {
            int a = d / 2;
            int64_t w = v[a] + (d % 2 ? 1 : -1);
            if (w < 0 || w >= sn[a] || (a == c->axis && (w < lo || w >= hi)))
                continue;
            int64_t r = list[h] + (d % 2 ? 1 : -1) * st[a];
            if (c->stamp[r] != mark && c->inside[c->src->q[r]])
                c->stamp[r] = mark, list[n++] = r;
        }
    }
    return n;
}

/* Outside (not another part's inside). */
static int fib_band_keeps(int64_t r, const void *u)
{
    const fib_ctx *c = u;
    return !c->inside[c->src->q[r]];
}

/* Adds to c->list (n inside samples, the current mark) the outside samples
 * within 3 of them within [lo, hi) along the axis; returns the new count. */
static int64_t fib_band(fib_ctx *c, int64_t lo, int64_t hi, int64_t n)
{
    return gs_field_near3(c->sn, c->list, n, c->axis, lo, hi, c->stamp, c->mark, fib_band_keeps,
                          c, c->list, n);
}

/* The samples of c->list[0 .. n) at source slice sx along the axis, their
 * coordinates across moved by -o (o NULL: source coordinates). */
static void fib_slice(const fib_ctx *c, int64_t n, int64_t sx, const int64_t *o, fib_xs *xs)
{
    xs->n = 0;
    xs->c[0] = xs->c[1] = 0;
    for (int64_t i = 0; i < n && xs->n < FIB_XS; i++) {
        int64_t v[3];
        gs_field_coords(c->list[i], c->sn, v);
        if (v[c->axis] != sx)
            continue;
        for (int k = 0; k < 2; k++) {
            xs->p[xs->n][k] = (int32_t)(v[c->b[k]] - (o ? o[c->b[k]] : 0));
            xs->c[k] += xs->p[xs->n][k];
        }
        xs->n++;
    }
    for (int k = 0; k < 2 && xs->n; k++)
        xs->c[k] /= xs->n;
}

/* Intersection over union of cross-section a (drawn in win, origin w) and
 * cross-section b moved by d. */
static double fib_iou(const uint8_t *win, const int32_t w[2], int32_t na, const fib_xs *b,
                      const int32_t d[2])
{
    int32_t in = 0;
    for (int32_t i = 0; i < b->n; i++) {
        int32_t u = b->p[i][0] + d[0] - w[0], v = b->p[i][1] + d[1] - w[1];
        in += u >= 0 && u < FIB_WIN && v >= 0 && v < FIB_WIN && win[u + FIB_WIN * v];
    }
    return (double)in / (double)(na + b->n - in);
}

/* Draws cross-section a into win (origin w around its centroid). */
static void fib_draw(const fib_xs *a, uint8_t *win, int32_t w[2])
{
    memset(win, 0, FIB_WIN * FIB_WIN);
    for (int k = 0; k < 2; k++)
        w[k] = (int32_t)a->c[k] - FIB_WIN / 2;
    for (int32_t i = 0; i < a->n; i++) {
        int32_t u = a->p[i][0] - w[0], v = a->p[i][1] - w[1];
        if (u >= 0 && u < FIB_WIN && v >= 0 && v < FIB_WIN)
            win[u + FIB_WIN * v] = 1;
    }
}

/* The best move of b (d0 + up to r samples each way across, nearest first
 * among equals) onto a (drawn in win); returns its overlap, *d the move. */
static double fib_align(const uint8_t *win, const int32_t w[2], int32_t na, const fib_xs *b,
                        const int32_t d0[2], int r, int32_t d[2])
{
    double best = -1;
    for (int32_t e = -r; e <= r; e++)
        for (int32_t f = -r; f <= r; f++) {
            int32_t m[2] = {d0[0] + e, d0[1] + f};
            double v = fib_iou(win, w, na, b, m);
            int closer = e * e + f * f < (d[0] - d0[0]) * (d[0] - d0[0]) + (d[1] - d0[1]) * (d[1] - d0[1]);
            if (v > best + 1e-12 || (v > best - 1e-12 && closer))
                best = v, d[0] = m[0], d[1] = m[1];
        }
    return best;
}

/* Places the part of slab k at offset o holding source sample seed when it
 * may go there: gap 0, at most FIB_OVER of its core on other cores; gap 1,
 * at most FIB_NEAR of it on or next to one across (the 3 x 3 samples
 * around); gap > 1, at most FIB_NEAR of it within gap of one across.
 * Returns whether it pasted. With tr, the track takes it: offset,
 * continuation seed, last cross-section. */
static int fib_place(fib_ctx *c, int64_t k, const int64_t o[3], int64_t seed, int gap, int dry,
                     fib_track *tr)
{
    const int ax = c->axis;
    const int64_t ts[3] = {1, c->tn[0], c->tn[0] * c->tn[1]};
    int64_t len = c->tn[ax] - k * c->S < c->S ? c->tn[ax] - k * c->S : c->S;
    int64_t lo = k * c->S + o[ax], hi = lo + len;
    if (lo < 0 || hi > c->sn[ax] || !c->inside[c->src->q[seed]])
        return 0;
    int cut;
    int64_t n = fib_grow(c, lo - FIB_ENDS, hi + FIB_ENDS, seed, &cut);
    if (cut)
        return 0;
    int64_t in = 0, on = 0, last = -1, t[3];
    for (int64_t i = 0; i < n; i++) {
        int64_t v[3], ti = gs_field_offset_target(c->sn, c->tn, c->list[i], o, t);
        gs_field_coords(c->list[i], c->sn, v);
        if (ti < 0 || v[ax] < lo || v[ax] >= hi)
            continue;
        in++;
        if (v[ax] == hi - 1 && last < 0)
            last = c->list[i];
        if (gap <= 1) {
            on += (c->occ[ti] & (gap ? 2 : 1)) != 0;
            continue;
        }
        int hit = 0;
        for (int e = -gap; e <= gap && !hit; e++)
            for (int f = -gap; f <= gap && !hit; f++) {
                int64_t u = t[c->b[0]] + e, w = t[c->b[1]] + f;
                if (e * e + f * f <= gap * gap && u >= 0 && u < c->tn[c->b[0]] && w >= 0 &&
                    w < c->tn[c->b[1]])
                    hit = c->occ[ti + e * ts[c->b[0]] + f * ts[c->b[1]]] & 1;
            }
        on += hit;
    }
    if (!in || (double)on > (gap ? FIB_NEAR : FIB_OVER) * (double)in)
        return 0;
    if (dry)
        return 1;
    c->fuse[c->fid[seed]] += (uint64_t)in;
    if (tr) {
        memcpy(tr->o, o, sizeof tr->o);
        tr->seed = last;
        tr->alive = last >= 0;
        fib_slice(c, n, hi - 1, o, &tr->end);
    }
    /* cores and their neighbours across */
    for (int64_t i = 0; i < n; i++) {
        int64_t v[3], ti = gs_field_offset_target(c->sn, c->tn, c->list[i], o, t);
        gs_field_coords(c->list[i], c->sn, v);
        if (ti < 0 || v[ax] < lo || v[ax] >= hi)
            continue;
        c->occ[ti] |= 1;
        for (int e = -1; e <= 1; e++)
            for (int f = -1; f <= 1; f++) {
                int64_t u = t[c->b[0]] + e, w = t[c->b[1]] + f;
                if (u >= 0 && u < c->tn[c->b[0]] && w >= 0 && w < c->tn[c->b[1]])
                    c->occ[ti + e * ts[c->b[0]] + f * ts[c->b[1]]] |= 2;
            }
    }
    n = fib_band(c, lo - FIB_ENDS, hi + FIB_ENDS, n);
    for (int64_t i = 0; i < n; i++) {
        int64_t ti = gs_field_offset_target(c->sn, c->tn, c->list[i], o, t);
        if (ti >= 0 && c->src->q[c->list[i]] < c->out[ti]) {
            c->out[ti] = c->src->q[c->list[i]];
            c->prov[ti] = (int32_t)c->list[i];
        }
    }
    c->pasted++;
    return 1;
}

/* A new track (its part of slab `slab` at offset o, holding source sample
 * seed) continued back towards the low face: the same source fiber at the
 * same offset while it may go there. */
static void fib_back(fib_ctx *c, int64_t slab, const int64_t o[3], int64_t seed)
{
    const int ax = c->axis;
    for (int64_t k = slab - 1; k >= 0; k--) {
        /* a sample of the part of slab k + 1 at its first core slice */
        int cut;
        int64_t lo = (k + 1) * c->S + o[ax];
        int64_t n = fib_grow(c, lo - FIB_ENDS, lo + c->S + FIB_ENDS, seed, &cut), first = -1;
        for (int64_t i = 0; i < n && first < 0; i++)
            if (c->list[i] / (ax == 0 ? 1 : ax == 1 ? c->sn[0] : c->sn[0] * c->sn[1]) %
                    c->sn[ax] == lo)
                first = c->list[i];
        if (first < 0 || !fib_place(c, k, o, first, FIB_GAP, 0, NULL))
            return;
        seed = first;
    }
}

/* The parts of every source fiber that fit in the source (uncut, a slab
 * long from slice sx), with their first cross-sections (source
 * coordinates) into starts (NULL: counted only); returns their count. */
static int64_t fib_starts(fib_ctx *c, fib_start *starts)
{
    const int ax = c->axis;
    const int64_t sa = ax == 0 ? 1 : ax == 1 ? c->sn[0] : c->sn[0] * c->sn[1];
    int64_t m = 0;
    for (int64_t sx = 0; sx + c->S <= c->sn[ax]; sx++) {
        uint32_t mark0 = c->mark + 1;
        for (int64_t i = 0; i < c->ns; i++) {
            if (i / sa % c->sn[ax] != sx || !c->inside[c->src->q[i]] || c->stamp[i] >= mark0)
                continue;
            int cut;
            int64_t n = fib_grow(c, sx - FIB_ENDS, sx + c->S + FIB_ENDS, i, &cut);
            if (cut)
                continue;
            if (starts) {
                starts[m].sx = sx, starts[m].seed = i;
                fib_slice(c, n, sx, NULL, &starts[m].xs);
            }
            m++;
        }
    }
    return m;
}

/* Whether source fiber a is less used than b (samples pasted per sample). */
static int fib_less_used(const fib_ctx *c, uint32_t a, uint32_t b)
{
    return c->fuse[a] * c->fvol[b] < c->fuse[b] * c->fvol[a];
}

/* The least used fiber first (samples pasted per sample), then voted
 * parts, the larger overlap, the order found. */
static int cmp_fib_cand(const void *a_, const void *b_)
{
    const fib_cand *a = a_, *b = b_;
    if (a->use * b->vol != b->use * a->vol)
        return a->use * b->vol < b->use * a->vol ? -1 : 1;
    if (a->voted != b->voted)
        return a->voted ? -1 : 1;
    if (a->iou != b->iou)
        return a->iou > b->iou ? -1 : 1;
    return a->i < b->i ? -1 : a->i > b->i;
}

/* A new track where the voted part of slab k at offset o (holding seed,
 * first cross-section h in target coordinates) may start: the least used
 * source fiber (samples pasted per source sample; the voted one first among
 * equals) whose part at the source slice nearest the voted part's, centred
 * on h, may go there too. The synthesis copies some source fibers far more
 * than others (FIBERS 48^3 seed 2: the two thinnest long fibers 28 times
 * their volume, the thickest 4, six fibers never), so new tracks following
 * the votes alone were thinner than the source. Returns whether it pasted. */
static int fib_new(fib_ctx *c, int64_t k, const int64_t o[3], int64_t seed, const fib_xs *h,
                   const fib_start *starts, int64_t nstart, fib_track *tr, int64_t *placed)
{
    *placed = seed;
    if (!fib_place(c, k, o, seed, FIB_GAP, 1, NULL))
        return 0;
    const int ax = c->axis;
    int64_t s0 = k * c->S + o[ax];
    uint32_t nf = c->nf, voted = c->fid[seed];
    int64_t *pick = c->pick;
    for (uint32_t f = 0; f <= nf; f++)
        pick[f] = -1;
    for (int64_t i = 0; i < nstart; i++) {
        uint32_t f = c->fid[starts[i].seed];
        int64_t j = pick[f];
        if (f == voted || !starts[i].xs.n)
            continue;
        if (j < 0 || llabs(starts[i].sx - s0) < llabs(starts[j].sx - s0))
            pick[f] = i;
    }
    for (;;) {
        int64_t best = -1;
        uint32_t bf = 0;
        for (uint32_t f = 1; f <= nf; f++)
            if (pick[f] >= 0 && (best < 0 || fib_less_used(c, f, bf)))
                best = pick[f], bf = f;
        if (best < 0 || !fib_less_used(c, bf, voted))
            return fib_place(c, k, o, seed, FIB_GAP, 0, tr);
        pick[bf] = -1;
        const fib_xs *x = &starts[best].xs;
        int64_t p[3];
        p[ax] = starts[best].sx - k * c->S;
        for (int q = 0; q < 2; q++) {
            double d = h->c[q] - x->c[q];
            p[c->b[q]] = -(int64_t)(d + (d > 0 ? 0.5 : -0.5));
        }
        if (fib_place(c, k, p, starts[best].seed, FIB_GAP, 0, tr)) {
            *placed = starts[best].seed;
            return 1;
        }
    }
}

gs_err gs_field_fibers_rebuild(const gs_qfield *src, const int64_t tn[3], uint8_t *target,
                               int32_t *prov, int axis, int64_t S, int64_t *completed,
                               int64_t *removed)
{
    fib_ctx c = {0};
    c.src = src;
    c.sn[0] = src->nx, c.sn[1] = src->ny, c.sn[2] = src->nz;
    memcpy(c.tn, tn, sizeof c.tn);
    c.nt = tn[0] * tn[1] * tn[2], c.ns = c.sn[0] * c.sn[1] * c.sn[2];
    c.S = S, c.axis = axis, c.b[0] = axis == 0 ? 1 : 0, c.b[1] = axis == 2 ? 1 : 2;
    c.nslab = (tn[axis] + S - 1) / S;
    c.target = target, c.prov = prov;
    for (int l = 0; l < 256; l++)
        c.inside[l] = gs_qfield_value(src, (uint8_t)l) < 0;
    fib_vote *votes = NULL;
    fib_part *parts = NULL;
    fib_track *tracks = NULL;
    fib_start *starts = NULL;
    fib_xs *heads = NULL;
    fib_cand *cands = NULL;
    int64_t *first = NULL, ntr = 0, nstart = 0;
    uint8_t win[FIB_WIN * FIB_WIN];
    gs_err err = GS_OK;
    int64_t nv = 0;
    for (int64_t i = 0; i < c.nt; i++)
        nv += c.inside[target[i]] && prov[i] >= 0 && c.inside[src->q[prov[i]]];
    GS_TRY(err, gs_alloc_array((void **)&votes, (size_t)(nv ? nv : 1), sizeof *votes, "votes"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&parts, (size_t)(nv ? nv : 1), sizeof *parts, "parts"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&c.list, (size_t)c.ns, sizeof *c.list, "part samples"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&c.stamp, (size_t)c.ns, sizeof *c.stamp, "part marks"),
           done);
    memset(c.stamp, 0, (size_t)c.ns * sizeof *c.stamp);
    /* the source's fibers */
    GS_TRY(err, gs_alloc_array((void **)&c.fid, (size_t)c.ns, sizeof *c.fid, "fiber ids"), done);
    {
        uint8_t *mask = (uint8_t *)c.list; /* scratch, as large */
        for (int64_t i = 0; i < c.ns; i++)
            mask[i] = c.inside[src->q[i]];
        GS_TRY(err, gs_measure_components3(mask, (int)c.sn[0], (int)c.sn[1], (int)c.sn[2], NULL,
                                           c.fid, &c.nf, &c.fvol), done);
    }
    GS_TRY(err, gs_alloc_array((void **)&c.fuse, (size_t)c.nf + 1, sizeof *c.fuse, "fiber use"),
           done);
    memset(c.fuse, 0, ((size_t)c.nf + 1) * sizeof *c.fuse);
    GS_TRY(err, gs_alloc_array((void **)&c.pick, (size_t)c.nf + 1, sizeof *c.pick, "fiber picks"),
           done);
    nv = 0;
    for (int64_t i = 0; i < c.nt; i++) {
        if (!c.inside[target[i]] || prov[i] < 0 || !c.inside[src->q[prov[i]]])
            continue;
        int64_t t[3], p[3], o[3];
        gs_field_coords(i, tn, t), gs_field_coords(prov[i], c.sn, p);
        for (int d = 0; d < 3; d++)
            o[d] = p[d] - t[d];
        votes[nv++] = (fib_vote){t[axis] / S, gs_field_pack_offset(o), prov[i]};
    }
    qsort(votes, (size_t)nv, sizeof *votes, cmp_fib_vote);
    /* the parts the votes name: per (slab, offset) the components of the
     * source's inside in its span holding the voted samples; a cut part
     * keeps its votes (so they stay its own) but is never a candidate */
    int64_t np = 0;
    for (int64_t i = 0; i < nv;) {
        int64_t j = i, o[3];
        while (j < nv && votes[j].slab == votes[i].slab && votes[j].off == votes[i].off)
            j++;
        gs_field_unpack_offset(votes[i].off, o);
        int64_t lo = votes[i].slab * S + o[axis] - FIB_ENDS, hi = lo + S + 2 * FIB_ENDS;
        uint32_t mark0 = c.mark + 1;
        int64_t first_part = np;
        for (int64_t k = i; k < j; k++) {
            int64_t r = votes[k].src;
            if (c.stamp[r] >= mark0) {
                parts[first_part + (c.stamp[r] - mark0)].votes++;
                continue;
            }
            int cut;
            int64_t n = fib_grow(&c, lo, hi, r, &cut);
            parts[np++] = (fib_part){cut ? INT64_MIN / 2 : 1, n, votes[i].slab, votes[i].off, r};
        }
        i = j;
    }
    gs_free(votes);
    votes = NULL;
    qsort(parts, (size_t)np, sizeof *parts, cmp_fib_part);
    GS_TRY(err, gs_alloc_array((void **)&first, (size_t)c.nslab + 1, sizeof *first, "slabs"), done);
    for (int64_t k = 0, i = 0; k <= c.nslab; k++) {
        while (i < np && parts[i].slab < k)
            i++;
        first[k] = i;
    }
    /* every source fiber's cross-sections where a part could start */
    nstart = fib_starts(&c, NULL);
    GS_TRY(err, gs_alloc_array((void **)&starts, (size_t)(nstart ? nstart : 1), sizeof *starts,
                               "fiber starts"), done);
    fib_starts(&c, starts);
    GS_TRY(err, gs_alloc_array((void **)&tracks, (size_t)(np ? np : 1), sizeof *tracks, "tracks"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&heads, (size_t)(np ? np : 1), sizeof *heads, "heads"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&cands, (size_t)c.nf + 1, sizeof *cands, "switches"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&c.out, (size_t)c.nt, 1, "rebuilt fibers"), done);
    GS_TRY(err, gs_alloc_array((void **)&c.occ, (size_t)c.nt, 1, "fiber cores"), done);
    memset(c.out, 255, (size_t)c.nt);
    memset(c.occ, 0, (size_t)c.nt);
    int64_t ended = 0;
    for (int64_t k = 0; k < c.nslab; k++) {
        int64_t lo = first[k], hi = first[k + 1];
        /* the slab's candidate parts' first cross-sections (target coordinates) */
        for (int64_t i = lo; i < hi; i++) {
            heads[i - lo].n = 0;
            if (parts[i].votes < 0 || 8 * parts[i].votes < parts[i].inside)
                continue;
            int64_t o[3];
            gs_field_unpack_offset(parts[i].off, o);
            int cut;
            int64_t s0 = k * S + o[axis];
            int64_t n = fib_grow(&c, s0 - FIB_ENDS, s0 + S + FIB_ENDS, parts[i].seed, &cut);
            fib_slice(&c, n, s0, o, &heads[i - lo]);
        }
        /* continuations, then switches */
        int64_t ntr0 = ntr;
        for (int64_t j = 0; j < ntr0; j++) {
            fib_track *tr = &tracks[j];
            if (!tr->alive)
                continue;
            fib_track next = *tr;
            if (fib_place(&c, k, tr->o, tr->seed, 0, 0, &next)) {
                *tr = next;
                continue;
            }
            /* a switch: per source fiber the voted part of the slab covering
             * the track's end (the most votes first), else its best covering
             * cross-section; the least used fiber first */
            int32_t w[2], d[2] = {0, 0}, z[2] = {0, 0};
            fib_draw(&tr->end, win, w);
            int64_t nc = 0;
            for (uint32_t f = 0; f <= c.nf; f++)
                c.pick[f] = -1;
            for (int64_t i = lo; i < hi; i++) {
                const fib_xs *h = &heads[i - lo];
                uint32_t f = c.fid[parts[i].seed];
                if (!h->n || c.pick[f] >= 0 ||
                    (h->c[0] - tr->end.c[0]) * (h->c[0] - tr->end.c[0]) +
                            (h->c[1] - tr->end.c[1]) * (h->c[1] - tr->end.c[1]) > 36)
                    continue;
                double v = fib_align(win, w, tr->end.n, h, z, FIB_SHIFT, d);
                if (v < FIB_IOU)
                    continue;
                fib_cand *q = &cands[nc];
                gs_field_unpack_offset(parts[i].off, q->o);
                q->o[c.b[0]] -= d[0], q->o[c.b[1]] -= d[1];
                q->seed = parts[i].seed, q->f = f, q->voted = 1, q->iou = v, q->i = nc;
                c.pick[f] = nc++;
            }
            for (int64_t i = 0; i < nstart; i++) {
                const fib_xs *h = &starts[i].xs;
                uint32_t f = c.fid[starts[i].seed];
                if (10 * h->n < 6 * tr->end.n || 10 * h->n > 16 * tr->end.n ||
                    (c.pick[f] >= 0 && cands[c.pick[f]].voted))
                    continue;
                int32_t d0[2] = {(int32_t)(tr->end.c[0] - h->c[0] + (tr->end.c[0] > h->c[0] ? 0.5 : -0.5)),
                                 (int32_t)(tr->end.c[1] - h->c[1] + (tr->end.c[1] > h->c[1] ? 0.5 : -0.5))};
                double v = fib_align(win, w, tr->end.n, h, d0, 1, d);
                if (v < FIB_IOU - 1e-9 || (c.pick[f] >= 0 && v <= cands[c.pick[f]].iou))
                    continue;
                int64_t at = c.pick[f] >= 0 ? c.pick[f] : nc++;
                fib_cand *q = &cands[at];
                q->o[axis] = starts[i].sx - k * S;
                q->o[c.b[0]] = -d[0], q->o[c.b[1]] = -d[1];
                q->seed = starts[i].seed, q->f = f, q->voted = 0, q->iou = v, q->i = at;
                c.pick[f] = at;
            }
            for (int64_t i = 0; i < nc; i++)
                cands[i].use = c.fuse[cands[i].f], cands[i].vol = c.fvol[cands[i].f];
            qsort(cands, (size_t)nc, sizeof *cands, cmp_fib_cand);
            int placed = 0;
            for (int64_t i = 0; i < nc && !placed; i++) {
                placed = fib_place(&c, k, cands[i].o, cands[i].seed, 1, 0, &next);
            }
            if (placed)
                *tr = next;
            else
                tr->alive = 0, ended++;
        }
        /* new tracks: the parts with the most votes no track took */
        for (int64_t i = lo; i < hi; i++) {
            if (!heads[i - lo].n)
                continue;
            int64_t o[3];
            gs_field_unpack_offset(parts[i].off, o);
            fib_track next = {0};
            int64_t placed_seed;
            if (!fib_new(&c, k, o, parts[i].seed, &heads[i - lo], starts, nstart, &next,
                         &placed_seed))
                continue;
            tracks[ntr++] = next;
            fib_back(&c, k, next.o, placed_seed);
        }
    }
    memcpy(target, c.out, (size_t)c.nt);
    *completed = c.pasted;
    *removed = ended;
done:
    gs_free(votes);
    gs_free(parts);
    gs_free(tracks);
    gs_free(starts);
    gs_free(heads);
    gs_free(cands);
    gs_free(first);
    gs_free(c.list);
    gs_free(c.stamp);
    gs_free(c.out);
    gs_free(c.occ);
    gs_free(c.fid);
    gs_free(c.fvol);
    gs_free(c.fuse);
    gs_free(c.pick);
    return err;
}
