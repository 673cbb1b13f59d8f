/* field's configuration: the key table (`geosynth field --help`) and its
 * validation. See engine_impl.h. */
#include <string.h>

#include "geosynth/field_examples.h"
#include "field/engine_impl.h"

static void validate_config(const void *cfg_, gs_cfg_ctx *ctx)
{
    const field_config *c = cfg_;
    int file = !strcmp(c->kind, "file");
    if (file && !c->path[0])
        gs_cfg_report(ctx, "example.path", "is required with example.kind = file (a mesh, .vdb, "
                                           "height-map image or HDF5 field)");
    if (!file && c->path[0])
        gs_cfg_report(ctx, "example.path",
                      "is only read with example.kind = file (example.kind = %s generates the "
                      "example)", c->kind);
    int64_t f = (int64_t)1 << (c->iterations - 1);
    for (int a = 0; a < 3; a++)
        if (c->target[a] % f != 0 || c->target[a] < c->block)
            gs_cfg_report(ctx, "field.target",
                          "axis %d = %lld: expected a multiple of 2^(iterations-1) = %lld and at "
                          "least field.block = %lld",
                          a, (long long)c->target[a], (long long)f, (long long)c->block);
    if (c->iterations > 1 && c->coarse_block * (f / 2) > c->target[0] && c->coarse_block * (f / 2) > c->target[1])
        gs_cfg_report(ctx, "field.coarse_block",
                      "%lld does not fit the target at the coarsest iteration (target / %lld)",
                      (long long)c->coarse_block, (long long)f);
    if (c->object_spacing > 0 && c->region_blocks > 0)
        gs_cfg_report(ctx, "field.object_spacing",
                      "needs field.region_blocks = 0, not %lld (it reads the provenance of the "
                      "whole target, which a region's private copy does not keep)",
                      (long long)c->region_blocks);
}

static const gs_cfg_key field_keys[] = {
    GS_CFG_KEY_ENUM(field_config, kind, "example.kind", "file|" GS_EXAMPLE_KINDS, "grid",
                    "example geometry: a built-in generator, or file = example.path"),
    GS_CFG_KEY_PATH(field_config, path, "example.path", "",
                    "example file: mesh (.obj .ply .stl .off), .vdb level set, height map "
                    "(.png .jpg) or HDF5 field (.h5)"),
    GS_CFG_KEY_INT(field_config, size, "example.size", 8, 1024, 0, "64",
                   "source samples along the longest axis (mesh, generator, height map)"),
    GS_CFG_KEY_INT(field_config, example_seed, "example.seed", 0, GS_CFG_INT_MAX, 0, "1",
                   "seed of the built-in generators (independent of run.seed)"),
    GS_CFG_KEY_ENUM(field_config, sign, "example.sign", "signed|unsigned", "signed",
                    "mesh distance: signed needs a closed mesh; unsigned works for any mesh "
                    "(surface thickened by example.shell)"),
    GS_CFG_KEY_REAL(field_config, shell, "example.shell", 0, 8, 0, "1",
                    "unsigned meshes: half thickness of the solid shell, in samples"),
    GS_CFG_KEY_REAL(field_config, margin, "example.margin", 0, 64, 0, "2",
                    "mesh: samples of empty margin around the bounding box"),
    GS_CFG_KEY_STRING(field_config, vdb_grid, "example.vdb_grid", "",
                      ".vdb: float grid name (empty = the first level set, else the first float grid)"),
    GS_CFG_KEY_STRING(field_config, dataset, "example.dataset", "/field/distance",
                      "HDF5: float32 dataset {nz, ny, nx} holding the distance field"),
    GS_CFG_KEY_INT(field_config, depth, "example.depth", 4, 4096, 0, "32",
                   "height map: samples along z"),
    GS_CFG_KEY_REAL(field_config, height, "example.height", 0, 4096, GS_CFG_OPEN_LO, "16",
                    "height map: relief (black to white) in samples"),
    GS_CFG_KEY_REAL(field_config, range, "field.range", 0, 64, GS_CFG_OPEN_LO, "3",
                    "quantization: 256 levels over [-range, +range] samples of distance"),
    GS_CFG_KEY_INT(field_config, iterations, "field.iterations", 1, GS_FIELD_MAX_ITER, 0, "3",
                   "multi-resolution iterations (paper: 3)"),
    GS_CFG_KEY_INT(field_config, block, "field.block", 2, 32, GS_CFG_POW2, "16",
                   "block size of the last iteration (paper: 16)"),
    GS_CFG_KEY_INT(field_config, coarse_block, "field.coarse_block", 2, 32, GS_CFG_POW2, "8",
                   "block size of the earlier iterations (paper: 8)"),
    GS_CFG_KEY_INT3(field_config, target, "field.target", 2, 4096, 0, "128",
                    "target samples x y z (paper: 128^3 from a 64^3 source)"),
    GS_CFG_KEY_BOOL(field_config, mask_unsynthesized, "field.mask_unsynthesized", "yes",
                    "yes: only synthesized samples count in a match (faithful statistics); "
                    "no: the paper's whole blocks, its random seeds only breaking ties (at full weight "
                    "they outweigh the overlap)"),
    GS_CFG_KEY_REAL(field_config, seed_weight, "field.seed_weight", 0, 1, 0, "0",
                    "masked matching: weight of unsynthesized samples (seeds, coarse result) "
                    "against synthesized ones; 0 = ignored (copies the source), 1 = paper"),
    GS_CFG_KEY_REAL(field_config, coarse_weight, "field.coarse_weight", 0, 1, 0, "1",
                    "masked matching after the first iteration: weight of the upsampled coarse "
                    "result against synthesized samples; 1 = equal (paper), 0 = ignored "
                    "(multi-resolution then does nothing)"),
    GS_CFG_KEY_BOOL(field_config, seed_blocks, "field.seed_blocks", "no",
                    "iteration 0 starts from random source blocks instead of random samples"),
    GS_CFG_KEY_BOOL(field_config, upper_bound, "field.upper_bound", "yes",
                    "queue pruning after iteration 0 (paper eq. 3's role): each search starts "
                    "bounded by the exact distance of the neighbour's match continued; same "
                    "result, fewer queue entries"),
    GS_CFG_KEY_REAL(field_config, copy_limit, "field.copy_limit", 0, 1, 0, "0",
                    "no piece copied verbatim from one source offset grows past this share of "
                    "the source (its bounding box): the search then excludes that offset's "
                    "continuation; 0 = off (the paper: large verbatim copies); 0.25 in terrain, texture, "
                    "balls and fibers.ini"),
    GS_CFG_KEY_INT(field_config, copy_limit_reach, "field.copy_limit_reach", 0, 8, 0, "0",
                   "copy_limit excludes the outgrown copy's continuation and the source blocks "
                   "within this many positions of it (each axis); 0 = block/4 (a copy shifted by "
                   "up to block/4 samples counts as the same copy); 1 in terrain.ini"),
    GS_CFG_KEY_INT(field_config, blend, "field.blend", 0, 4, 0, "0",
                   "seam blending after the last iteration: samples within this many of a seam "
                   "between pieces copied from different source offsets fade from one piece into "
                   "the other (overlap blending); 0 = off (the paper: the pieces meet in steps); 2 "
                   "where copy_limit is set"),
    GS_CFG_KEY_BOOL(field_config, seam_gradient, "field.seam_gradient", "no",
                    "after the blend, a gradient-domain (screened Poisson) correction spreads "
                    "what two pieces still disagree by across a seam over both pieces (decaying "
                    "over about a block), so the step across the seam is the pieces' own; no = "
                    "off (the paper)"),
    GS_CFG_KEY_ENUM(field_config, height_match, "field.height_match", "none|coarse|final|both", "none",
                    "height-map examples: the column heights of the coarse result (coarse: "
                    "before it guides the next iteration), of the last iteration's result "
                    "(final), or of both, mapped rank for rank onto the example's height "
                    "distribution at that level, each column shifted along z (histogram "
                    "matching); none = off (the paper); final in terrain.ini"),
    GS_CFG_KEY_INT(field_config, repeat_reach, "field.repeat_reach", 0, 15, 0, "0",
                   "in the last iteration a block may not take a source block within this many "
                   "positions (each axis) of the one a lower neighbour took (no source block "
                   "copied again a block stride on, e.g. a flat summit down a column); below "
                   "block/2, so a continuation stays allowed; 0 = off (the paper); 6 in "
                   "terrain.ini"),
    GS_CFG_KEY_INT(field_config, repeat_span, "field.repeat_span", 0, 16, 0, "0",
                   "with repeat_reach, in every iteration a block may not take a source block "
                   "within the level's reach (repeat_reach, halved per coarser level) of a "
                   "feature block (relief at or above the example's median, not a plain) taken "
                   "by the blocks up to this many positions away along each axis that are "
                   "matched before it (beyond the lower neighbours), while repeat_free of the "
                   "source stays free: no source feature copied again a few blocks on (a chain of "
                   "blocks falling into a cycle, stacked summits); 0 = off"),
    GS_CFG_KEY_INT(field_config, repeat_pairs, "field.repeat_pairs", 0, 15, 0, "0",
                   "in every iteration a block may not take, next to a lower neighbour, a "
                   "source block within this many positions (halved per coarser level) of the "
                   "one an earlier block took beside a neighbour in the same direction whose "
                   "source block lies within as many of that lower neighbour's: no two "
                   "neighbouring source blocks recur side by side (one place of the example "
                   "copied twice in the same arrangement of pieces), while repeat_free of the "
                   "source stays free; 0 = off; 2 in terrain.ini"),
    GS_CFG_KEY_REAL(field_config, repeat_free, "field.repeat_free", 0.05, 1, 0, "0.5",
                    "the share of the source blocks repeat_span and repeat_pairs leave free: "
                    "their exclusions, nearest first, stop before more would be excluded; 0.3 "
                    "in terrain.ini"),
    GS_CFG_KEY_BOOL(field_config, seam_cut, "field.seam_cut", "no",
                    "minimum-error boundary cut: each block takes the samples of its box that a "
                    "minimum cut between the synthesized overlap and the matched block gives it "
                    "(the seam follows where they agree, not the block grid); with target "
                    "regions the same at any rank count; no = off (the paper: a block fills "
                    "only unsynthesized samples)"),
    GS_CFG_KEY_BOOL(field_config, seam_columns, "field.seam_columns", "no",
                    "with seam_cut: the cut keeps every column (x, y) of a block whole, so a "
                    "height field's seams are vertical (no column assembled from two pieces at "
                    "different heights); yes in texture.ini; no = the 3D cut"),
    GS_CFG_KEY_BOOL(field_config, keep_volume, "field.keep_volume", "no",
                    "exact ties of a match (blocks equal where the query is known) go to the "
                    "blocks that bring the synthesized volume fraction toward the source's (the "
                    "most inside first while the output is short of it, else the fewest); the "
                    "match stays an exact best; with target regions a region reads the volume "
                    "of its own box and of the samples outside its colour's boxes (any rank "
                    "count gives one result); no = off (ties by the seeded order)"),
    GS_CFG_KEY_REAL(field_config, object_spacing, "field.object_spacing", 0, 2, 0, "0",
                    "for an example of separate objects (discs of a height field, balls): in "
                    "the last iteration a block may not take a source block that would put an "
                    "object's centre closer than this share of the source's smallest centre "
                    "spacing to an object already in the output (nearer than a quarter of it "
                    "counts as the same object continued); the match stays the exact best of "
                    "the other blocks; needs region_blocks = 0; 0 = off (the paper)"),
    GS_CFG_KEY_REAL(field_config, object_same, "field.object_same", 0.01, 0.99, 0, "0.25",
                    "with object_spacing: centres nearer than this share of the source's "
                    "smallest centre spacing count as the same object continued (a block may "
                    "put one there); farther ones, up to object_spacing, are excluded"),
    GS_CFG_KEY_BOOL(field_config, object_continue, "field.object_continue", "no",
                    "with object_spacing: a block whose unsynthesized samples an object of the "
                    "output reaches may only take a source block that continues it (puts one "
                    "of the source's objects within object_same of its centre), for every such "
                    "object at once, while a source block outside the other exclusions does "
                    "(else it is matched as without); without object_spacing off; no = off"),
    GS_CFG_KEY_ENUM(field_config, wrap, "field.wrap", "none|xy|xyz", "none",
                    "the example as a tile: source blocks wrap around its faces along these "
                    "axes, so every source sample lies in as many candidate blocks (without it a "
                    "sample within a block of a face lies in fewer, and an example's middle is "
                    "copied more often than its border); xy for a height map or texture whose "
                    "edges continue each other; none = off (the paper)"),
    GS_CFG_KEY_BOOL(field_config, complete_objects, "field.complete_objects", "no",
                    "after the last iteration, for an example of separate objects, every "
                    "object of the output (core component, deeper than one sample) is replaced "
                    "by the whole source object its samples were copied from, at that offset "
                    "(objects glued from pieces of several become whole); for long objects "
                    "(fibers) each fiber is rebuilt from whole source cross-sections, slab by "
                    "slab along it; no = off (the paper)"),
    GS_CFG_KEY_INT(field_config, region_blocks, "field.region_blocks", 0, 4096, 0, "4",
                   "target regions run in parallel on the ranks: block positions (stride "
                   "block/2) per region along each axis; 0 = one region; any value gives the "
                   "paper's raster-order result, for any rank count"),
    GS_CFG_KEY_ENUM(field_config, tree, "field.tree", "whole|sharded", "whole",
                    "search tree per rank: whole = every rank holds the whole tree and pyramid "
                    "(fastest, target regions in parallel); sharded = each rank holds a z-slab "
                    "of them, so memory per rank falls with the rank count, and every match is "
                    "searched by all ranks together; same output"),
    GS_CFG_KEY_ENUM(field_config, geometry, "output.geometry", "contour|copy|both|none", "contour",
                    "output mesh: contour of the field (OpenVDB), the source's surface copied "
                    "along the provenance onto it (paper 5.3), both, or none"),
    GS_CFG_KEY_ENUM(field_config, mesh_format, "output.mesh_format", "obj|ply", "ply",
                    "file format of output meshes"),
    GS_CFG_KEY_REAL(field_config, adaptivity, "output.adaptivity", 0, 1, 0, "0",
                    "contour mesh adaptivity (0 = uniform)"),
    GS_CFG_KEY_INT(field_config, relax, "output.relax", 0, 1000, 0, "10",
                   "copied geometry: Laplacian relaxation iterations of seam vertices"),
    GS_CFG_KEY_REAL(field_config, snap, "output.snap", 0, 2, 0, "0.5",
                    "copied geometry: how far (samples) a contour vertex may move onto the copied "
                    "source surface"),
    GS_CFG_KEY_BOOL(field_config, vdb, "output.vdb", "yes", "also write field.vdb"),
    GS_CFG_KEY_BOOL(field_config, preview, "output.preview", "yes",
                    "write RUN_DIR/preview.png: the source's contour and the output's contour "
                    "side by side (whatever output.geometry is)"),
    GS_CFG_RUN_KEYS(field_config, run, "field"),
};

const gs_cfg_table field_cfg_table =
    GS_CFG_TABLE("field", field_config, field_keys, validate_config);
