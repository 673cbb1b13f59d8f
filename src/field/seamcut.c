/* Minimum-error boundary cut inside one block (field.seam_cut; see
 * field_impl.h, gs_field_seam_cut).
 *
 * The block's samples are the nodes of a 6-connected grid graph; the edge
 * between neighbours s and t costs e(s) + e(t), e the disagreement of the
 * old content and the new block at a sample (Kwatra et al. 2003, "Graphcut
 * textures", the 3D form of Efros and Freeman's minimum error boundary).
 * A sample tied to the new block has no old content to disagree with: an
 * edge from it costs twice its other end's e, as if the disagreement went on
 * (counted as 0, the seam next to the unsynthesized samples cost half of any
 * other and stayed on the block grid: terrain.ini's straight seams, #19).
 * Samples tied to the old content are sources, samples that must take the
 * new block are sinks; the minimum cut between them is found with Dinic's
 * maximum flow (BFS levels, blocking flow by an iterative DFS with current
 * arcs: no recursion, so a 32^3 block's long paths need no deep stack). The
 * nodes still reached from a source in the residual graph keep the old
 * content, every other node takes the new block. Integer capacities and a
 * fixed visiting order: the same labels on every rank and every run. */
#include <stdlib.h>
#include <string.h>

#include "field_impl.h"
#include "geosynth/mem.h"

gs_err gs_field_cut_scratch_init(gs_field_cut_scratch *c, int B)
{
    gs_field_cut_scratch_free(c);
    size_t n = (size_t)B * B * B;
    c->B = B;
    GS_CALL(gs_alloc_array((void **)&c->cap, n * 6, sizeof *c->cap, "seam cut capacities"));
    GS_CALL(gs_alloc_array((void **)&c->level, n, sizeof *c->level, "seam cut levels"));
    GS_CALL(gs_alloc_array((void **)&c->queue, n, sizeof *c->queue, "seam cut queue"));
    GS_CALL(gs_alloc_array((void **)&c->path, n + 1, sizeof *c->path, "seam cut path"));
    GS_CALL(gs_alloc_array((void **)&c->arc, n, 1, "seam cut arcs"));
    return GS_OK;
}

void gs_field_cut_scratch_free(gs_field_cut_scratch *c)
{
    gs_free(c->cap);
    gs_free(c->level);
    gs_free(c->queue);
    gs_free(c->path);
    gs_free(c->arc);
    memset(c, 0, sizeof *c);
}

/* Neighbour of node i along direction d (0 -x, 1 +x, 2 -y, 3 +y, 4 -z,
 * 5 +z), -1 outside the block. */
static inline int32_t nb(int B, int32_t i, int d)
{
    int a = d >> 1, c = a == 0 ? i % B : a == 1 ? i / B % B : i / (B * B);
    int32_t st = a == 0 ? 1 : a == 1 ? B : B * B;
    if (d & 1)
        return c + 1 < B ? i + st : -1;
    return c > 0 ? i - st : -1;
}

/* BFS levels from every source over arcs with residual capacity; sinks are
 * reached, never expanded. Returns whether a sink was reached. */
static int bfs(gs_field_cut_scratch *c, const uint8_t *term)
{
    int B = c->B;
    int32_t n = B * B * B, head = 0, tail = 0;
    int reached = 0;
    for (int32_t i = 0; i < n; i++) {
        c->level[i] = term[i] == GS_CUT_OLD ? 0 : -1;
        if (term[i] == GS_CUT_OLD)
            c->queue[tail++] = i;
    }
    while (head < tail) {
        int32_t u = c->queue[head++];
        if (term[u] == GS_CUT_NEW) {
            reached = 1;
            continue;
        }
        for (int d = 0; d < 6; d++) {
            int32_t v = nb(B, u, d);
            if (v >= 0 && c->level[v] < 0 && c->cap[6 * (size_t)u + d] > 0) {
                c->level[v] = c->level[u] + 1;
                c->queue[tail++] = v;
            }
        }
    }
    return reached;
}

/* Blocking flow from source s along the level graph. */
static void augment_from(gs_field_cut_scratch *c, const uint8_t *term, int32_t s)
{
    int B = c->B;
    int32_t *path = c->path;
    int k = 0;
    path[0] = s;
    while (k >= 0) {
        int32_t u = path[k];
        if (term[u] == GS_CUT_NEW) {
            uint32_t f = UINT32_MAX;
            int first = 0;
            for (int j = 0; j < k; j++) {
                uint32_t r = c->cap[6 * (size_t)path[j] + c->arc[path[j]]];
                if (r < f)
                    f = r, first = j;
            }
            for (int j = 0; j < k; j++) {
                int d = c->arc[path[j]];
                int32_t v = path[j + 1];
                c->cap[6 * (size_t)path[j] + d] -= f;
                c->cap[6 * (size_t)v + (d ^ 1)] += f;
            }
            k = first; /* retreat to the first saturated arc's tail */
            continue;
        }
        int32_t v = -1;
        while (c->arc[u] < 6) {
            int d = c->arc[u];
            v = nb(B, u, d);
            if (v >= 0 && c->cap[6 * (size_t)u + d] > 0 && c->level[v] == c->level[u] + 1)
                break;
            c->arc[u]++;
            v = -1;
        }
        if (v >= 0) {
            path[++k] = v;
        } else {
            c->level[u] = -1; /* dead end */
            if (--k >= 0)
                c->arc[path[k]]++;
        }
    }
}

gs_err gs_field_seam_cut(gs_field_cut_scratch *c, const uint8_t *term, const uint32_t *cost,
                         int columns, uint8_t *take_new)
{
    int B = c->B;
    int32_t n = B * B * B;
    int any_old = 0, any_new = 0;
    for (int32_t i = 0; i < n; i++)
        any_old |= term[i] == GS_CUT_OLD, any_new |= term[i] == GS_CUT_NEW;
    if (!any_old) { /* nothing ties the block to old content: all new */
        memset(take_new, 1, (size_t)n);
        return GS_OK;
    }
    for (int32_t i = 0; i < n; i++)
        for (int d = 0; d < 6; d++) {
            int32_t v = nb(B, i, d);
            c->cap[6 * (size_t)i + d] = v < 0 ? 0
                                        : columns && d >= 4 ? GS_CUT_COLUMN
                                        : term[v] == GS_CUT_NEW && term[i] != GS_CUT_NEW ? 2 * cost[i]
                                        : term[i] == GS_CUT_NEW && term[v] != GS_CUT_NEW ? 2 * cost[v]
                                                                                          : cost[i] + cost[v];
        }
    while (any_new && bfs(c, term)) {
        memset(c->arc, 0, (size_t)n);
        for (int32_t s = 0; s < n; s++)
            if (term[s] == GS_CUT_OLD && c->level[s] == 0)
                augment_from(c, term, s);
    }
    /* old: reached from a source in the residual graph */
    bfs(c, term);
    for (int32_t i = 0; i < n; i++)
        take_new[i] = c->level[i] < 0;
    return GS_OK;
}
