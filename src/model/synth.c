/* Region plans (overlapping sweeps with colours) and the serial driver.
 * See include/geosynth/model.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/rng.h"
#include "model/model_impl.h"

void gs_model_params_default(gs_model_params *p)
{
    memset(p, 0, sizeof *p);
    p->seed = 1;
    p->overlap = -1;
    p->attempts = 20;
    p->min_changes = 1;
    p->max_passes = 4;
    p->fix_z_faces = 1;
    p->backtracks = 1000;
    p->order = GS_MODEL_ORDER_ENTROPY;
    p->weights = GS_MODEL_WEIGHTS_UNIFORM;
    p->ac = GS_MODEL_AC3;
    p->split_depth = 2;
}

static gs_err check_params(const gs_model_params *p)
{
    for (int a = 0; a < 3; a++)
        GS_CHECK(p->region[a] >= 0, GS_ERR_ARG,
                 "model.region[%d] = %d: expected 0 (whole axis) or a positive edge", a,
                 p->region[a]);
    GS_CHECK(p->overlap >= -1, GS_ERR_ARG,
             "model.overlap = %d: expected -1 (half the region) or >= 0", p->overlap);
    GS_CHECK(p->attempts >= 1 && p->attempts <= 100000, GS_ERR_ARG,
             "model.attempts = %d: expected an integer in [1, 100000]", p->attempts);
    GS_CHECK(p->backtracks >= 0, GS_ERR_ARG, "model.backtracks = %d: expected >= 0", p->backtracks);
    GS_CHECK(p->min_changes >= 0 && p->min_changes <= 1000, GS_ERR_ARG,
             "model.min_changes = %d: expected an integer in [0, 1000]", p->min_changes);
    GS_CHECK(p->max_passes >= 1 && p->max_passes <= 100000, GS_ERR_ARG,
             "model.max_passes = %d: expected an integer in [1, 100000]", p->max_passes);
    GS_CHECK(p->order == GS_MODEL_ORDER_SCAN || p->order == GS_MODEL_ORDER_RANDOM ||
                 p->order == GS_MODEL_ORDER_ENTROPY || p->order == GS_MODEL_ORDER_ENTROPY_LOG ||
                 p->order == GS_MODEL_ORDER_ENTROPY_LAYERS ||
                 p->order == GS_MODEL_ORDER_ENTROPY_COLUMNS,
             GS_ERR_ARG, "model.order = %d: expected scan, random or entropy", (int)p->order);
    GS_CHECK(p->weights == GS_MODEL_WEIGHTS_UNIFORM || p->weights == GS_MODEL_WEIGHTS_FREQUENCY,
             GS_ERR_ARG, "model.weights = %d: expected uniform or frequency", (int)p->weights);
    GS_CHECK(p->ac == GS_MODEL_AC3 || p->ac == GS_MODEL_AC4, GS_ERR_ARG,
             "model.ac = %d: expected 3 or 4", (int)p->ac);
    GS_CHECK(!p->periodic[2] || !p->fix_z_faces, GS_ERR_ARG,
             "model.periodic along z needs model.fix_z_faces = false (fixed ground and sky "
             "layers cannot wrap)");
    return GS_OK;
}

/* Active z range: everything, or without the bottom and top layers. */
static void active_z(const gs_model_params *p, int nz, int *lo, int *hi)
{
    int fix = p->fix_z_faces && nz >= 3;
    *lo = fix ? 1 : 0;
    *hi = fix ? nz - 1 : nz;
}

/* How far outside its box a region reads: the face neighbours (1) and,
 * with resemblance, every cell of the (2w+1)^3 window of a box cell
 * (w along every axis at once: edges and corners too). */
static int resem_reach(const gs_model_params *p)
{
    return p->resem ? p->resem->w : 0;
}

/* Region starts along one axis of extent n with edge b (<= n). Stride
 * b - overlap (b/2 when overlap < 0), at least 1; odd passes shift the grid by a quarter region. Returns the count; colours
 * along the axis in *m (regions k and k+m are >= gap cells apart, so one
 * reads nothing the other writes). */
static int axis_starts(int n, int b, int overlap, int pass, int periodic, int gap, int *starts,
                       int *m)
{
    int k = 0;
    if (b >= n) {
        starts[k++] = 0;
    } else {
        int s = overlap < 0 ? b / 2 : b - overlap;
        if (s < 1)
            s = 1;
        int o = (pass & 1) ? s / 2 : 0;
        for (int t = -o;; t += s) {
            int st = t < 0 ? 0 : (t > n - b ? n - b : t);
            if (k == 0 || st != starts[k - 1])
                starts[k++] = st;
            if (st == n - b)
                break;
        }
    }
    int mm = 1;
    for (;;) {
        int good = 1;
        for (int i = 0; i + mm < k; i++)
            if (starts[i + mm] < starts[i] + b + gap)
                good = 0;
        /* periodic axis: the last region of a colour must also keep a gap
         * to the first one across the wrap */
        for (int c = 0; periodic && b < n && c < mm && c < k; c++) {
            int last = c + ((k - 1 - c) / mm) * mm;
            if (last != c && starts[c] + n < starts[last] + b + gap)
                good = 0;
        }
        if (good)
            break;
        mm++;
    }
    *m = mm;
    return k;
}

/* model.region_jitter (issue #18, the region grid): cuts of an axis of
 * extent n into pieces of b - J .. b + J cells drawn from r, the last piece
 * taking what is left (a remainder too short for a piece of its own is
 * shared with the one before). cut[0] = 0, piece k = [cut[k], cut[k + 1]).
 * Returns the count. */
static int jitter_cuts(int n, int b, int J, gs_rng *r, int *cut)
{
    int k = 0, pos = 0;
    cut[0] = 0;
    while (pos < n) {
        const int rem = n - pos;
        int w = b - J + (int)gs_rng_below(r, (uint64_t)(2 * J + 1));
        if (rem <= b + J && (rem <= w || rem - w < b - J))
            w = rem;
        else if (rem - w < b - J)
            w = rem / 2;
        pos += w;
        cut[++k] = pos;
    }
    return k;
}

/* Colours along a cut axis: the smallest m such that pieces k and k + m are
 * >= gap cells apart. */
static int cut_colors(const int *cut, int k, int gap)
{
    int m = 1;
    for (int i = 0; i + m < k; i++)
        if (cut[i + m] < cut[i + 1] + gap) {
            m++;
            i = -1;
        }
    return m;
}

#define GS_MODEL_PLAN_DOMAIN 0x4d4f504cu /* "MOPL": jittered region edges */

/* The jittered plan (model.region_jitter = J > 0, overlap 0, x and y not
 * periodic), drawn from streams keyed by (seed, pass): the same plan on every
 * rank; z as the regular plan. Rows of regions along y; row 0's x cuts are
 * pieces of edge +- J; every second one of them is an anchor, kept by row 1,
 * which splits each span between anchors (and the faces) into about edge-wide
 * pieces at jittered places: those new cuts are row 1's anchors, kept by row
 * 2, and so on. A vertical region line thus runs through two rows at most.
 * The line between rows r and r + 1 is a staircase: its base height (pieces
 * of edge +- J/2 along y) moves by a drawn +-J/2 between consecutive anchors
 * of row r (the cuts rows r and r + 1 share), so no line crosses the output.
 * Region edges stay >= edge - 3J/2 > edge/4. */
static gs_err jitter_plan(const gs_model_params *p, const int ext[3], const int edge[3],
                          int zlo, const int *zstarts, int zcnt, int zm, int pass, int gap,
                          gs_model_region **out, size_t *nout, int *ncolors)
{
    const int nx = ext[0], ny = ext[1], bx = edge[0], by = edge[1], J = p->region_jitter;
    const size_t W = (size_t)nx + 2;
    int *ycut = NULL, *xcut = NULL, *xk = NULL, *anc = NULL, *na = NULL, *dy = NULL;
    gs_model_region *list = NULL;
    gs_err err = GS_OK;
    gs_rng r;
    gs_rng_init(&r, p->seed, gs_rng_stream_id(GS_MODEL_PLAN_DOMAIN, (uint64_t)pass, 0, 0));
    GS_TRY(err, gs_alloc_array((void **)&ycut, (size_t)ny + 2, sizeof(int), "plan"), done);
    const int rows = by >= ny ? (ycut[0] = 0, ycut[1] = ny, 1)
                              : jitter_cuts(ny, by, J / 2 > 0 ? J / 2 : 1, &r, ycut);
    GS_TRY(err, gs_alloc_array((void **)&xcut, (size_t)rows * W, sizeof(int), "plan"), done);
    GS_TRY(err, gs_alloc_array((void **)&anc, (size_t)rows * W, sizeof(int), "plan"), done);
    GS_TRY(err, gs_alloc_array((void **)&dy, (size_t)rows * W, sizeof(int), "plan"), done);
    GS_TRY(err, gs_alloc_array((void **)&xk, (size_t)rows, sizeof(int), "plan"), done);
    GS_TRY(err, gs_alloc_array((void **)&na, (size_t)rows, sizeof(int), "plan"), done);
    for (int ky = 0; ky < rows; ky++) {
        int *c = xcut + (size_t)ky * W, *a = anc + (size_t)ky * W;
        if (bx >= nx) {
            c[0] = 0, c[1] = nx, xk[ky] = 1, na[ky] = 0;
        } else if (ky == 0) {
            xk[0] = jitter_cuts(nx, bx, J, &r, c);
            const int first = 1 + (int)gs_rng_below(&r, 2);
            na[0] = 0;
            for (int i = first; i < xk[0]; i += 2)
                a[na[0]++] = c[i];
        } else { /* the anchors of the row below, and new cuts between them */
            const int *pa = anc + (size_t)(ky - 1) * W;
            int k = 0, m = 0;
            c[0] = 0;
            for (int s = 0; s <= na[ky - 1]; s++) {
                const int u = s ? pa[s - 1] : 0, v = s < na[ky - 1] ? pa[s] : nx;
                int pieces = (v - u + bx / 2) / bx;
                pieces = pieces < 1 ? 1 : pieces;
                int prev = u;
                for (int i = 1; i < pieces; i++) {
                    int t = u + (int)((int64_t)(v - u) * i / pieces) - J / 2 +
                            (int)gs_rng_below(&r, (uint64_t)(J / 2 * 2 + 1));
                    const int lo = prev + bx - J, hi = v - (pieces - i) * (bx - J);
                    t = t < lo ? lo : t > hi ? hi : t;
                    if (t <= prev || t >= v)
                        continue;
                    c[++k] = t;
                    a[m++] = t;
                    prev = t;
                }
                if (v < nx)
                    c[++k] = v;
            }
            c[++k] = nx;
            xk[ky] = k;
            na[ky] = m;
        }
        /* the staircase above row ky: one step per span between its anchors */
        for (int s = 0; s <= na[ky]; s++)
            dy[(size_t)ky * W + (size_t)s] =
                ky + 1 < rows ? (int)gs_rng_below(&r, (uint64_t)(J / 2 * 2 + 1)) - J / 2 : 0;
    }
    size_t n = 0;
    int mx = 1;
    for (int ky = 0; ky < rows; ky++) {
        const int m = cut_colors(xcut + (size_t)ky * W, xk[ky], gap);
        mx = m > mx ? m : mx;
        n += (size_t)xk[ky] * (size_t)zcnt;
    }
    const int my = rows > 2 ? 2 : rows;
    GS_TRY(err, gs_alloc_array((void **)&list, n, sizeof *list, "region plan"), done);
    size_t i = 0;
    for (int kz = 0; kz < zcnt; kz++)
        for (int ky = 0; ky < rows; ky++)
            for (int kx = 0; kx < xk[ky]; kx++, i++) {
                const int *c = xcut + (size_t)ky * W;
                gs_model_region *g = &list[i];
                g->box.x0 = c[kx];
                g->box.x1 = c[kx + 1];
                /* the staircase step holding x0: anchors of that row at or below x0 */
                int y[2];
                for (int e = 0; e < 2; e++) {
                    const int row = ky - 1 + e;
                    if (row < 0 || row + 1 >= rows) {
                        y[e] = e ? ny : 0;
                        continue;
                    }
                    int s = 0;
                    while (s < na[row] && anc[(size_t)row * W + (size_t)s] <= c[kx])
                        s++;
                    y[e] = ycut[row + 1] + dy[(size_t)row * W + (size_t)s];
                }
                g->box.y0 = y[0];
                g->box.y1 = y[1];
                GS_TRY_CHECK(err, g->box.x1 - g->box.x0 >= gap && g->box.y1 - g->box.y0 >= gap,
                             GS_ERR_INTERNAL, done, "jittered region %zu: %dx%d", i,
                             g->box.x1 - g->box.x0, g->box.y1 - g->box.y0);
                g->box.z0 = zlo + zstarts[kz];
                g->box.z1 = g->box.z0 + edge[2];
                g->color = (uint32_t)((kx % mx) + mx * ((ky % my) + my * (kz % zm)));
                g->id = (uint32_t)i;
            }
    *out = list;
    *nout = n;
    *ncolors = mx * my * zm;
    list = NULL;
done:
    gs_free(ycut);
    gs_free(xcut);
    gs_free(xk);
    gs_free(anc);
    gs_free(na);
    gs_free(dy);
    gs_free(list);
    return err;
}

static int cmp_color(const void *pa, const void *pb)
{
    const gs_model_region *a = pa, *b = pb;
    if (a->color != b->color)
        return a->color < b->color ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

gs_err gs_model_plan(const gs_model_params *p, int nx, int ny, int nz, int pass,
                     gs_model_region **regions, size_t *nregions, int *ncolors)
{
    GS_CALL(check_params(p));
    int zlo, zhi;
    active_z(p, nz, &zlo, &zhi);
    const int ext[3] = {nx, ny, zhi - zlo};
    int edge[3], m[3], cnt[3];
    const int gap = resem_reach(p) > 1 ? resem_reach(p) : 1;
    int *starts[3] = {NULL, NULL, NULL};
    gs_err err = GS_OK;
    for (int a = 0; a < 3; a++) {
        GS_TRY_CHECK(err, ext[a] >= 1, GS_ERR_ARG, done, "output extent %d along axis %d", ext[a],
                     a);
        edge[a] = (p->region[a] <= 0 || p->region[a] >= ext[a]) ? ext[a] : p->region[a];
        GS_TRY(err, gs_alloc_array((void **)&starts[a], (size_t)ext[a] + 2, sizeof(int), "plan"),
               done);
        cnt[a] = axis_starts(ext[a], edge[a], p->overlap, pass, p->periodic[a], gap, starts[a],
                             &m[a]);
    }
    size_t n = (size_t)cnt[0] * (size_t)cnt[1] * (size_t)cnt[2];
    gs_model_region *list = NULL;
    if (p->region_jitter > 0) {
        GS_TRY_CHECK(err, p->overlap == 0 && !p->periodic[0] && !p->periodic[1], GS_ERR_ARG,
                     done, "model.region_jitter needs model.overlap = 0 and x, y not periodic");
        GS_TRY_CHECK(err, 2 * p->region_jitter < (edge[0] < edge[1] ? edge[0] : edge[1]),
                     GS_ERR_ARG, done, "model.region_jitter %d: less than half the region edge",
                     p->region_jitter);
        GS_TRY(err, jitter_plan(p, ext, edge, zlo, starts[2], cnt[2], m[2], pass, gap, &list, &n,
                                ncolors),
               done);
        qsort(list, n, sizeof *list, cmp_color);
        for (size_t i = 0; i < n; i++)
            list[i].id = (uint32_t)i;
        *regions = list;
        *nregions = n;
        goto done;
    }
    GS_TRY(err, gs_alloc_array((void **)&list, n, sizeof *list, "region plan"), done);
    size_t i = 0;
    for (int kz = 0; kz < cnt[2]; kz++)
        for (int ky = 0; ky < cnt[1]; ky++)
            for (int kx = 0; kx < cnt[0]; kx++, i++) {
                gs_model_region *r = &list[i];
                r->box.x0 = starts[0][kx];
                r->box.y0 = starts[1][ky];
                r->box.z0 = zlo + starts[2][kz];
                r->box.x1 = r->box.x0 + edge[0];
                r->box.y1 = r->box.y0 + edge[1];
                r->box.z1 = r->box.z0 + edge[2];
                r->color = (uint32_t)((kx % m[0]) + m[0] * ((ky % m[1]) + m[1] * (kz % m[2])));
                r->id = (uint32_t)i;
            }
    qsort(list, n, sizeof *list, cmp_color);
    for (i = 0; i < n; i++)
        list[i].id = (uint32_t)i;
    *regions = list;
    *nregions = n;
    *ncolors = m[0] * m[1] * m[2];
done:
    for (int a = 0; a < 3; a++)
        gs_free(starts[a]);
    return err;
}

size_t gs_model_plan_max_cells(const gs_model_region *plan, size_t n)
{
    size_t best = 0;
    for (size_t i = 0; i < n; i++) {
        const gs_model_box *b = &plan[i].box;
        size_t c = (size_t)(b->x1 - b->x0) * (size_t)(b->y1 - b->y0) * (size_t)(b->z1 - b->z0);
        best = c > best ? c : best;
    }
    return best;
}

/* Does [lo, hi), grown by `grow` cells (the shell, 0 or 1), meet [blo, bhi)
 * along one axis, across the wrap of a periodic axis? */
static int axis_meets(int lo, int hi, int grow, int blo, int bhi, int n, int periodic, int mirror)
{
    int rlo = lo - grow, rhi = hi + grow;
    if (grow && mirror && hi == n && n - 2 < rlo)
        rlo = n - 2; /* the mirror image of the upper face: itself or the cell below */
    for (int t = periodic ? -1 : 0; t <= (periodic ? 1 : 0); t++)
        if (rlo < bhi + t * n && blo + t * n < rhi)
            return 1;
    return 0;
}

/* Does a read meet b's box? A region reads its box, the face-neighbour
 * shell (the box grown by one cell along one axis at a time: the
 * constraints) and, with resemblance of window radius w, the box grown by w
 * along every axis at once (the window of a box cell reaches edges and
 * corners: a diagonal region touching only at a corner is read too). */
static int box_reads(const gs_model_params *p, const int n[3], const int alo[3], const int ahi[3],
                     const int blo[3], const int bhi[3])
{
    int plain[3], grown[3], window = resem_reach(p) > 0;
    for (int d = 0; d < 3; d++) {
        plain[d] = axis_meets(alo[d], ahi[d], 0, blo[d], bhi[d], n[d], p->periodic[d], 0);
        grown[d] = axis_meets(alo[d], ahi[d], 1, blo[d], bhi[d], n[d], p->periodic[d],
                              p->mirror[d]);
        window &= axis_meets(alo[d], ahi[d], resem_reach(p), blo[d], bhi[d], n[d], p->periodic[d],
                             0);
    }
    return window || (grown[0] && plain[1] && plain[2]) || (plain[0] && grown[1] && plain[2]) ||
           (plain[0] && plain[1] && grown[2]);
}

int gs_model_regions_interact(const gs_model_params *p, int nx, int ny, int nz,
                              const gs_model_box *a, const gs_model_box *b)
{
    const int n[3] = {nx, ny, nz};
    const int alo[3] = {a->x0, a->y0, a->z0}, ahi[3] = {a->x1, a->y1, a->z1};
    const int blo[3] = {b->x0, b->y0, b->z0}, bhi[3] = {b->x1, b->y1, b->z1};
    return box_reads(p, n, alo, ahi, blo, bhi) || box_reads(p, n, blo, bhi, alo, ahi);
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

/* Buckets of edge E + g along each axis (E = the longest region edge, g the
 * read reach: 1, or the resemblance radius w when larger):
 * regions that interact have lower corners less than E + g apart along
 * every axis (straight or across a periodic wrap), so they sit in
 * neighbouring buckets: +-1 along a plain axis; +-2 along a periodic one
 * (its last bucket may be narrower), or every bucket when there are < 5. */
gs_err gs_model_plan_conflicts(const gs_model_params *p, int nx, int ny, int nz,
                               const gs_model_region *plan, size_t n, int64_t **offsets,
                               int64_t **ids)
{
    const int dim[3] = {nx, ny, nz};
    int edge[3] = {1, 1, 1}, nb[3];
    for (size_t i = 0; i < n; i++) {
        const gs_model_box *b = &plan[i].box;
        const int len[3] = {b->x1 - b->x0, b->y1 - b->y0, b->z1 - b->z0};
        for (int a = 0; a < 3; a++)
            edge[a] = len[a] > edge[a] ? len[a] : edge[a];
    }
    const int grow = resem_reach(p) > 1 ? resem_reach(p) : 1;
    for (int a = 0; a < 3; a++) {
        edge[a] += grow;
        nb[a] = dim[a] > 0 ? (dim[a] + edge[a] - 1) / edge[a] : 1;
    }
    size_t nbuckets = (size_t)nb[0] * (size_t)nb[1] * (size_t)nb[2];
    size_t *start = NULL, *member = NULL, *bucket = NULL, *cand = NULL;
    int64_t *off = NULL, *list = NULL;
    size_t cap = 0, m = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&start, nbuckets + 1, sizeof *start, "buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&member, n ? n : 1, sizeof *member, "buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&bucket, n ? n : 1, sizeof *bucket, "buckets"), done);
    GS_TRY(err, gs_alloc_array((void **)&cand, n ? n : 1, sizeof *cand, "conflicts"), done);
    GS_TRY(err, gs_alloc_array((void **)&off, n + 1, sizeof *off, "conflicts"), done);
    memset(start, 0, (nbuckets + 1) * sizeof *start);
    for (size_t i = 0; i < n; i++) {
        const gs_model_box *b = &plan[i].box;
        const int lo[3] = {b->x0, b->y0, b->z0};
        size_t at = 0;
        for (int a = 2; a >= 0; a--) {
            int k = lo[a] / edge[a];
            k = k < 0 ? 0 : k >= nb[a] ? nb[a] - 1 : k;
            at = at * (size_t)nb[a] + (size_t)k;
        }
        bucket[i] = at;
        start[at + 1]++;
    }
    for (size_t k = 0; k < nbuckets; k++)
        start[k + 1] += start[k];
    for (size_t i = 0; i < n; i++)
        member[start[bucket[i]]++] = i;
    for (size_t k = nbuckets; k > 0; k--) /* back to bucket starts */
        start[k] = start[k - 1];
    start[0] = 0;
    for (size_t i = 0; i < n; i++) {
        int near[3][5], nnear[3];
        size_t rest = bucket[i];
        for (int a = 0; a < 3; a++) {
            int k = (int)(rest % (size_t)nb[a]);
            rest /= (size_t)nb[a];
            nnear[a] = 0;
            if (p->periodic[a] && nb[a] < 5) {
                for (int t = 0; t < nb[a]; t++)
                    near[a][nnear[a]++] = t;
            } else {
                int reach = p->periodic[a] ? 2 : 1;
                for (int t = k - reach; t <= k + reach; t++)
                    if (p->periodic[a])
                        near[a][nnear[a]++] = (t + nb[a]) % nb[a];
                    else if (t >= 0 && t < nb[a])
                        near[a][nnear[a]++] = t;
            }
        }
        size_t nc = 0;
        for (int z = 0; z < nnear[2]; z++)
            for (int y = 0; y < nnear[1]; y++)
                for (int x = 0; x < nnear[0]; x++) {
                    size_t bk = (size_t)near[0][x] +
                                (size_t)nb[0] * ((size_t)near[1][y] + (size_t)nb[1] * (size_t)near[2][z]);
                    for (size_t q = start[bk]; q < start[bk + 1]; q++) {
                        size_t j = member[q];
                        if (j < i && plan[j].color < plan[i].color &&
                            gs_model_regions_interact(p, nx, ny, nz, &plan[i].box, &plan[j].box))
                            cand[nc++] = j;
                    }
                }
        qsort(cand, nc, sizeof *cand, cmp_size);
        off[i] = (int64_t)m;
        if (m + nc > cap) {
            size_t ncap = 2 * (m + nc) + 16;
            int64_t *grown = gs_realloc(list, ncap * sizeof *list);
            GS_TRY_CHECK(err, grown != NULL, GS_ERR_MEM, done, "out of memory (%zu conflicts)",
                         ncap);
            list = grown;
            cap = ncap;
        }
        for (size_t c = 0; c < nc; c++)
            list[m++] = (int64_t)plan[cand[c]].id;
    }
    off[n] = (int64_t)m;
    if (!list)
        GS_TRY(err, gs_alloc_array((void **)&list, 1, sizeof *list, "conflicts"), done);
    *offsets = off;
    *ids = list;
    off = NULL;
    list = NULL;
done:
    gs_free(start);
    gs_free(member);
    gs_free(bucket);
    gs_free(cand);
    gs_free(off);
    gs_free(list);
    return err;
}

struct cells_idx {
    size_t cells, idx;
};

static int cmp_cells_desc(const void *a, const void *b)
{
    const struct cells_idx *x = a, *y = b;
    if (x->cells != y->cells)
        return x->cells < y->cells ? 1 : -1;
    return (x->idx > y->idx) - (x->idx < y->idx);
}

/* model.open_blocks: see model.h. Structures are labelled once from lat (the
 * content the pass starts from: every region of the pass shares colour 0,
 * so the pass runs as one window and a checkpoint sees it only before its
 * first region, where this plan is the same again on resume). */
gs_err gs_model_plan_open_blocks(const gs_model_params *p, const gs_model_lattice *lat,
                                 int ground, int cap, int claim, gs_model_region *plan,
                                 size_t *n, int *ncolors, int32_t *owner)
{
    const int nx = lat->nx, ny = lat->ny, nz = lat->nz;
    const size_t ncol = (size_t)nx * (size_t)ny;
    int32_t *comp = NULL, *stack = NULL, *bb = NULL, *claimed = NULL, *rank_of = NULL, *seen = NULL;
    struct cells_idx *order = NULL;
    gs_model_region *moved = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&comp, ncol ? ncol : 1, sizeof *comp, "open blocks"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&stack, ncol ? ncol : 1, sizeof *stack, "open blocks"),
           done);
    /* a column is tall when it holds a non-empty cell above the ground
     * layer: layer by layer (contiguous; every rank plans, so this is serial
     * work at any rank count) */
    for (size_t c = 0; c < ncol; c++)
        comp[c] = -1;
    for (int z = ground + 1; z < nz; z++) {
        const uint16_t *layer = lat->labels + gs_model_lattice_index(lat, 0, 0, z);
        for (size_t c = 0; c < ncol; c++)
            comp[c] = layer[c] != 0 ? -2 : comp[c];
    }
    int nc = 0; /* structures: 8-connected sets of tall columns */
    for (size_t c0 = 0; c0 < ncol; c0++)
        if (comp[c0] == -2) {
            size_t top = 0;
            comp[c0] = nc;
            stack[top++] = (int32_t)c0;
            while (top) {
                const int c = stack[--top], x = c % nx, y = c / nx;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        const int u = x + dx, v = y + dy;
                        if (u < 0 || v < 0 || u >= nx || v >= ny)
                            continue;
                        const size_t q = (size_t)v * (size_t)nx + (size_t)u;
                        if (comp[q] == -2) {
                            comp[q] = nc;
                            stack[top++] = (int32_t)q;
                        }
                    }
            }
            nc++;
        }
    /* each structure's columns grown by one (its shell), clamped to the lattice */
    GS_TRY(err, gs_alloc_array((void **)&bb, (size_t)(nc ? nc : 1) * 4, sizeof *bb, "open blocks"),
           done);
    for (int k = 0; k < nc; k++)
        bb[4 * k] = nx, bb[4 * k + 1] = ny, bb[4 * k + 2] = 0, bb[4 * k + 3] = 0;
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) {
            const int k = comp[(size_t)y * (size_t)nx + (size_t)x];
            if (k < 0)
                continue;
            int32_t *b = bb + 4 * k;
            b[0] = x - 1 < b[0] ? (x > 0 ? x - 1 : 0) : b[0];
            b[1] = y - 1 < b[1] ? (y > 0 ? y - 1 : 0) : b[1];
            b[2] = x + 2 > b[2] ? (x + 2 < nx ? x + 2 : nx) : b[2];
            b[3] = y + 2 > b[3] ? (y + 2 < ny ? y + 2 : ny) : b[3];
        }
    if (claim) {
        GS_TRY(err, gs_alloc_array((void **)&claimed, (size_t)(nc ? nc : 1), sizeof *claimed,
                                   "open blocks"), done);
        for (int k = 0; k < nc; k++)
            claimed[k] = -1;
    }
    /* seen[k] = 1 + the candidate that last took structure k in or left it
     * out: b only grows, so a structure b took in stays inside it and one
     * too large to take in stays too large; looking at it again changes
     * nothing */
    GS_TRY(err, gs_alloc_array((void **)&seen, (size_t)(nc ? nc : 1), sizeof *seen, "open blocks"),
           done);
    memset(seen, 0, (size_t)(nc ? nc : 1) * sizeof *seen);
    size_t kept = 0;
    for (size_t i = 0; i < *n; i++) {
        gs_model_box b = plan[i].box;
        int ok = 1;
        for (int changed = 1; changed;) {
            changed = 0;
            const int x0 = b.x0 > 0 ? b.x0 - 1 : 0, x1 = b.x1 < nx ? b.x1 + 1 : nx;
            const int y0 = b.y0 > 0 ? b.y0 - 1 : 0, y1 = b.y1 < ny ? b.y1 + 1 : ny;
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++) {
                    const int k = comp[(size_t)y * (size_t)nx + (size_t)x];
                    if (k < 0 || seen[k] == (int32_t)i + 1)
                        continue;
                    seen[k] = (int32_t)i + 1;
                    const int32_t *c = bb + 4 * k;
                    const gs_model_box g = {c[0] < b.x0 ? c[0] : b.x0, c[1] < b.y0 ? c[1] : b.y0,
                                            b.z0, c[2] > b.x1 ? c[2] : b.x1,
                                            c[3] > b.y1 ? c[3] : b.y1, b.z1};
                    if (g.x1 - g.x0 > cap || g.y1 - g.y0 > cap)
                        continue; /* too large to take in: the region rebuilds across it */
                    if (g.x0 != b.x0 || g.y0 != b.y0 || g.x1 != b.x1 || g.y1 != b.y1) {
                        b = g;
                        changed = 1;
                    }
                }
        }
        /* kept only if it interacts with no region kept before it */
        for (size_t j = 0; j < kept && ok; j++)
            ok = !gs_model_regions_interact(p, nx, ny, nz, &b, &plan[j].box);
        /* claim: nor meets a structure one kept before it meets; it claims
         * the structures it meets */
        const int sx0 = b.x0 > 0 ? b.x0 - 1 : 0, sx1 = b.x1 < nx ? b.x1 + 1 : nx;
        const int sy0 = b.y0 > 0 ? b.y0 - 1 : 0, sy1 = b.y1 < ny ? b.y1 + 1 : ny;
        for (int pass = 0; claim && ok && pass < 2; pass++)
            for (int y = sy0; y < sy1 && ok; y++)
                for (int x = sx0; x < sx1 && ok; x++) {
                    const int k = comp[(size_t)y * (size_t)nx + (size_t)x];
                    if (k >= 0 && pass == 0)
                        ok = claimed[k] < 0;
                    else if (k >= 0)
                        claimed[k] = (int32_t)kept;
                }
        if (ok) {
            plan[kept].box = b;
            plan[kept].color = 0;
            plan[kept].id = (uint32_t)kept;
            kept++;
        }
    }
    *n = kept;
    *ncolors = 1;
    if (claim && kept > 1) { /* largest first (ties: plan order), the ids renumbered:
                                the dataflow's pick rule then balances two ranks */
        GS_TRY(err, gs_alloc_array((void **)&order, kept, sizeof *order, "open blocks"), done);
        GS_TRY(err, gs_alloc_array((void **)&rank_of, kept, sizeof *rank_of, "open blocks"),
               done);
        GS_TRY(err, gs_alloc_array((void **)&moved, kept, sizeof *moved, "open blocks"), done);
        for (size_t j = 0; j < kept; j++) {
            const gs_model_box *q = &plan[j].box;
            order[j].cells = (size_t)(q->x1 - q->x0) * (size_t)(q->y1 - q->y0);
            order[j].idx = j;
        }
        qsort(order, kept, sizeof *order, cmp_cells_desc);
        for (size_t j = 0; j < kept; j++) {
            moved[j] = plan[order[j].idx];
            moved[j].id = (uint32_t)j;
            rank_of[order[j].idx] = (int32_t)j;
        }
        memcpy(plan, moved, kept * sizeof *plan);
        for (int k = 0; k < nc; k++)
            if (claimed[k] >= 0)
                claimed[k] = rank_of[claimed[k]];
    }
    for (size_t c = 0; owner && c < ncol; c++)
        owner[c] = claim && comp[c] >= 0 ? claimed[comp[c]] : -1;
done:
    gs_free(comp);
    gs_free(stack);
    gs_free(bb);
    gs_free(seen);
    gs_free(claimed);
    gs_free(rank_of);
    gs_free(order);
    gs_free(moved);
    return err;
}

gs_err gs_model_synthesize(const gs_model_rules_t rules, const gs_model_params *p,
                           gs_model_lattice *lat, gs_model_stats *stats)
{
    GS_CALL(check_params(p));
    gs_model_stats st;
    memset(&st, 0, sizeof st);
    double t0 = gs_time_now();
    int zlo, zhi;
    active_z(p, lat->nz, &zlo, &zhi);
    const size_t ncell = (size_t)lat->nx * (size_t)lat->ny * (size_t)lat->nz;
    uint16_t *coverage = NULL, *buf = NULL;
    size_t bufcells = 0;
    gs_model_region *plan = NULL;
    gs_model_solver_t solver = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&coverage, ncell, sizeof *coverage, "coverage"), done);
    GS_TRY(err, gs_model_solver_create(rules, p->ac, &solver), done);
    int pass = 0;
    for (; pass < p->max_passes; pass++) {
        size_t nplan = 0;
        int ncolors = 0;
        GS_TRY(err, gs_model_plan(p, lat->nx, lat->ny, lat->nz, pass, &plan, &nplan, &ncolors),
               done);
        if (gs_model_plan_max_cells(plan, nplan) > bufcells) { /* region_jitter: per pass */
            gs_free(buf);
            buf = NULL;
            bufcells = gs_model_plan_max_cells(plan, nplan);
            GS_TRY(err, gs_alloc_array((void **)&buf, bufcells, sizeof *buf, "region labels"), done);
        }
        for (size_t i = 0; i < nplan; i++) {
            const gs_model_box *b = &plan[i].box;
            gs_model_region_result res;
            GS_TRY(err, gs_model_region_run(solver, lat, b, p, plan[i].id, (uint64_t)pass, buf, &res),
                   done);
            st.regions++;
            st.attempts += (uint64_t)res.attempts;
            st.choices += res.choices;
            st.backtracks += res.backtracks;
            st.split += (uint64_t)res.split;
            if (res.mh_rejected) {
                st.mh_rejected++;
                continue;
            }
            if (!res.ok) {
                st.failed++;
                st.kept_cells += res.kept_cells;
                if (res.partial)
                    gs_model_region_apply(lat, b, buf);
                continue;
            }
            st.accepted++;
            gs_model_region_apply(lat, b, buf);
            for (int z = b->z0; z < b->z1; z++)
                for (int y = b->y0; y < b->y1; y++)
                    for (int x = b->x0; x < b->x1; x++) {
                        uint16_t *cv = &coverage[gs_model_lattice_index(lat, x, y, z)];
                        if (*cv < UINT16_MAX)
                            (*cv)++;
                    }
        }
        GS_FREE(plan);
        uint64_t mincov = UINT64_MAX;
        for (int z = zlo; z < zhi; z++)
            for (int y = 0; y < lat->ny; y++)
                for (int x = 0; x < lat->nx; x++) {
                    uint64_t cv = coverage[gs_model_lattice_index(lat, x, y, z)];
                    if (cv < mincov)
                        mincov = cv;
                }
        st.min_coverage = mincov == UINT64_MAX ? 0 : mincov;
        if (st.min_coverage >= (uint64_t)p->min_changes) {
            pass++;
            break;
        }
    }
    st.passes = pass;
    st.seconds = gs_time_now() - t0;
    if (stats)
        *stats = st;
done:
    gs_free(coverage);
    gs_free(buf);
    gs_free(plan);
    gs_model_solver_destroy(&solver);
    return err;
}

gs_err gs_model_initial_tiled(const gs_model_rules_t rules, const gs_model_lattice *example,
                              const gs_model_params *p, int tile, gs_model_lattice *out,
                              int *tiled)
{
    GS_CALL(check_params(p));
    GS_CHECK(tile >= 1, GS_ERR_ARG, "start tile edge %d: expected >= 1", tile);
    *tiled = 0;
    GS_CALL(gs_model_initial(rules, example, NULL, out));
    const int tx = tile < out->nx ? tile : out->nx, ty = tile < out->ny ? tile : out->ny;
    gs_model_lattice t = {0};
    gs_model_solver_t solver = NULL;
    uint16_t *buf = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_model_lattice_create(&t, tx, ty, out->nz), done);
    GS_TRY(err, gs_model_initial(rules, example, NULL, &t), done);
    GS_TRY(err, gs_model_solver_create(rules, p->ac, &solver), done);
    GS_TRY(err, gs_alloc_array((void **)&buf, (size_t)tx * ty * out->nz, sizeof *buf, "start tile"),
           done);
    gs_model_params q = *p;
    q.periodic[0] = q.periodic[1] = 1;
    q.periodic[2] = 0;
    q.shape = NULL; /* the tile repeats over the output: no target shape */
    int zlo, zhi;
    active_z(&q, t.nz, &zlo, &zhi);
    gs_model_box box = {0, 0, zlo, tx, ty, zhi};
    gs_model_region_result res;
    /* region id UINT32_MAX + 1: a stream no region plan uses */
    GS_TRY(err, gs_model_region_run(solver, &t, &box, &q, (uint64_t)1 << 32, 0, buf, &res), done);
    if (!res.ok)
        goto done;
    gs_model_region_apply(&t, &box, buf);
    for (int z = 0; z < out->nz; z++)
        for (int y = 0; y < out->ny; y++)
            for (int x = 0; x < out->nx; x++)
                out->labels[gs_model_lattice_index(out, x, y, z)] =
                    t.labels[gs_model_lattice_index(&t, x % tx, y % ty, z)];
    /* periodic along an output axis only when the tile divides it */
    int per[3] = {p->periodic[0] && out->nx % tx == 0, p->periodic[1] && out->ny % ty == 0, 0};
    size_t bad = gs_model_rules_violations_wrap(rules, out, per);
    GS_TRY_CHECK(err, bad == 0, GS_ERR_INTERNAL, done, "tiled start model has %zu violations", bad);
    *tiled = 1;
done:
    if (err == GS_OK && !*tiled)
        err = gs_model_initial(rules, example, NULL, out);
    gs_model_lattice_destroy(&t);
    gs_model_solver_destroy(&solver);
    gs_free(buf);
    return err;
}
