/* Writes the seed corpus of tests/fuzz/fuzz_vox.c with our own writer plus a
 * few hand-damaged variants (no third-party files). Not built by `make`:
 *   mpicc -std=c11 -Iinclude tests/fuzz/gen_vox_corpus.c build/libgeosynth.a \
 *     <LDLIBS> -o /tmp/gen && /tmp/gen tests/fuzz/corpus/vox
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/vox.h"

static const char *dir;

static void save(const char *name, const uint8_t *buf, size_t len)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(buf, 1, len, f) != len) {
        perror(path);
        exit(1);
    }
    fclose(f);
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static uint8_t *find(uint8_t *b, size_t len, const char *id)
{
    for (size_t i = 8; i + 4 <= len; i++)
        if (!memcmp(b + i, id, 4))
            return b + i;
    return NULL;
}

int main(int argc, char **argv)
{
    if (argc != 2)
        return 2;
    dir = argv[1];
    uint8_t *buf;
    size_t len;
    gs_vox v;
    /* 1: single voxel */
    uint8_t one = 7;
    if (gs_vox_from_lattice(1, 1, 1, &one, NULL, &v) || gs_vox_encode(&v, &buf, &len))
        return 1;
    save("one.vox", buf, len);
    gs_vox_destroy(&v);
    gs_free(buf);
    /* 2: 3x4x5 pattern */
    uint8_t lab[60];
    for (int i = 0; i < 60; i++)
        lab[i] = (uint8_t)(i % 3 ? (i * 37) % 255 + 1 : 0);
    if (gs_vox_from_lattice(3, 4, 5, lab, NULL, &v) || gs_vox_encode(&v, &buf, &len))
        return 1;
    save("pattern.vox", buf, len);
    /* damaged variants of pattern.vox */
    uint8_t *d = malloc(len);
    memcpy(d, buf, len);
    put32(find(d, len, "SIZE") + 12, 0);
    save("bad-size-zero.vox", d, len);
    memcpy(d, buf, len);
    put32(find(d, len, "XYZI") + 12, 0x40000000);
    save("bad-xyzi-count.vox", d, len);
    memcpy(d, buf, len);
    find(d, len, "XYZI")[16] = 200;
    save("bad-voxel-coord.vox", d, len);
    memcpy(d, buf, len);
    put32(find(d, len, "nGRP") + 12 + 8, 0x7fffffff);
    save("bad-group-count.vox", d, len);
    memcpy(d, buf, len);
    put32(find(d, len, "nTRN") + 12 + 8, 0); /* root transform points at itself */
    save("bad-graph-cycle.vox", d, len);
    memcpy(d, buf, len);
    put32(d + 16, (uint32_t)len * 2);
    save("bad-main-size.vox", d, len);
    save("truncated.vox", buf, len / 2);
    free(d);
    gs_vox_destroy(&v);
    gs_free(buf);
    /* 3: two models placed apart, custom palette */
    gs_vox two;
    memset(&two, 0, sizeof two);
    gs_vox_model models[2] = {{2, 2, 2, lab}, {3, 1, 2, lab + 10}};
    gs_vox_instance inst[3] = {{0, 0, 0, 0, 0}, {1, 5, -3, 2, 0}, {0, -4, 4, 4, 0}};
    two.nmodels = 2;
    two.models = models;
    two.ninstances = 3;
    two.instances = inst;
    for (int i = 1; i < 256; i++) {
        two.palette[i][0] = (uint8_t)i;
        two.palette[i][1] = (uint8_t)(255 - i);
        two.palette[i][2] = (uint8_t)(i * 7);
        two.palette[i][3] = 255;
    }
    if (gs_vox_encode(&two, &buf, &len))
        return 1;
    save("two-models.vox", buf, len);
    gs_free(buf);
    /* 4: a Slab6 file 2x3x2 */
    uint8_t slab[12 + 12 + 768];
    put32(slab, 2);
    put32(slab + 4, 3);
    put32(slab + 8, 2);
    for (int i = 0; i < 12; i++)
        slab[12 + i] = (uint8_t)(i % 2 ? 255 : i * 20);
    for (int i = 0; i < 768; i++)
        slab[24 + i] = (uint8_t)(i % 64);
    save("tiny.slab.vox", slab, sizeof slab);
    return 0;
}
