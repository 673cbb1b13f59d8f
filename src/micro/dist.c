/* Radial contact distributions and their merged signed histogram (paper 4.3,
 * 5.1, 5.3). See include/geosynth/micro.h for the conventions. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "micro/micro_impl.h"

gs_err gs_micro_dist_create(gs_micro_dist *d, uint32_t nbins, const double *pos, const double *neg)
{
    GS_CHECK(nbins >= 1 && nbins <= 16384, GS_ERR_ARG, "distribution with %u bins: expected [1, 16384]",
             nbins);
    double mass = 0;
    for (uint32_t k = 0; k < nbins; k++) {
        double a = pos ? pos[k] : 0, b = neg ? neg[k] : 0;
        GS_CHECK(a >= 0 && b >= 0 && isfinite(a) && isfinite(b), GS_ERR_ARG,
                 "distribution bin %u: probabilities %g, %g: expected finite values >= 0", k, a, b);
        mass += a + b;
    }
    GS_CHECK(mass > 0, GS_ERR_ARG, "distribution has no mass: every bin is 0");
    double *p = NULL, *q = NULL;
    GS_CALL(gs_alloc_array((void **)&p, nbins, sizeof *p, "distribution"));
    gs_err err = gs_alloc_array((void **)&q, nbins, sizeof *q, "distribution");
    if (err != GS_OK) {
        gs_free(p);
        GS_CALL(err);
    }
    for (uint32_t k = 0; k < nbins; k++)
        p[k] = pos ? pos[k] : 0, q[k] = neg ? neg[k] : 0;
    d->nbins = nbins;
    d->pos = p;
    d->neg = q;
    return GS_OK;
}

void gs_micro_dist_free(gs_micro_dist *d)
{
    if (!d)
        return;
    GS_FREE(d->pos);
    GS_FREE(d->neg);
    d->nbins = 0;
}

/* 1-D squared Euclidean distance transform of f (Felzenszwalb-Huttenlocher):
 * out[q] = min_p (q - p)^2 + f[p]. v, z: scratch of n and n+1 entries. */
static void edt_1d(const double *f, double *out, size_t n, size_t *v, double *z)
{
    size_t k = 0;
    v[0] = 0;
    z[0] = -INFINITY;
    z[1] = INFINITY;
    for (size_t q = 1; q < n; q++) {
        if (f[q] == INFINITY)
            continue;
        if (f[v[0]] == INFINITY) { /* first finite sample: restart the envelope */
            v[0] = q;
            continue;
        }
        double s;
        for (;;) {
            size_t p = v[k];
            s = ((f[q] + (double)q * q) - (f[p] + (double)p * p)) / (2.0 * ((double)q - (double)p));
            if (s <= z[k] && k > 0) {
                k--;
                continue;
            }
            break;
        }
        if (s <= z[k]) { /* k == 0: q replaces the only parabola */
            v[0] = q;
            continue;
        }
        k++;
        v[k] = q;
        z[k] = s;
        z[k + 1] = INFINITY;
    }
    if (f[v[0]] == INFINITY) {
        for (size_t q = 0; q < n; q++)
            out[q] = INFINITY;
        return;
    }
    k = 0;
    for (size_t q = 0; q < n; q++) {
        while (z[k + 1] < (double)q)
            k++;
        double dq = (double)q - (double)v[k];
        out[q] = dq * dq + f[v[k]];
    }
}

/* Squared distance from every pixel to the nearest pixel with feat[] != 0;
 * periodic: the image is a torus (its edges wrap), as a Boolean-model image
 * drawn by gs_micro_image_boolean is. Each 1-D pass then runs on the line
 * repeated three times and keeps the middle copy. */
static gs_err edt_2d(uint32_t w, uint32_t h, const uint8_t *feat, int periodic, double *out)
{
    size_t rep = periodic ? 3 : 1, n = (w > h ? w : h) * rep;
    double *f = NULL, *g = NULL, *z = NULL;
    size_t *v = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&f, n, sizeof *f, "distance transform"), done);
    GS_TRY(err, gs_alloc_array((void **)&g, n, sizeof *g, "distance transform"), done);
    GS_TRY(err, gs_alloc_array((void **)&z, n + 1, sizeof *z, "distance transform"), done);
    GS_TRY(err, gs_alloc_array((void **)&v, n, sizeof *v, "distance transform"), done);
    size_t mid_h = periodic ? h : 0, mid_w = periodic ? w : 0;
    for (uint32_t x = 0; x < w; x++) { /* columns */
        for (size_t y = 0; y < rep * h; y++)
            f[y] = feat[(y % h) * w + x] ? 0 : INFINITY;
        edt_1d(f, g, rep * h, v, z);
        for (uint32_t y = 0; y < h; y++)
            out[(size_t)y * w + x] = g[mid_h + y];
    }
    for (uint32_t y = 0; y < h; y++) { /* rows */
        for (size_t x = 0; x < rep * w; x++)
            f[x] = out[(size_t)y * w + x % w];
        edt_1d(f, g, rep * w, v, z);
        memcpy(out + (size_t)y * w, g + mid_w, w * sizeof *g);
    }
done:
    gs_free(f);
    gs_free(g);
    gs_free(z);
    gs_free(v);
    return err;
}

static gs_err contact_of_image(gs_micro_dist *d, uint32_t w, uint32_t h, const uint8_t *pix,
                               uint8_t threshold, double units_per_pixel, uint32_t max_bins,
                               int periodic);

gs_err gs_micro_dist_from_image(gs_micro_dist *d, uint32_t w, uint32_t h, const uint8_t *pix,
                                uint8_t threshold, double units_per_pixel, uint32_t max_bins)
{
    return contact_of_image(d, w, h, pix, threshold, units_per_pixel, max_bins, 0);
}

/* The paper's radial search (5.3) over every pixel; periodic: the image is a
 * torus. */
static gs_err contact_of_image(gs_micro_dist *d, uint32_t w, uint32_t h, const uint8_t *pix,
                               uint8_t threshold, double units_per_pixel, uint32_t max_bins,
                               int periodic)
{
    GS_CHECK(w > 0 && h > 0 && (uint64_t)w * h < (1ull << 34), GS_ERR_ARG,
             "image %u x %u: expected a non-empty image below 2^34 pixels", w, h);
    GS_CHECK(units_per_pixel > 0 && isfinite(units_per_pixel), GS_ERR_ARG,
             "units_per_pixel %g: expected > 0", units_per_pixel);
    GS_CHECK(max_bins >= 1 && max_bins <= 16384, GS_ERR_ARG, "max_bins %u: expected [1, 16384]", max_bins);
    size_t n = (size_t)w * h, white = 0;
    for (size_t i = 0; i < n; i++)
        white += pix[i] >= threshold;
    GS_CHECK(white > 0 && white < n, GS_ERR_ARG,
             "image %u x %u is all %s at threshold %u: a contact distribution needs both colours", w, h,
             white ? "white" : "black", threshold);
    gs_err err = GS_OK;
    uint8_t *mask = NULL;
    double *dw = NULL, *db = NULL, *cp = NULL, *cn = NULL;
    GS_TRY(err, gs_alloc_array((void **)&mask, n, 1, "image mask"), done);
    GS_TRY(err, gs_alloc_array((void **)&dw, n, sizeof *dw, "image distances"), done);
    GS_TRY(err, gs_alloc_array((void **)&db, n, sizeof *db, "image distances"), done);
    GS_TRY(err, gs_alloc_array((void **)&cp, max_bins, sizeof *cp, "distribution counters"), done);
    GS_TRY(err, gs_alloc_array((void **)&cn, max_bins, sizeof *cn, "distribution counters"), done);
    for (size_t i = 0; i < n; i++)
        mask[i] = pix[i] < threshold; /* black pixels: what white pixels search for */
    GS_TRY(err, edt_2d(w, h, mask, periodic, dw), done);
    for (size_t i = 0; i < n; i++)
        mask[i] = !mask[i];
    GS_TRY(err, edt_2d(w, h, mask, periodic, db), done);
    uint32_t used = 1;
    for (size_t i = 0; i < n; i++) {
        int is_white = pix[i] >= threshold;
        double D = sqrt(is_white ? dw[i] : db[i]); /* >= 1: nearest opposite pixel */
        double x = (D - 0.5) * units_per_pixel;
        uint32_t k = x >= (double)(max_bins - 1) ? max_bins - 1 : (uint32_t)x;
        (is_white ? cp : cn)[k] += 1;
        used = k + 1 > used ? k + 1 : used;
    }
    for (uint32_t k = 0; k < used; k++)
        cp[k] /= (double)n, cn[k] /= (double)n;
    GS_TRY(err, gs_micro_dist_create(d, used, cp, cn), done);
done:
    gs_free(mask);
    gs_free(dw);
    gs_free(db);
    gs_free(cp);
    gs_free(cn);
    return err;
}

gs_err gs_micro_image_boolean(uint32_t w, uint32_t h, double rmin, double rmax, double coverage, gs_rng *rng,
                              uint8_t *pix)
{
    GS_CHECK(w > 0 && h > 0, GS_ERR_ARG, "image %u x %u: expected positive sizes", w, h);
    GS_CHECK(rmin > 0 && rmin <= rmax && rmax < (w < h ? w : h), GS_ERR_ARG,
             "disk radii [%g, %g]: expected 0 < rmin <= rmax < image size", rmin, rmax);
    GS_CHECK(coverage > 0 && coverage < 1, GS_ERR_ARG, "coverage %g: expected (0, 1)", coverage);
    size_t n = (size_t)w * h, white = 0;
    memset(pix, 0, n);
    while ((double)white < coverage * (double)n) {
        double cx = gs_rng_uniform(rng) * w, cy = gs_rng_uniform(rng) * h;
        double r = rmin + (rmax - rmin) * gs_rng_uniform(rng);
        int64_t x0 = (int64_t)floor(cx - r), x1 = (int64_t)ceil(cx + r);
        int64_t y0 = (int64_t)floor(cy - r), y1 = (int64_t)ceil(cy + r);
        for (int64_t y = y0; y <= y1; y++)
            for (int64_t x = x0; x <= x1; x++) {
                double dx = (double)x + 0.5 - cx, dy = (double)y + 0.5 - cy;
                if (dx * dx + dy * dy > r * r)
                    continue;
                size_t i = (size_t)(((y % h) + h) % h) * w + (size_t)(((x % w) + w) % w);
                if (!pix[i])
                    pix[i] = 255, white++;
            }
    }
    return GS_OK;
}

gs_err gs_micro_dist_random(gs_micro_dist *d, const gs_micro_dist_range *r, gs_rng *rng)
{
    GS_CHECK(r->min_bins >= 1 && r->min_bins <= r->max_bins && r->max_bins <= 16384, GS_ERR_ARG,
             "random distribution bins [%u, %u]: expected 1 <= min <= max <= 16384", r->min_bins, r->max_bins);
    GS_CHECK(r->min_pos_share > 0 && r->min_pos_share <= r->max_pos_share && r->max_pos_share < 1,
             GS_ERR_ARG, "random distribution positive share [%g, %g]: expected 0 < min <= max < 1",
             r->min_pos_share, r->max_pos_share);
    GS_CHECK(r->area >= 0 && isfinite(r->area), GS_ERR_ARG,
             "random distribution surface area %g: expected >= 0 (0: a 64 x 64 unit torus)", r->area);
    double area = r->area > 0 ? r->area : 64.0 * 64.0;
    double share = r->min_pos_share + (r->max_pos_share - r->min_pos_share) * gs_rng_uniform(rng);
    double rmax = (double)r->min_bins + (double)(r->max_bins - r->min_bins) * gs_rng_uniform(rng);
    /* at least 4 discs' worth of positive area on the surface, a disc at least 1 unit */
    rmax = fmin(rmax, sqrt(area * share / (4 * 3.14159265358979323846)));
    rmax = fmax(rmax, 1.0);
    /* the torus has the surface's area (at most 512 x 512 units), 2-8 pixels a unit */
    double side = fmin(sqrt(area), 512.0), ppu = fmax(2.0, fmin(8.0, 1024.0 / side));
    uint32_t w = (uint32_t)ceil(side * ppu);
    if ((double)w <= 2.5 * rmax * ppu) /* a disc must fit the torus */
        w = (uint32_t)ceil(2.5 * rmax * ppu) + 1;
    uint8_t *pix = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&pix, (size_t)w * w, 1, "random distribution image"), done);
    GS_TRY(err, gs_micro_image_boolean(w, w, 0.5 * rmax * ppu, rmax * ppu, share, rng, pix), done);
    GS_TRY(err, contact_of_image(d, w, w, pix, 128, 1.0 / ppu, 64, 1), done);
done:
    gs_free(pix);
    return err;
}

gs_err gs_micro_hist_from_dist(gs_micro_hist *h, const gs_micro_dist *d, uint32_t ntris)
{
    uint32_t K = d->nbins;
    GS_CHECK(K >= 1 && K <= 16384, GS_ERR_ARG, "distribution with %u bins: expected [1, 16384]", K);
    double mass = 0;
    for (uint32_t k = 0; k < K; k++)
        mass += d->pos[k] + d->neg[k];
    GS_CHECK(mass > 0 && isfinite(mass), GS_ERR_ARG, "distribution mass %g: expected > 0", mass);
    int64_t *count = NULL;
    double *prob = NULL, *rem = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&count, 2 * (size_t)K, sizeof *count, "histogram"), fail);
    GS_TRY(err, gs_alloc_array((void **)&prob, 2 * (size_t)K, sizeof *prob, "histogram"), fail);
    GS_TRY(err, gs_alloc_array((void **)&rem, 2 * (size_t)K, sizeof *rem, "histogram"), fail);
    int64_t sum = 0;
    for (uint32_t k = 0; k < K; k++) {
        prob[gs_micro_bin_index(K, 0, k)] = d->pos[k] / mass;
        prob[gs_micro_bin_index(K, 1, k)] = d->neg[k] / mass;
    }
    for (uint32_t i = 0; i < 2 * K; i++) {
        double x = prob[i] * (double)ntris;
        count[i] = (int64_t)floor(x);
        rem[i] = x - (double)count[i];
        sum += count[i];
    }
    /* Largest remainder: hand the missing units to the largest fractions. */
    for (int64_t missing = (int64_t)ntris - sum; missing > 0; missing--) {
        uint32_t best = 0;
        for (uint32_t i = 1; i < 2 * K; i++)
            if (rem[i] > rem[best])
                best = i;
        count[best]++;
        rem[best] = -1;
    }
    gs_free(rem);
    h->nbins = K;
    h->count = count;
    h->prob = prob;
    return GS_OK;
fail:
    gs_free(count);
    gs_free(prob);
    gs_free(rem);
    return err;
}

void gs_micro_hist_free(gs_micro_hist *h)
{
    if (!h)
        return;
    GS_FREE(h->count);
    GS_FREE(h->prob);
    h->nbins = 0;
}
