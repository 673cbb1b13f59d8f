/* Mesh refinement for the micro engine: uniform 1-to-4 splits, then
 * conforming longest-edge bisection, until every edge is <= a bound.
 *
 * Why this scheme: the reconstruction works per triangle, so triangles must
 * be small (paper 4.4) and not slivers (high aspect ratios give artefacts).
 * 1-to-4 splits produce similar triangles (angles kept) and are used while
 * halving every edge is still needed. The last factor < 2 is done by
 * longest-edge bisection (Rivara): a triangle with any too-long edge is cut
 * from the midpoint of its longest edge to the opposite vertex, and its other
 * marked edges are then cut too, so the result is conforming; bisecting across
 * the longest edge keeps the minimum angle at least half the input's. */
#include <math.h>
#include <string.h>

#include "geosynth/mem.h"
#include "micro/micro_impl.h"

/* Numbers the edges of m: e[3t+i] is the id of edge (v_i, v_{i+1}) of t;
 * ends[2 id] its vertices. */
static gs_err number_edges(const gs_micro_mesh *m, uint32_t *e, uint32_t **ends_out, uint32_t *nedges)
{
    micro_map map;
    GS_CALL(micro_map_init(&map, (uint64_t)m->ntris * 3 / 2 + 16));
    uint32_t *ends = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&ends, (size_t)m->ntris * 6, sizeof *ends, "edge list"), done);
    uint32_t n = 0;
    for (uint32_t t = 0; t < m->ntris; t++)
        for (int i = 0; i < 3; i++) {
            uint32_t a = m->tris[3 * (size_t)t + i], b = m->tris[3 * (size_t)t + (i + 1) % 3];
            int found;
            uint32_t *slot = micro_map_slot(&map, micro_edge_key(a, b), &found);
            if (!found) {
                ends[2 * (size_t)n] = a, ends[2 * (size_t)n + 1] = b;
                *slot = n++;
            }
            e[3 * (size_t)t + i] = *slot;
        }
    *ends_out = ends;
    *nedges = n;
done:
    micro_map_free(&map);
    return err;
}

/* One refinement pass. uniform: split every edge; otherwise split the edges
 * longer than max_edge plus the longest edge of every triangle that has a
 * split edge (closure). *changed = 0 when nothing was split. */
static gs_err refine_pass(gs_micro_mesh *m, int uniform, double max_edge, int *changed)
{
    gs_err err = GS_OK;
    uint32_t *e = NULL, *ends = NULL, *mid = NULL, nedges = 0;
    uint8_t *longest = NULL;
    gs_micro_mesh out = {0};
    GS_TRY(err, gs_alloc_array((void **)&e, (size_t)m->ntris * 3, sizeof *e, "triangle edges"), done);
    GS_TRY(err, number_edges(m, e, &ends, &nedges), done);
    GS_TRY(err, gs_alloc_array((void **)&mid, nedges, sizeof *mid, "edge midpoints"), done);
    GS_TRY(err, gs_alloc_array((void **)&longest, m->ntris, 1, "longest edges"), done);
    /* mid[id]: 0 = keep, 1 = split (later: the midpoint vertex index). */
    for (uint32_t t = 0; t < m->ntris; t++) {
        double best = -1;
        int bi = 0;
        for (int i = 0; i < 3; i++) {
            uint32_t id = e[3 * (size_t)t + i];
            double len = micro_dist3f(m->pos + 3 * (size_t)ends[2 * (size_t)id],
                                      m->pos + 3 * (size_t)ends[2 * (size_t)id + 1]);
            if (uniform || len > max_edge)
                mid[id] = 1;
            /* ties broken by edge id so the choice is deterministic */
            if (len > best || (len == best && id < e[3 * (size_t)t + bi]))
                best = len, bi = i;
        }
        longest[t] = (uint8_t)bi;
    }
    /* Closure: a triangle with any split edge must split its longest one. */
    for (int again = 1; again;) {
        again = 0;
        for (uint32_t t = 0; t < m->ntris; t++) {
            const uint32_t *te = e + 3 * (size_t)t;
            uint32_t lid = te[longest[t]];
            if (!mid[lid] && (mid[te[0]] || mid[te[1]] || mid[te[2]]))
                mid[lid] = 1, again = 1;
        }
    }
    uint64_t nsplit = 0, ntri_new = 0;
    for (uint32_t id = 0; id < nedges; id++)
        nsplit += mid[id];
    for (uint32_t t = 0; t < m->ntris; t++)
        ntri_new += 1 + (uint64_t)mid[e[3 * (size_t)t]] + mid[e[3 * (size_t)t + 1]] + mid[e[3 * (size_t)t + 2]];
    *changed = nsplit > 0;
    if (!nsplit)
        goto done;
    GS_TRY_CHECK(err, m->nverts + nsplit < UINT32_MAX && ntri_new < UINT32_MAX, GS_ERR_ARG, done,
                 "subdivision to edges <= %g would exceed 2^32 vertices or triangles", max_edge);
    GS_TRY(err, gs_micro_mesh_alloc(&out, (uint32_t)(m->nverts + nsplit), (uint32_t)ntri_new), done);
    memcpy(out.pos, m->pos, (size_t)m->nverts * 3 * sizeof *m->pos);
    uint32_t nv = m->nverts;
    for (uint32_t id = 0; id < nedges; id++) {
        if (!mid[id]) {
            mid[id] = UINT32_MAX;
            continue;
        }
        const float *a = m->pos + 3 * (size_t)ends[2 * (size_t)id], *b = m->pos + 3 * (size_t)ends[2 * (size_t)id + 1];
        for (int d = 0; d < 3; d++)
            out.pos[3 * (size_t)nv + d] = (float)(0.5 * ((double)a[d] + b[d]));
        mid[id] = nv++;
    }
    uint32_t *o = out.tris;
#define EMIT(x, y, z) (o[0] = (x), o[1] = (y), o[2] = (z), o += 3)
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *tv = m->tris + 3 * (size_t)t, *te = e + 3 * (size_t)t;
        int L = longest[t];
        uint32_t a = tv[L], b = tv[(L + 1) % 3], c = tv[(L + 2) % 3];
        uint32_t mab = mid[te[L]], mbc = mid[te[(L + 1) % 3]], mca = mid[te[(L + 2) % 3]];
        if (mab == UINT32_MAX) {
            EMIT(a, b, c);
            continue;
        }
        if (mbc == UINT32_MAX) {
            EMIT(mab, b, c);
        } else {
            EMIT(mab, b, mbc);
            EMIT(mab, mbc, c);
        }
        if (mca == UINT32_MAX) {
            EMIT(a, mab, c);
        } else {
            EMIT(a, mab, mca);
            EMIT(mab, c, mca);
        }
    }
#undef EMIT
    GS_ASSERT((uint64_t)(o - out.tris) == 3 * ntri_new);
    gs_micro_mesh_free(m);
    *m = out;
    out = (gs_micro_mesh){0};
done:
    gs_micro_mesh_free(&out);
    gs_free(e);
    gs_free(ends);
    gs_free(mid);
    gs_free(longest);
    return err;
}

gs_err gs_micro_mesh_subdivide(gs_micro_mesh *m, double max_edge, gs_micro_subdiv_stats *stats)
{
    GS_CHECK(max_edge > 0 && isfinite(max_edge), GS_ERR_ARG, "subdivision max_edge %g: expected > 0",
             max_edge);
    gs_micro_subdiv_stats st = {0};
    double emax, amin;
    gs_micro_mesh_edge_stats(m, &emax, &amin);
    /* Work on a copy so m is unchanged on error. */
    gs_micro_mesh w;
    GS_CALL(gs_micro_mesh_alloc(&w, m->nverts, m->ntris));
    memcpy(w.pos, m->pos, (size_t)m->nverts * 3 * sizeof *m->pos);
    memcpy(w.tris, m->tris, (size_t)m->ntris * 3 * sizeof *m->tris);
    gs_err err = GS_OK;
    int changed = 1;
    while (emax > 2 * max_edge) {
        GS_TRY(err, refine_pass(&w, 1, max_edge, &changed), fail);
        st.uniform_passes++;
        emax *= 0.5;
    }
    while (changed) {
        GS_TRY(err, refine_pass(&w, 0, max_edge, &changed), fail);
        st.bisect_passes += changed;
        GS_TRY_CHECK(err, st.bisect_passes < 64, GS_ERR_INTERNAL, fail,
                     "longest-edge bisection did not converge to edges <= %g", max_edge);
    }
    gs_micro_mesh_edge_stats(&w, &st.max_edge, &st.min_angle_deg);
    gs_micro_mesh_free(m);
    *m = w;
    if (stats)
        *stats = st;
    return GS_OK;
fail:
    gs_micro_mesh_free(&w);
    return err;
}
