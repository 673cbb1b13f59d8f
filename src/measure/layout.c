/* Layout of separate objects (see include/geosynth/measure.h,
 * gs_measure_object_layout): components of a mask, their centres, the
 * nearest-neighbour distances of the centres, crowded and fused objects of
 * an output against its example. analysis/field_layout.py is the same in
 * Python. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

typedef struct layout_objects {
    int64_t n;       /* components */
    double *c;       /* 3 per component: mean x, y, z of its samples */
    double *size;    /* samples */
    double *radius;  /* largest distance of a sample from the centre */
    uint8_t *inner;  /* 1: touches no face of the grid (axes of one sample have none) */
} layout_objects;

static void objects_free(layout_objects *o)
{
    gs_free(o->c);
    gs_free(o->size);
    gs_free(o->radius);
    gs_free(o->inner);
    memset(o, 0, sizeof *o);
}

/* Over the labelled samples: pass 0 sums each object's sample positions
 * into its centre and clears inner where it touches a face; pass 1 (the
 * centres divided) keeps its largest distance from the centre. */
static void objects_pass(const uint32_t *label, const int64_t n[3], int pass, layout_objects *o)
{
    for (int64_t z = 0, i = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++)
            for (int64_t x = 0; x < n[0]; x++, i++) {
                uint32_t l = label[i];
                if (!l)
                    continue;
                double *c = o->c + 3 * (l - 1);
                int64_t p[3] = {x, y, z};
                if (pass) {
                    double dx = (double)x - c[0], dy = (double)y - c[1], dz = (double)z - c[2];
                    double r = sqrt(dx * dx + dy * dy + dz * dz);
                    if (r > o->radius[l - 1])
                        o->radius[l - 1] = r;
                    continue;
                }
                for (int a = 0; a < 3; a++) {
                    c[a] += (double)p[a];
                    if (n[a] > 1 && (p[a] == 0 || p[a] == n[a] - 1))
                        o->inner[l - 1] = 0;
                }
            }
}

static gs_err objects_alloc(layout_objects *o, int64_t n)
{
    memset(o, 0, sizeof *o);
    o->n = n;
    size_t m = (size_t)n + 1;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&o->c, m, 3 * sizeof *o->c, "object centres"), done);
    GS_TRY(err, gs_alloc_array((void **)&o->size, m, sizeof *o->size, "object sizes"), done);
    GS_TRY(err, gs_alloc_array((void **)&o->inner, m, 1, "object faces"), done);
    GS_TRY(err, gs_alloc_array((void **)&o->radius, m, sizeof *o->radius, "object radii"), done);
    memset(o->radius, 0, m * sizeof *o->radius);
    memset(o->c, 0, m * 3 * sizeof *o->c);
    memset(o->inner, 1, m);
done:
    if (err != GS_OK)
        objects_free(o);
    return err;
}

/* The objects of a mask, labelled alone (gs_measure_object_layout). */
static gs_err objects_of(const uint8_t *mask, const int64_t n[3], layout_objects *o)
{
    memset(o, 0, sizeof *o);
    int64_t cells = n[0] * n[1] * n[2];
    uint32_t *label = NULL, nc = 0;
    uint64_t *sz = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&label, (size_t)cells, sizeof *label, "object labels"), done);
    GS_TRY(err, gs_measure_components3(mask, (int)n[0], (int)n[1], (int)n[2], NULL, label, &nc,
                                       &sz), done);
    GS_TRY(err, objects_alloc(o, nc), done);
    objects_pass(label, n, 0, o);
    for (uint32_t l = 0; l < nc; l++) {
        o->size[l] = (double)sz[l + 1];
        for (int a = 0; a < 3; a++)
            o->c[3 * l + a] /= o->size[l];
    }
    objects_pass(label, n, 1, o);
done:
    gs_free(label);
    gs_free(sz);
    if (err != GS_OK)
        objects_free(o);
    return err;
}

/* The same objects from components labelled elsewhere (c[1 .. nc], their
 * sizes, coordinate sums, faces and radii: gs_measure_components_nested3's
 * inner set): the same sums in the same order, so the same figures. */
static gs_err objects_from(const gs_measure_component *c, uint32_t nc, const int64_t n[3],
                           layout_objects *o)
{
    GS_CALL(objects_alloc(o, nc));
    uint8_t faces = 0; /* the faces of the axes longer than one sample */
    for (int a = 0; a < 3; a++)
        if (n[a] > 1)
            faces |= (uint8_t)(3u << (2 * a));
    for (uint32_t l = 0; l < nc; l++) {
        const gs_measure_component *k = &c[l + 1];
        o->size[l] = (double)k->size;
        o->inner[l] = !(k->faces & faces);
        o->radius[l] = k->radius;
        for (int a = 0; a < 3; a++)
            o->c[3 * l + a] = k->sum[a] / o->size[l];
    }
    return GS_OK;
}

typedef struct by_x {
    double x;
    int64_t i;
} by_x;

static int cmp_by_x(const void *a, const void *b)
{
    const by_x *p = a, *q = b;
    return p->x < q->x ? -1 : p->x > q->x ? 1 : (p->i > q->i) - (p->i < q->i);
}

/* Per inner object, the distance of its centre to the nearest other
 * object's centre (any object, inner or not), sorted ascending into *nn
 * (*k values; none when there is no other object). A sweep along x: cost
 * O(n log n) plus the pairs nearer in x than the best so far. */
static gs_err nearest(const layout_objects *o, const uint8_t *measured, double **nn, int64_t *k)
{
    by_x *s = NULL;
    double *d = NULL;
    *nn = NULL, *k = 0;
    gs_err err = GS_OK;
    size_t m = (size_t)(o->n ? o->n : 1);
    GS_TRY(err, gs_alloc_array((void **)&s, m, sizeof *s, "objects by x"), done);
    GS_TRY(err, gs_alloc_array((void **)&d, m, sizeof *d, "nearest distances"), done);
    for (int64_t i = 0; i < o->n; i++)
        s[i].x = o->c[3 * i], s[i].i = i;
    qsort(s, (size_t)o->n, sizeof *s, cmp_by_x);
    for (int64_t r = 0; r < o->n && o->n > 1; r++) {
        int64_t i = s[r].i;
        if (!measured[i])
            continue;
        const double *ci = o->c + 3 * i;
        double best = INFINITY;
        for (int dir = -1; dir <= 1; dir += 2)
            for (int64_t t = r + dir; t >= 0 && t < o->n; t += dir) {
                double dx = s[t].x - ci[0];
                if (dx * dx >= best)
                    break;
                const double *cj = o->c + 3 * s[t].i;
                double dy = cj[1] - ci[1], dz = cj[2] - ci[2], q = dx * dx + dy * dy + dz * dz;
                if (q < best)
                    best = q;
            }
        d[(*k)++] = sqrt(best);
    }
    gs_sort_f64(d, (size_t)*k);
    *nn = d;
    d = NULL;
done:
    gs_free(s);
    gs_free(d);
    return err;
}

static double quantile(const double *s, int64_t n, double p)
{
    return n ? s[(int64_t)(p * (double)(n - 1) + 0.5)] : 0;
}

static void side_figures(const layout_objects *o, const uint8_t *measured, const double *nn,
                         int64_t k, double nn_min, double big, double fused, double small,
                         double reach, gs_measure_objlayout_side *f)
{
    f->objects = 0;
    int64_t over = 0, close = 0, frag = 0, merged = 0;
    for (int64_t i = 0; i < o->n; i++)
        if (measured[i])
            f->objects++, over += o->size[i] > fused * big, frag += o->size[i] < small,
                merged += o->radius[i] > reach;
    for (int64_t i = 0; i < k; i++)
        close += nn[i] < nn_min;
    f->nn_p10 = quantile(nn, k, 0.1);
    f->nn_p50 = quantile(nn, k, 0.5);
    f->close_share = k ? (double)close / (double)k : 0;
    f->fused_share = f->objects ? (double)over / (double)f->objects : 0;
    f->fragment_share = f->objects ? (double)frag / (double)f->objects : 0;
    f->merged_share = f->objects ? (double)merged / (double)f->objects : 0;
}

/* The figures of the objects oo of an output of on samples and os of its
 * example. */
static gs_err layout_figures(const layout_objects *oo, const layout_objects *os,
                             const int64_t on[3], double fused, gs_measure_objlayout *r)
{
    double *no = NULL, *ns = NULL, *ng = NULL;
    uint8_t *guarded = NULL;
    int64_t ko = 0, ks = 0, kg = 0;
    gs_err err = GS_OK;
    GS_TRY(err, nearest(oo, oo->inner, &no, &ko), done);
    GS_TRY(err, nearest(os, os->inner, &ns, &ks), done);
    double big = 0, rmax = 0, least = INFINITY;
    for (int64_t i = 0; i < os->n; i++)
        if (os->inner[i]) {
            big = os->size[i] > big ? os->size[i] : big;
            least = os->size[i] < least ? os->size[i] : least;
            rmax = os->radius[i] > rmax ? os->radius[i] : rmax;
        }
    double nn_min = ks ? ns[0] : 0;
    /* fragments: smaller than 3/4 of the example's smallest whole object
     * (analysis/field_discs.py's cut ratio; embark-5's discs 83-90 samples) */
    double small = isfinite(least) ? 0.75 * least : 0;
    /* merged: reaching farther from its centre than half a sample beyond
     * the example's largest object radius (two objects glued, or one with a
     * piece of another; texture.ini's discs 5.07-5.33, a disc grown by a
     * piece of another at a seam 5.9-6.7) */
    double reach = rmax + 0.5;
    side_figures(oo, oo->inner, no, ko, nn_min, big, fused, small, reach, &r->out);
    side_figures(os, os->inner, ns, ks, nn_min, big, fused, small, reach, &r->src);
    GS_TRY(err, gs_measure_ks(no, (size_t)ko, ns, (size_t)ks, &r->nn_ks), done);
    /* guarded: the output's objects whose centre lies at least the example's
     * largest nn plus its largest object radius from every face */
    r->guard = (ks ? ns[ks - 1] : 0) + rmax;
    GS_TRY(err, gs_alloc_array((void **)&guarded, (size_t)(oo->n ? oo->n : 1), 1, "guarded objects"),
           done);
    for (int64_t i = 0; i < oo->n; i++) {
        guarded[i] = oo->inner[i];
        for (int a = 0; a < 3 && guarded[i]; a++)
            guarded[i] = on[a] == 1 || (oo->c[3 * i + a] >= r->guard &&
                                        (double)(on[a] - 1) - oo->c[3 * i + a] >= r->guard);
    }
    GS_TRY(err, nearest(oo, guarded, &ng, &kg), done);
    side_figures(oo, guarded, ng, kg, nn_min, big, fused, small, reach, &r->out_guarded);
    GS_TRY(err, gs_measure_ks(ng, (size_t)kg, ns, (size_t)ks, &r->nn_ks_guarded), done);
done:
    gs_free(no);
    gs_free(ns);
    gs_free(ng);
    gs_free(guarded);
    return err;
}

gs_err gs_measure_object_layout(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                                const int64_t sn[3], double fused, gs_measure_objlayout *r)
{
    memset(r, 0, sizeof *r);
    layout_objects oo, os;
    gs_err err = GS_OK;
    memset(&os, 0, sizeof os);
    GS_CALL(objects_of(out, on, &oo));
    GS_TRY(err, objects_of(src, sn, &os), done);
    err = layout_figures(&oo, &os, on, fused, r);
done:
    objects_free(&oo);
    objects_free(&os);
    return err;
}

gs_err gs_measure_object_layout_components(const gs_measure_component *out, uint32_t nout,
                                           const int64_t on[3], const gs_measure_component *src,
                                           uint32_t nsrc, const int64_t sn[3], double fused,
                                           gs_measure_objlayout *r)
{
    memset(r, 0, sizeof *r);
    layout_objects oo, os;
    gs_err err = GS_OK;
    memset(&os, 0, sizeof os);
    GS_CALL(objects_from(out, nout, on, &oo));
    GS_TRY(err, objects_from(src, nsrc, sn, &os), done);
    err = layout_figures(&oo, &os, on, fused, r);
done:
    objects_free(&oo);
    objects_free(&os);
    return err;
}
