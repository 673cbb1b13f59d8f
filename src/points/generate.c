/* Example geometry textures of the paper's kinds (height field, chain mail,
 * weave, flowers) as Poisson-disk samplings of unions of parametric
 * primitives, and the padding check; see include/geosynth/points.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

enum { PRIM_HEIGHT, PRIM_TORUS, PRIM_TUBE_X, PRIM_TUBE_Y, PRIM_ELLIPSOID };

typedef struct hf_image {
    int w, h;
    const uint8_t *u8;
    const float *f32;
    double scale;
} hf_image;

typedef struct prim {
    int kind;
    double c[3];   /* center (torus, ellipsoid) or line offset (tubes) */
    double R[9];   /* local -> world rotation, row-major */
    double a, b, e; /* torus: major, tube radius, bump height; ellipsoid: semi-axes;
                       tube: radius, amplitude, period */
    double phase;
    double lo[2], hi[2]; /* parameter domain in world units (height field, tubes) */
    const hf_image *img;
    double bound_r;      /* bounding sphere radius around c (inside test culling) */
} prim;

static void rot_zy(double az, double ay, double R[9])
{
    double cz = cos(az), sz = sin(az), cy = cos(ay), sy = sin(ay);
    /* Rz * Ry */
    double M[9] = {cz * cy, -sz, cz * sy, sz * cy, cz, sz * sy, -sy, 0, cy};
    memcpy(R, M, sizeof M);
}

static void to_world(const prim *pr, const double l[3], double w[3])
{
    for (int d = 0; d < 3; d++)
        w[d] = pr->c[d] + pr->R[3 * d] * l[0] + pr->R[3 * d + 1] * l[1] + pr->R[3 * d + 2] * l[2];
}

static void to_local(const prim *pr, const double w[3], double l[3])
{
    double e[3] = {w[0] - pr->c[0], w[1] - pr->c[1], w[2] - pr->c[2]};
    for (int d = 0; d < 3; d++)
        l[d] = pr->R[d] * e[0] + pr->R[3 + d] * e[1] + pr->R[6 + d] * e[2];
}

static double hf_value(const hf_image *im, double fx, double fy)
{
    /* fx, fy in [0, 1]: pixel centers at (i + 0.5) / w */
    double x = fx * im->w - 0.5, y = fy * im->h - 0.5;
    int x0 = (int)floor(x), y0 = (int)floor(y);
    double tx = x - x0, ty = y - y0;
    double v[4];
    for (int k = 0; k < 4; k++) {
        int xi = x0 + (k & 1), yi = y0 + (k >> 1);
        xi = xi < 0 ? 0 : xi >= im->w ? im->w - 1 : xi;
        yi = yi < 0 ? 0 : yi >= im->h ? im->h - 1 : yi;
        size_t i = (size_t)yi * im->w + xi;
        v[k] = im->u8 ? im->u8[i] / 255.0 : (double)im->f32[i];
    }
    return im->scale * ((v[0] * (1 - tx) + v[1] * tx) * (1 - ty) + (v[2] * (1 - tx) + v[3] * tx) * ty);
}

/* The trigonometric terms of a primitive that depend on u alone (v = 0) or
 * on v alone (v = 1), so a frame's three evaluations share them. */
static void prim_trig(const prim *pr, int v, double t, double out[3])
{
    switch (pr->kind) {
    case PRIM_TORUS: {
        double A = 2 * GS_PI * t;
        out[0] = cos((v ? 3 : 12) * A);
        out[1] = cos(A);
        out[2] = sin(A);
        return;
    }
    case PRIM_TUBE_X:
    case PRIM_TUBE_Y: {
        double A = v ? 2 * GS_PI * t : GS_PI * (pr->lo[0] + t * (pr->hi[0] - pr->lo[0])) / pr->e +
                                          pr->phase;
        out[0] = cos(A);
        out[1] = sin(A);
        return;
    }
    case PRIM_ELLIPSOID: {
        double A = v ? GS_PI * t : 2 * GS_PI * t;
        out[0] = cos(A);
        out[1] = sin(A);
        return;
    }
    default:
        return;
    }
}

/* Point at parameters (u, v) in [0,1)^2 (tu, tv: prim_trig of u and v)
 * and, when ref != NULL, a reference point the outward normal points away
 * from. */
static void prim_point(const prim *pr, double u, double v, const double tu[3],
                       const double tv[3], double p[3], double ref[3])
{
    switch (pr->kind) {
    case PRIM_HEIGHT: {
        double x = pr->lo[0] + u * (pr->hi[0] - pr->lo[0]);
        double y = pr->lo[1] + v * (pr->hi[1] - pr->lo[1]);
        p[0] = x;
        p[1] = y;
        p[2] = hf_value(pr->img, u, v);
        if (ref) {
            ref[0] = x;
            ref[1] = y;
            ref[2] = p[2] - 1;
        }
        return;
    }
    case PRIM_TORUS: {
        double bu = tu[0], bv = tv[0];
        bu = bu > 0 ? bu * bu : 0;
        bv = bv > 0 ? bv * bv : 0;
        double rt = pr->b + pr->e * bu * bv;
        double l[3] = {(pr->a + rt * tv[1]) * tu[1], (pr->a + rt * tv[1]) * tu[2], rt * tv[2]};
        to_world(pr, l, p);
        if (ref) {
            double lc[3] = {pr->a * tu[1], pr->a * tu[2], 0};
            to_world(pr, lc, ref);
        }
        return;
    }
    case PRIM_TUBE_X:
    case PRIM_TUBE_Y: {
        int ax = pr->kind == PRIM_TUBE_X ? 0 : 1;
        double t = pr->lo[0] + u * (pr->hi[0] - pr->lo[0]);
        double z = pr->c[2] + pr->a * 0 + pr->b * tu[0];
        double dz = -pr->b * GS_PI / pr->e * tu[1];
        double T[3] = {0, 0, dz}, N1[3] = {0, 0, 0}, N2[3];
        T[ax] = 1;
        N1[1 - ax] = 1;
        v3_normalize(T);
        v3_cross(T, N1, N2);
        double cc[3];
        cc[ax] = t;
        cc[1 - ax] = pr->c[1 - ax];
        cc[2] = z;
        for (int d = 0; d < 3; d++) {
            p[d] = cc[d] + pr->a * (tv[0] * N1[d] + tv[1] * N2[d]);
            if (ref)
                ref[d] = cc[d];
        }
        return;
    }
    default: { /* ellipsoid: th = pi v, ph = 2 pi u */
        double l[3] = {pr->a * tv[1] * tu[0], pr->b * tv[1] * tu[1], pr->e * tv[0]};
        to_world(pr, l, p);
        if (ref)
            memcpy(ref, pr->c, 3 * sizeof *ref);
        return;
    }
    }
}

/* 1 when p is inside the solid bounded by pr (with a small margin). */
static int prim_inside(const prim *pr, const double p[3])
{
    if (pr->kind == PRIM_HEIGHT || pr->kind == PRIM_TUBE_X || pr->kind == PRIM_TUBE_Y)
        return 0; /* never overlap another primitive by construction */
    if (v3_dist2(p, pr->c) > pr->bound_r * pr->bound_r)
        return 0;
    double l[3];
    to_local(pr, p, l);
    if (pr->kind == PRIM_TORUS) {
        double rr = sqrt(l[0] * l[0] + l[1] * l[1]) - pr->a;
        return rr * rr + l[2] * l[2] < 0.97 * pr->b * pr->b;
    }
    double s = l[0] * l[0] / (pr->a * pr->a) + l[1] * l[1] / (pr->b * pr->b) +
               l[2] * l[2] / (pr->e * pr->e);
    return s < 0.97;
}

/* Point at (u, v) (prim_point) with the trigonometric terms it used, so
 * prim_normal can take them up. */
static void prim_pos(const prim *pr, double u, double v, double tu[3], double tv[3], double p[3],
                     double ref[3])
{
    prim_trig(pr, 0, u, tu);
    prim_trig(pr, 1, v, tv);
    prim_point(pr, u, v, tu, tv, p, ref);
}

/* Outward unit normal n at p = prim_pos(u, v) by forward differences;
 * returns the area element |dp/du x dp/dv|. */
static double prim_normal(const prim *pr, double u, double v, const double tu[3],
                          const double tv[3], const double p[3], const double ref[3], double n[3])
{
    double pu[3], pv[3];
    const double h = 1e-5;
    double tuh[3], tvh[3];
    prim_trig(pr, 0, u + h, tuh);
    prim_trig(pr, 1, v + h, tvh);
    prim_point(pr, u + h, v, tuh, tv, pu, NULL);
    prim_point(pr, u, v + h, tu, tvh, pv, NULL);
    for (int d = 0; d < 3; d++) {
        pu[d] = (pu[d] - p[d]) / h;
        pv[d] = (pv[d] - p[d]) / h;
    }
    v3_cross(pu, pv, n);
    double dA = v3_normalize(n);
    double out[3] = {p[0] - ref[0], p[1] - ref[1], p[2] - ref[2]};
    if (v3_dot(n, out) < 0)
        for (int d = 0; d < 3; d++)
            n[d] = -n[d];
    return dA;
}

static double prim_frame(const prim *pr, double u, double v, double p[3], double n[3])
{
    double ref[3], tu[3], tv[3];
    prim_pos(pr, u, v, tu, tv, p, ref);
    return prim_normal(pr, u, v, tu, tv, p, ref, n);
}

static int prim_bounded(const prim *pr)
{
    return pr->kind == PRIM_TORUS || pr->kind == PRIM_ELLIPSOID;
}

/* For each bounded primitive i (its surface lies within bound_r of c), the
 * bounded primitives j != i whose bounding spheres come near its own
 * (CSR: nb[start[i] .. start[i + 1])): the only ones whose prim_inside can
 * be true at a point of i (the others fail its bounding-sphere test, and
 * unbounded kinds never contain a point). The test is an OR, so checking
 * fewer primitives changes nothing. Sweep over centres sorted by x. */
static gs_err prim_neighbours(const prim *prims, int np, int **start_out, int **nb_out)
{
    keyed *key = NULL;
    int *order = NULL, *start = NULL, *nb = NULL, *fill = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&key, (size_t)np + 1, sizeof *key, "prim order"), done);
    GS_TRY(err, gs_alloc_array((void **)&order, (size_t)np + 1, sizeof *order, "prim order"), done);
    GS_TRY(err, gs_alloc_array((void **)&start, (size_t)np + 1, sizeof *start, "prim order"), done);
    GS_TRY(err, gs_alloc_array((void **)&fill, (size_t)np + 1, sizeof *fill, "prim order"), done);
    int nbounded = 0;
    double maxb = 0;
    for (int i = 0; i < np; i++)
        if (prim_bounded(&prims[i])) {
            key[nbounded++] = (keyed){prims[i].c[0], (size_t)i};
            maxb = fmax(maxb, prims[i].bound_r);
        }
    qsort(key, (size_t)nbounded, sizeof *key, gs_points_keyed_cmp);
    for (int a = 0; a < nbounded; a++)
        order[a] = (int)key[a].idx;
    /* Two passes over the pairs: count, then fill. */
    for (int pass = 0; pass < 2; pass++) {
        for (int a = 0; a < nbounded; a++) {
            const prim *pa = &prims[order[a]];
            for (int b = a + 1; b < nbounded; b++) {
                const prim *pb = &prims[order[b]];
                double reach = 1.01 * (pa->bound_r + pb->bound_r) + 1e-9;
                if (pb->c[0] - pa->c[0] > 1.01 * (pa->bound_r + maxb) + 1e-9)
                    break;
                if (v3_dist2(pa->c, pb->c) > reach * reach)
                    continue;
                if (pass == 0) {
                    start[order[a] + 1]++;
                    start[order[b] + 1]++;
                } else {
                    nb[start[order[a]] + fill[order[a]]++] = order[b];
                    nb[start[order[b]] + fill[order[b]]++] = order[a];
                }
            }
        }
        if (pass == 0) {
            for (int i = 0; i < np; i++)
                start[i + 1] += start[i];
            GS_TRY(err, gs_alloc_array((void **)&nb, start[np] ? (size_t)start[np] : 1, sizeof *nb,
                                       "prim neighbours"), done);
        }
    }
    *start_out = start;
    *nb_out = nb;
    start = nb = NULL;
done:
    gs_free(key);
    gs_free(order);
    gs_free(start);
    gs_free(nb);
    gs_free(fill);
    return err;
}

/* The status every process returns (gp->agree; here alone: local). */
static gs_err gen_agree(const gs_points_gen_params *gp, gs_err local)
{
    return gp->agree ? gp->agree(gp->map_user, local) : local;
}

/* Items [0, n) of fn through gp->map (or here). */
static gs_err gen_map(const gs_points_gen_params *gp, size_t n, size_t bytes,
                      gs_points_range_fn fn, void *ctx, void *out)
{
    if (n == 0)
        return GS_OK;
    if (gp->map)
        return gp->map(gp->map_user, n, bytes, fn, ctx, out);
    return fn(ctx, 0, n, out);
}

/* The dart throwing of sample_prims. Try t (over all primitives, in order)
 * takes words 6t .. 6t + 5 of the stream (three uniforms u, v, acc), so any
 * range of tries starts from its own position in the stream. Everything a
 * try decides but the distance to the samples already taken (the acceptance
 * by area, the box, the other primitives) depends on the try alone; those
 * run over the map hook, the distance test then runs here in try order,
 * exactly the serial loop. */
typedef struct dart_ctx {
    const prim *prims;
    int np;
    const int *nb_start, *nb;
    const double *max_dA;   /* per primitive, with the rejection's margin */
    const uint64_t *first;  /* np + 1: first try of each primitive */
    uint64_t base;          /* first try of this map */
    double lo[2], hi[2];    /* the sampled xy range, already shrunk by s */
    uint64_t seed, stream;
} dart_ctx;

typedef struct dart {
    double p[3];
    int64_t keep; /* passed every test but the distance one */
} dart;

/* The stream at try t of the dart throwing. */
static void dart_rng(const dart_ctx *c, uint64_t t, gs_rng *rng)
{
    uint64_t word = 6 * t;
    gs_rng_restore(rng, (gs_rng_state){c->seed, c->stream, word / 4, word % 4});
}

/* (area, max_dA) of primitives [lo, hi) (gs_points_range_fn). */
static gs_err prim_scan(void *vctx, size_t lo, size_t hi, void *vout)
{
    const dart_ctx *c = vctx;
    double *out = vout;
    const int scan = 48;
    for (size_t i = lo; i < hi; i++) {
        const prim *pr = &c->prims[i];
        double area = 0, max_dA = 0, p[3], n[3];
        for (int a = 0; a < scan; a++)
            for (int b = 0; b < scan; b++) {
                double dA = prim_frame(pr, (a + 0.5) / scan, (b + 0.5) / scan, p, n);
                area += dA / (scan * scan);
                max_dA = fmax(max_dA, dA);
            }
        out[2 * (i - lo)] = area;
        out[2 * (i - lo) + 1] = max_dA;
    }
    return GS_OK;
}

/* Tries base + [lo, hi) (gs_points_range_fn). */
static gs_err throw_darts(void *vctx, size_t lo, size_t hi, void *vout)
{
    const dart_ctx *c = vctx;
    dart *out = vout;
    uint64_t t0 = c->base + lo;
    int i = 0;
    while (c->first[i + 1] <= t0)
        i++;
    gs_rng rng;
    dart_rng(c, t0, &rng);
    for (size_t k = lo; k < hi; k++) {
        while (c->first[i + 1] <= c->base + k)
            i++;
        const prim *pr = &c->prims[i];
        dart *d = &out[k - lo];
        d->keep = 0;
        double u = gs_rng_uniform(&rng), v = gs_rng_uniform(&rng), acc = gs_rng_uniform(&rng);
        double tu[3], tv[3], ref[3], n[3], *p = d->p;
        prim_pos(pr, u, v, tu, tv, p, ref);
        if (p[0] < c->lo[0] || p[0] > c->hi[0] || p[1] < c->lo[1] || p[1] > c->hi[1])
            continue;
        int inside = 0;
        if (prim_bounded(pr))
            for (int q = c->nb_start[i]; q < c->nb_start[i + 1] && !inside; q++)
                inside = prim_inside(&c->prims[c->nb[q]], p);
        else
            for (int j = 0; j < c->np && !inside; j++)
                inside = j != i && prim_inside(&c->prims[j], p);
        if (inside)
            continue;
        double dA = prim_normal(pr, u, v, tu, tv, p, ref, n);
        d->keep = !(acc * c->max_dA[i] > dA);
    }
    return GS_OK;
}

/* The sample of try t on primitive i (a dart that throw_darts kept): its
 * point and normal computed again, the same values (a fortieth of the tries
 * become samples, so the exchange carries no normals). */
static void dart_sample(const dart_ctx *c, uint64_t t, int i, gs_opoint *q)
{
    gs_rng rng;
    dart_rng(c, t, &rng);
    double u = gs_rng_uniform(&rng), v = gs_rng_uniform(&rng);
    double tu[3], tv[3], ref[3];
    prim_pos(&c->prims[i], u, v, tu, tv, q->p, ref);
    prim_normal(&c->prims[i], u, v, tu, tv, q->p, ref, q->n);
}

/* Tries per map of the dart throwing (bounds its buffer: 32 bytes each). */
#define DART_CHUNK ((uint64_t)1 << 16)

/* Dart throwing over the union of prims, then the texture's box. pre: a
 * failure of the caller's set-up, returned (by every process) from the
 * first agreement. With gp->map and gp->agree collective, every process
 * makes the same calls to them whatever fails, and a failure before the
 * end is returned by all. */
static gs_err sample_prims(const gs_points_gen_params *gp, gs_err pre, const prim *prims, int np,
                           uint32_t kind, gs_points_texture *out)
{
    memset(out, 0, sizeof *out);
    gs_err err = pre;
    double s = gp->spacing;
    gs_points_grid_t grid = NULL;
    int *nb_start = NULL, *nb = NULL;
    double *scan = NULL;
    uint64_t *first = NULL;
    dart *darts = NULL;
    if (err == GS_OK && !(gp->size[0] > 0 && gp->size[1] > 0 && gp->spacing > 0 && gp->pad >= 0))
        err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                             "point generator: size %g x %g, spacing %g, pad %g: expected positive "
                             "sizes and spacing, pad >= 0", gp->size[0], gp->size[1], gp->spacing,
                             gp->pad);
    double lo[3] = {-gp->pad - s, -gp->pad - s, -1e300}, hi[3] = {gp->size[0] + gp->pad + s,
                                                                 gp->size[1] + gp->pad + s, 1e300};
    if (err == GS_OK) {
        /* z bounds from a coarse scan of every primitive. */
        double zmin = INFINITY, zmax = -INFINITY;
        for (int i = 0; i < np; i++)
            for (int a = 0; a <= 16; a++)
                for (int b = 0; b <= 16; b++) {
                    double p[3], r[3], tu[3], tv[3];
                    prim_pos(&prims[i], a / 16.0, b / 16.0, tu, tv, p, r);
                    zmin = fmin(zmin, p[2]);
                    zmax = fmax(zmax, p[2]);
                }
        if (!(np > 0 && zmax >= zmin))
            err = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                 "point generator: no geometry");
        lo[2] = zmin - 2 * s;
        hi[2] = zmax + 2 * s;
    }
    if (err == GS_OK)
        err = gs_points_grid_create(lo, hi, s, &grid);
    if (err == GS_OK)
        err = prim_neighbours(prims, np, &nb_start, &nb);
    if (err == GS_OK)
        err = gs_alloc_array((void **)&scan, (size_t)np, 3 * sizeof *scan, "primitive areas");
    if (err == GS_OK)
        err = gs_alloc_array((void **)&first, (size_t)np + 1, sizeof *first, "primitive tries");
    GS_TRY(err, gen_agree(gp, err), done);
    dart_ctx dc = {prims, np, nb_start, nb, scan + 2 * np, first, 0, {lo[0] + s, lo[1] + s},
                   {hi[0] - s, hi[1] - s}, gp->seed, gs_rng_stream_id(0x50544753u, kind, 0, 0)};
    GS_TRY(err, gen_map(gp, (size_t)np, 2 * sizeof *scan, prim_scan, &dc, scan), done);
    first[0] = 0;
    for (int i = 0; i < np; i++) {
        double want = 6.0 * scan[2 * i] / (s * s);
        uint64_t tries = (uint64_t)(want * 1.25 * 1.25) + 16; /* x acceptance of the rejection */
        scan[2 * np + i] = scan[2 * i + 1] * 1.25;
        first[i + 1] = first[i] + tries;
    }
    uint64_t total = first[np];
    size_t chunk = total < DART_CHUNK ? (size_t)total : (size_t)DART_CHUNK;
    err = gs_alloc_array((void **)&darts, chunk ? chunk : 1, sizeof *darts, "dart throwing");
    GS_TRY(err, gen_agree(gp, err), done);
    int pi = 0; /* the primitive of try at + k */
    for (uint64_t at = 0; at < total; at += chunk) {
        size_t m = total - at < chunk ? (size_t)(total - at) : chunk;
        dc.base = at;
        GS_TRY(err, gen_map(gp, m, sizeof *darts, throw_darts, &dc, darts), done);
        for (size_t k = 0; k < m && err == GS_OK; k++) {
            while (first[pi + 1] <= at + k)
                pi++;
            if (darts[k].keep && !gs_points_grid_any_within(grid, darts[k].p, s)) {
                gs_opoint q;
                dart_sample(&dc, at + k, pi, &q);
                err = gs_points_grid_add(grid, &q);
            }
        }
        GS_TRY(err, gen_agree(gp, err), done);
    }
    GS_TRY(err, gs_points_grid_collect(grid, &out->pts), done);
    out->box_lo[0] = 0;
    out->box_lo[1] = 0;
    out->box_hi[0] = gp->size[0];
    out->box_hi[1] = gp->size[1];
    out->box_lo[2] = INFINITY;
    out->box_hi[2] = -INFINITY;
    for (size_t i = 0; i < out->pts.n; i++) {
        out->box_lo[2] = fmin(out->box_lo[2], out->pts.v[i].p[2]);
        out->box_hi[2] = fmax(out->box_hi[2], out->pts.v[i].p[2]);
    }
    out->box_lo[2] -= 0.5 * s;
    out->box_hi[2] += 0.5 * s;
    out->spacing = s;
done:
    if (err != GS_OK)
        gs_points_free(&out->pts);
    gs_points_grid_destroy(&grid);
    gs_free(nb_start);
    gs_free(nb);
    gs_free(scan);
    gs_free(first);
    gs_free(darts);
    return err;
}

static void prim_identity(prim *p)
{
    memset(p, 0, sizeof *p);
    rot_zy(0, 0, p->R);
}

static gs_err heightfield_check(int w, int h, const uint8_t *u8, const float *f32,
                                double height_scale)
{
    GS_CHECK(w >= 2 && h >= 2 && w <= 65536 && h <= 65536, GS_ERR_ARG,
             "height field image: %d x %d pixels, expected 2..65536 on each side", w, h);
    GS_CHECK((u8 != NULL) != (f32 != NULL), GS_ERR_ARG,
             "height field image: give exactly one of the uint8 and float arrays");
    GS_CHECK(isfinite(height_scale), GS_ERR_ARG, "height field: scale %g is not finite",
             height_scale);
    if (f32)
        for (size_t i = 0; i < (size_t)w * h; i++)
            GS_CHECK(isfinite(f32[i]), GS_ERR_ARG,
                     "height field image: pixel (%zu, %zu) is not finite", i % (size_t)w,
                     i / (size_t)w);
    return GS_OK;
}

gs_err gs_points_gen_heightfield(const gs_points_gen_params *gp, int w, int h,
                                 const uint8_t *u8, const float *f32, double height_scale,
                                 gs_points_texture *out)
{
    gs_err err = heightfield_check(w, h, u8, f32, height_scale);
    hf_image im = {w, h, u8, f32, height_scale};
    prim pr;
    prim_identity(&pr);
    pr.kind = PRIM_HEIGHT;
    pr.img = &im;
    pr.lo[0] = -gp->pad;
    pr.lo[1] = -gp->pad;
    pr.hi[0] = gp->size[0] + gp->pad;
    pr.hi[1] = gp->size[1] + gp->pad;
    GS_CALL(sample_prims(gp, err, &pr, 1, 1, out));
    return GS_OK;
}

/* sample_prims of the primitives build makes (its failure goes to every
 * process through sample_prims), then frees them. */
typedef gs_err (*prims_fn)(const gs_points_gen_params *gp, int cells, prim **out, int *nout);
static gs_err sample_built(const gs_points_gen_params *gp, int cells, prims_fn build,
                           uint32_t kind, gs_points_texture *out)
{
    prim *prims = NULL;
    int np = 0;
    gs_err err = build(gp, cells, &prims, &np);
    err = sample_prims(gp, err, prims, np, kind, out);
    gs_free(prims);
    return err;
}

/* Lattice sites (i, j) covering [-pad - a, size + pad + a]. */
static void lattice_range(const gs_points_gen_params *gp, double a, int axis, int *i0, int *i1)
{
    *i0 = (int)floor((-gp->pad - a) / a);
    *i1 = (int)ceil((gp->size[axis] + gp->pad + a) / a);
}

static gs_err chainmail_prims(const gs_points_gen_params *gp, int cells, prim **out, int *nout)
{
    GS_CHECK(cells >= 1 && cells <= 64, GS_ERR_ARG, "chain mail: %d cells, expected 1..64", cells);
    GS_CHECK(gp->size[0] > 0 && gp->spacing > 0, GS_ERR_ARG, "chain mail: bad size or spacing");
    double a = gp->size[0] / cells;
    int i0, i1, j0, j1;
    lattice_range(gp, a, 0, &i0, &i1);
    double ay = 0.6 * a; /* rows overlap so rings interlock */
    lattice_range(gp, ay, 1, &j0, &j1);
    size_t n = (size_t)(i1 - i0 + 1) * (size_t)(j1 - j0 + 1);
    GS_CHECK(n < 100000, GS_ERR_ARG, "chain mail: %zu rings, expected < 100000", n);
    prim *prims = NULL;
    GS_CALL(gs_alloc_array((void **)&prims, n, sizeof *prims, "chain mail rings"));
    int np = 0;
    gs_rng rng;
    gs_rng_init(&rng, gp->seed, gs_rng_stream_id(0x50544753u, 2, 1, 0));
    /* Not periodic: each ring off its site by up to 6% of the lattice
     * step, turned by up to 0.1 rad, its lean, major and tube radii varied
     * by up to 0.08 rad, 8% and 12% (the rings still interlock; where two
     * touch, dart throwing drops the samples inside the other). */
    double jit = gp->periodic ? 0 : 1;
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            prim *pr = &prims[np++];
            prim_identity(pr);
            double u[6];
            for (int k = 0; k < 6; k++)
                u[k] = jit * (2 * gs_rng_uniform(&rng) - 1);
            pr->kind = PRIM_TORUS;
            pr->c[0] = i * a + ((j & 1) ? 0.5 * a : 0) + 0.06 * a * u[0];
            pr->c[1] = j * ay + 0.06 * a * u[1];
            pr->c[2] = 0;
            pr->a = 0.36 * a * (1 + 0.08 * u[2]);
            pr->b = 0.075 * a * (1 + 0.12 * u[3]);
            pr->e = 0.03 * a;
            pr->bound_r = pr->a + pr->b + pr->e;
            rot_zy(0.1 * u[4], (((i + j) & 1) ? 0.45 : -0.45) + 0.08 * u[5], pr->R);
        }
    *out = prims;
    *nout = np;
    return GS_OK;
}

gs_err gs_points_gen_chainmail(const gs_points_gen_params *gp, int cells, gs_points_texture *out)
{
    return sample_built(gp, cells, chainmail_prims, 2, out);
}

static gs_err weave_prims(const gs_points_gen_params *gp, int cells, prim **out, int *nout)
{
    GS_CHECK(cells >= 1 && cells <= 64, GS_ERR_ARG, "weave: %d cells, expected 1..64", cells);
    GS_CHECK(gp->size[0] > 0 && gp->spacing > 0, GS_ERR_ARG, "weave: bad size or spacing");
    double a = gp->size[0] / cells;
    int i0, i1, j0, j1;
    lattice_range(gp, a, 0, &i0, &i1);
    lattice_range(gp, a, 1, &j0, &j1);
    int n = (i1 - i0 + 1) + (j1 - j0 + 1);
    prim *prims = NULL;
    GS_CALL(gs_alloc_array((void **)&prims, (size_t)n, sizeof *prims, "weave threads"));
    int np = 0;
    double r = 0.2 * a, amp = 1.3 * r;
    gs_rng rng;
    gs_rng_init(&rng, gp->seed, gs_rng_stream_id(0x50544753u, 3, 1, 0));
    /* Not periodic: each thread off its lattice line by up to 8% of the
     * step, its radius varied by up to 10% (the over/under clearance at a
     * crossing stays above the sum of the two radii). */
    double jit = gp->periodic ? 0 : 1;
    for (int j = j0; j <= j1; j++) { /* threads along x at y = j a */
        prim *pr = &prims[np++];
        prim_identity(pr);
        double u0 = jit * (2 * gs_rng_uniform(&rng) - 1), u1 = jit * (2 * gs_rng_uniform(&rng) - 1);
        pr->kind = PRIM_TUBE_X;
        pr->c[1] = j * a + 0.08 * a * u0;
        pr->a = r * (1 + 0.1 * u1);
        pr->b = amp;
        pr->e = a;
        pr->phase = GS_PI * j;
        pr->lo[0] = -gp->pad - 2 * r;
        pr->hi[0] = gp->size[0] + gp->pad + 2 * r;
    }
    for (int i = i0; i <= i1; i++) { /* threads along y at x = i a, opposite phase */
        prim *pr = &prims[np++];
        prim_identity(pr);
        double u0 = jit * (2 * gs_rng_uniform(&rng) - 1), u1 = jit * (2 * gs_rng_uniform(&rng) - 1);
        pr->kind = PRIM_TUBE_Y;
        pr->c[0] = i * a + 0.08 * a * u0;
        pr->a = r * (1 + 0.1 * u1);
        pr->b = -amp;
        pr->e = a;
        pr->phase = GS_PI * i;
        pr->lo[0] = -gp->pad - 2 * r;
        pr->hi[0] = gp->size[1] + gp->pad + 2 * r;
    }
    *out = prims;
    *nout = np;
    return GS_OK;
}

gs_err gs_points_gen_weave(const gs_points_gen_params *gp, int cells, gs_points_texture *out)
{
    return sample_built(gp, cells, weave_prims, 3, out);
}

static gs_err flowers_prims(const gs_points_gen_params *gp, int cells, prim **out, int *nout)
{
    GS_CHECK(cells >= 1 && cells <= 64, GS_ERR_ARG, "flowers: %d cells, expected 1..64", cells);
    GS_CHECK(gp->size[0] > 0 && gp->size[1] > 0 && gp->spacing > 0, GS_ERR_ARG,
             "flowers: bad size or spacing");
    double dmin = gp->size[0] / cells;
    double ext[2] = {gp->size[0] + 2 * gp->pad, gp->size[1] + 2 * gp->pad};
    size_t max_fl = (size_t)(2.0 * ext[0] * ext[1] / (dmin * dmin)) + 8;
    GS_CHECK(max_fl < 20000, GS_ERR_ARG, "flowers: %zu flowers, expected < 20000", max_fl);
    double *centers = NULL;
    prim *prims = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&centers, max_fl, 3 * sizeof *centers, "flower centers"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&prims, max_fl * 8, sizeof *prims, "flower parts"), done);
    gs_rng rng;
    gs_rng_init(&rng, gp->seed, gs_rng_stream_id(0x50544753u, 4, 1, 0));
    size_t nf = 0;
    for (size_t t = 0; t < 40 * max_fl && nf < max_fl; t++) {
        double c[3] = {-gp->pad + ext[0] * gs_rng_uniform(&rng),
                       -gp->pad + ext[1] * gs_rng_uniform(&rng), 0.08 * dmin * gs_rng_normal(&rng)};
        int ok = 1;
        for (size_t k = 0; k < nf && ok; k++) {
            double dx = c[0] - centers[3 * k], dy = c[1] - centers[3 * k + 1];
            ok = dx * dx + dy * dy >= dmin * dmin;
        }
        if (ok)
            memcpy(centers + 3 * nf++, c, sizeof c);
    }
    int np = 0;
    for (size_t f = 0; f < nf; f++) {
        const double *c = centers + 3 * f;
        prim *ball = &prims[np++];
        prim_identity(ball);
        ball->kind = PRIM_ELLIPSOID;
        memcpy(ball->c, c, sizeof ball->c);
        ball->a = ball->b = ball->e = 0.11 * dmin;
        ball->bound_r = ball->a;
        int petals = 5 + (int)gs_rng_below(&rng, 3);
        double a0 = 2 * GS_PI * gs_rng_uniform(&rng);
        for (int k = 0; k < petals; k++) {
            double al = a0 + 2 * GS_PI * k / petals;
            prim *pe = &prims[np++];
            prim_identity(pe);
            pe->kind = PRIM_ELLIPSOID;
            pe->c[0] = c[0] + 0.24 * dmin * cos(al);
            pe->c[1] = c[1] + 0.24 * dmin * sin(al);
            pe->c[2] = c[2] + 0.05 * dmin;
            pe->a = 0.19 * dmin;
            pe->b = 0.09 * dmin;
            pe->e = 0.04 * dmin;
            pe->bound_r = pe->a;
            rot_zy(al, -0.35, pe->R);
        }
    }
    *out = prims;
    *nout = np;
    prims = NULL;
done:
    gs_free(centers);
    gs_free(prims);
    return err;
}

gs_err gs_points_gen_flowers(const gs_points_gen_params *gp, int cells, gs_points_texture *out)
{
    return sample_built(gp, cells, flowers_prims, 4, out);
}

void gs_points_texture_free(gs_points_texture *t)
{
    gs_points_free(&t->pts);
}

gs_err gs_points_texture_check(const gs_points_texture *t, double need)
{
    const double *lo = t->box_lo, *hi = t->box_hi;
    GS_CHECK(hi[0] > lo[0] && hi[1] > lo[1] && hi[2] >= lo[2], GS_ERR_ARG,
             "input texture: box [%g, %g] x [%g, %g] x [%g, %g] is empty", lo[0], hi[0], lo[1],
             hi[1], lo[2], hi[2]);
    GS_CHECK(t->spacing > 0, GS_ERR_ARG, "input texture: spacing %g must be > 0", t->spacing);
    size_t inside = 0;
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *p = t->pts.v[i].p;
        inside += p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1];
    }
    GS_CHECK(inside >= 16, GS_ERR_ARG, "input texture: only %zu points inside the box", inside);
    double density = inside / ((hi[0] - lo[0]) * (hi[1] - lo[1]));
    static const char *names[4] = {"-x", "+x", "-y", "+y"};
    for (int side = 0; side < 4; side++) {
        int ax = side / 2, other = 1 - ax, up = side & 1;
        double edge = up ? hi[ax] : lo[ax];
        size_t strip = 0, outer = 0;
        double reach = 0;
        for (size_t i = 0; i < t->pts.n; i++) {
            const double *p = t->pts.v[i].p;
            if (p[other] < lo[other] || p[other] >= hi[other])
                continue;
            double beyond = up ? p[ax] - edge : edge - p[ax];
            if (beyond < 0)
                continue;
            reach = fmax(reach, beyond);
            if (beyond < need) {
                strip++;
                outer += beyond >= 0.5 * need;
            }
        }
        double area = need * (hi[other] - lo[other]);
        double ds = strip / area, dout = outer / (0.5 * area);
        GS_CHECK(ds >= 0.25 * density && dout >= 0.25 * density, GS_ERR_ARG,
                 "input texture: geometry on side %s reaches %g past the bounding box with %.0f%% "
                 "of the box's density in [0, %g] (%.0f%% in the outer half); the method needs "
                 "geometry to continue at least %g beyond every side of the box (paper section 3): "
                 "pad the example or shrink the box", names[side], reach, 100 * ds / density, need,
                 100 * dout / density, need);
    }
    return GS_OK;
}
