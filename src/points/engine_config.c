/* points' configuration: the key table (`geosynth points --help`) and its
 * validation. See engine_impl.h. */
#include "points/engine_impl.h"

#define PC points_config
static const gs_cfg_key points_keys[] = {
    GS_CFG_KEY_ENUM(PC, kind, "input.kind", "heightfield|chainmail|weave|flowers|ply|mesh",
                    "chainmail",
                    "example: a generated texture of the paper's kinds, an oriented point set "
                    "(ply) or a triangle mesh sampled uniformly (mesh)"),
    GS_CFG_KEY_PATH(PC, path, "input.path", "",
                    "ply: PLY with x y z nx ny nz; mesh: OBJ/PLY/STL/OFF; heightfield: "
                    "grey image (PNG/JPEG)"),
    GS_CFG_KEY_REAL_LIST(PC, size, "input.size", 0, 1e6, GS_CFG_OPEN_LO, "4, 4",
                         "generated examples: box extent along x and y"),
    GS_CFG_KEY_INT(PC, cells, "input.cells", 1, 64, 0, "4",
                   "generated examples: lattice cells (rings, threads, flower spacing) across x"),
    GS_CFG_KEY_BOOL(PC, periodic, "input.periodic", "false",
                    "chainmail/weave: rings and threads exactly on the lattice (a tileable "
                    "example); false = jittered off it with varying sizes, like the paper's"),
    GS_CFG_KEY_REAL(PC, spacing, "input.spacing", 0, 1e6, 0, "0.033",
                    "sampling spacing (Poisson-disk radius) of generated and mesh examples; "
                    "ply: 0 = estimate from the points"),
    GS_CFG_KEY_REAL(PC, height_scale, "input.height_scale", -1e6, 1e6, 0, "0.6",
                    "heightfield: height of a white pixel"),
    GS_CFG_KEY_REAL(PC, pad, "input.pad", 0, 1e6, 0, "0",
                    "generated examples: geometry beyond every side of the box (0 = 1.2 x what "
                    "the parameters need)"),
    GS_CFG_KEY_REAL_LIST(PC, box_lo, "input.box_lo", -1e300, 1e300, 0, "",
                         "ply/mesh: low corner x y z of the box B_Tin (geometry must continue "
                         "past its sides)"),
    GS_CFG_KEY_REAL_LIST(PC, box_hi, "input.box_hi", -1e300, 1e300, 0, "",
                         "ply/mesh: high corner x y z of the box B_Tin"),
    GS_CFG_KEY_ENUM(PC, up, "input.up", "x|y|z", "z",
                    "ply/mesh: axis normal to the reference plane (the texture's height axis)"),
    GS_CFG_KEY_INT(PC, input_seed, "input.seed", 0, GS_CFG_INT_MAX, 0, "2007",
                   "seed of the example's generation or mesh sampling (run.seed drives synthesis)"),
    GS_CFG_KEY_REAL_LIST(PC, out_size, "points.out_size", 0, 1e6, GS_CFG_OPEN_LO, "",
                         "output extent along the two plane axes (empty = from out_points, or "
                         "2 x the box)"),
    GS_CFG_KEY_REAL(PC, out_points, "points.out_points", 0, 1e9, 0, "0",
                    "wanted output points: scales the box so the output holds about this many "
                    "(0 = use out_size)"),
    GS_CFG_KEY_REAL(PC, field_step, "points.field_step", 0, 1e6, 0, "0",
                    "node spacing of the distance fields D (0 = max(1.5 spacing, box/40))"),
    GS_CFG_KEY_INT(PC, patch_cells, "points.patch_cells", 0, 1024, 0, "0",
                   "patch edge in field steps (0 = 0.4 x box side)"),
    GS_CFG_KEY_INT(PC, overlap_cells, "points.overlap_cells", 0, 1023, 0, "0",
                   "overlap strip width in field steps (0 = patch/4)"),
    GS_CFG_KEY_INT(PC, extra_cells, "points.extra_cells", 0, 1024, 0, "0",
                   "extra region w_E in field steps (0 = patch/4 rounded up)"),
    GS_CFG_KEY_REAL(PC, mls_radius, "points.mls_radius", 0, 1e6, 0, "0",
                    "radius of the MLS weights (0 = 3 spacing)"),
    GS_CFG_KEY_REAL(PC, trunc, "points.trunc", 0, 1e6, 0, "0",
                    "distance truncation of the fields (0 = 2 field steps)"),
    GS_CFG_KEY_REAL(PC, eps, "points.eps", 0, 100, 0, "0.1",
                    "candidate tolerance: patches within (1 + eps) x best are picked at random"),
    GS_CFG_KEY_REAL(PC, warp_margin, "points.warp_margin", 0, 1e6, 0, "0",
                    "extension of F_k before warping (0 = max(3 spacing, field step))"),
    GS_CFG_KEY_REAL(PC, w_p, "points.w_p", 0, 1e6, 0, "1", "pairing weight of positions (eq. 2)"),
    GS_CFG_KEY_REAL(PC, w_n, "points.w_n", 0, 1e6, 0, "1", "pairing weight of normals (table 1)"),
    GS_CFG_KEY_REAL(PC, w_v, "points.w_v", 0, 1e6, 0, "10",
                    "pairing weight of surface variation (table 1)"),
    GS_CFG_KEY_REAL(PC, w_l, "points.w_l", 0, 1e6, 0, "8", "pairing weight w_l (table 1)"),
    GS_CFG_KEY_REAL(PC, w_d, "points.w_d", 0, 1e6, 0, "6", "pairing weight w_d (table 1)"),
    GS_CFG_KEY_REAL(PC, max_pair_dist, "points.max_pair_dist", 0, 1e6, 0, "0",
                    "largest pair distance (0 = max(3 spacing, overlap/2))"),
    GS_CFG_KEY_REAL(PC, max_normal, "points.max_normal", 0, 1, 0, "0.5",
                    "largest normal difference (1 - n.n)/2 of a pair"),
    GS_CFG_KEY_REAL(PC, max_variation, "points.max_variation", 0, 1, 0, "0.1",
                    "largest surface-variation difference of a pair"),
    GS_CFG_KEY_REAL(PC, coherence_sigma, "points.coherence_sigma", 0, 1e6, 0, "0",
                    "width of the pairing coherence term (0 = overlap/2)"),
    GS_CFG_KEY_REAL(PC, variation_radius, "points.variation_radius", 0, 1e6, 0, "0",
                    "radius of the surface variation (0 = 2.5 spacing)"),
    GS_CFG_KEY_INT(PC, greedy_iterations, "points.greedy_iterations", 0, 100, 0, "3",
                   "greedy improvement passes of the pairing"),
    GS_CFG_KEY_INT(PC, cluster_max, "points.cluster_max", 1, 100000, 0, "12",
                   "points per cluster of the target set Q (at least)"),
    GS_CFG_KEY_INT(PC, max_pairs, "points.max_pairs", 4, 5000, 0, "48",
                   "clusters grow so |Q| stays near this (thin-plate spline size)"),
    GS_CFG_KEY_INT(PC, relax_iterations, "points.relax_iterations", 0, 100, 0, "1",
                   "relaxation passes over the output at the end"),
    GS_CFG_KEY_REAL(PC, tps_lambda, "points.tps_lambda", 0, 1e6, 0, "0",
                    "thin-plate spline smoothing (0 = interpolate)"),
    GS_CFG_KEY_REAL(PC, warp_fade, "points.warp_fade", 0, 2, 0, "0",
                    "the warp fades to none ((weight / this)^2) where the overlap strips' blend "
                    "weight falls below this, to 0 at their inner edge, so the patch's inside "
                    "keeps the example's shape (1: rings past the strips stay round, but fewer "
                    "seams close); whole objects (points.objects) move by the spline at their "
                    "centre unfaded; 0 = the spline everywhere (the paper's)"),
    GS_CFG_KEY_BOOL(PC, warp_height_bound, "points.warp_height_bound", "true",
                    "the warp lifts or lowers no point beyond the example's height range (a "
                    "point already beyond it keeps its own height as the bound); false = the "
                    "spline as it is (it put up to 190 points above the example's top per "
                    "chainmail run)"),
    GS_CFG_KEY_BOOL(PC, warp_select, "points.warp_select", "true",
                    "each patch takes the spline of the pairs, the spline of their normal parts, "
                    "or no warp, whichever leaves it closest to the output in the overlap "
                    "(false = always the pairs' spline, the paper's)"),
    GS_CFG_KEY_BOOL(PC, warp_select_seams, "points.warp_select_seams", "true",
                    "with warp_select: each of the three is blended and the one whose seams "
                    "with the output are best (distance and normal angle, each over no warp's; "
                    "a warp no worse than none in either, nor in open seam points) is "
                    "pasted; false = judged by the gap before the blend (the patch's blend "
                    "runs once, not three times)"),
    GS_CFG_KEY_PATH(PC, choices, "points.choices", "",
                    "patches.csv of an earlier run (output.patch_metrics) with the same example "
                    "and sizes: each patch takes the source patch that run chose (the search "
                    "still runs); with the warp or blend switched off it shows what they do on "
                    "the same patches (tests/bench/points_elements.sh); empty = search and pick"),
    GS_CFG_KEY_BOOL(PC, blend, "points.blend", "true",
                    "blend the overlap strips onto the output (paper section 5.3); false pastes "
                    "the warped patch as it is (to measure what the blend does)"),
    GS_CFG_KEY_BOOL(PC, ray_blend, "points.ray_blend", "true",
                    "blend by ray intersection (paper fig. 3d); false = projection"),
    GS_CFG_KEY_BOOL(PC, blend_resample, "points.blend_resample", "false",
                    "the blend adds points along the links of the patch's sheet it tears (fewer "
                    "specks: heightfield.ini 1.40 -> 1.19 per unit area without the clean-up "
                    "below, the example 0.99; seams' normal mismatch up 5-15%, curtains where a "
                    "crest tore); false = the paper's blend"),
    GS_CFG_KEY_BOOL(PC, blend_keep_outer, "points.blend_keep_outer", "false",
                    "the outer half of each overlap strip keeps the output's own points and the "
                    "patch blends over the inner half (no crest is pulled down where the strip "
                    "ends): seeds 1-3, specks per unit area without the clean-up below "
                    "heightfield.ini 1.40 -> 1.32 (the example 0.99), seams there a little worse "
                    "(open 0.095 -> 0.111); weave.ini seam dist ratio 1.58 -> 1.36, angle ratio "
                    "1.50 -> 1.26, open 0.145 -> 0.172; false = the paper's blend over the whole "
                    "strip"),
    GS_CFG_KEY_BOOL(PC, blend_fill, "points.blend_fill", "true",
                    "the output's own points in the overlap strips fill the holes the blend tore "
                    "in the pasted patch (each moved onto the pasted surface, kept a spacing from "
                    "every point and within 2 spacings of one): heightfield.ini seeds 1-3 specks "
                    "per unit area without the clean-up below 1.53, 1.26, 1.41 -> 1.14, 0.85, "
                    "0.83 (the example 0.99); false = the paper's blend"),
    GS_CFG_KEY_BOOL(PC, blend_implicit, "points.blend_implicit", "false",
                    "the overlap strips blend as the zero set of (1 - t) f_F + t f_N, continuous "
                    "signed distances to the patch and the output, so neighbouring points move "
                    "alike (no tear where a nearest-point target jumps): specks per unit area "
                    "without the clean-up below, heightfield.ini seeds 1-6 1.14, 0.85, 0.83, "
                    "0.92, 0.88, 0.85 -> 0.69, 0.63, 0.68, 0.72, 0.69, 0.61 (the example 0.99); "
                    "seams' normal mismatch up (angle ratio 0.67-0.73 -> 0.69-0.80); chainmail.ini "
                    "seed 1 worse (0.03 -> 0.17, the example 0); the blend about 5 x the "
                    "sheet blend's time at np 1 (heightfield.ini seed 1: 1.1-1.4 s -> 6.5 s), "
                    "its per-point solves spread over the ranks; "
                    "false = each point by its neighbours' targets on the output (the paper's)"),
    GS_CFG_KEY_BOOL(PC, drop_strip_specks, "points.drop_strip_specks", "true",
                    "drop pieces of fewer than 30 points lying wholly in the overlap strips "
                    "(or within 2 spacings outside their seam edge) after the synthesis (a safety "
                    "net, not the paper's; summary.json counts them); false keeps them (to "
                    "measure what the blend leaves)"),
    GS_CFG_KEY_BOOL(PC, strip_resample, "points.strip_resample", "true",
                    "after the synthesis, resample the overlap strips as dart throwing sampled "
                    "the example: a strip point off the surface of the others goes onto it "
                    "(one with no sheet of the others there is dropped), the points are kept "
                    "in a seeded order with no two within a spacing, and darts around the kept "
                    "ones (onto the degree-2 MLS surface, and only where the points sample "
                    "it, not past a crest or an edge) fill the holes up to the count the "
                    "blend left in each cell of 4 spacings, then past it around pieces of "
                    "fewer than 30 points; the points inside the patches stay. Seeds 1-3, "
                    "8 x 8, without the clean-up below: specks per unit area a ridged field "
                    "1.59, 1.77, 1.51 -> 0.10, 0.11, 0.13 (the example 0); chainmail.ini "
                    "seed 1 seam distance ratio 1.21 -> 1.21; points per unit area within "
                    "5% of the example's; 0.5-2 s more CPU; "
                    "false = the strips as the blend leaves them"),
    GS_CFG_KEY_BOOL(PC, objects, "points.objects", "true",
                    "paste the example's disconnected objects (flowers, rings: pieces no wider "
                    "than half a patch, whole in the example) whole or not at all, each by the "
                    "patch holding its centre; false = every point by its position (the paper: "
                    "objects cut at the seams)"),
    GS_CFG_KEY_BOOL(PC, write_points, "output.points", "true", "write RUN_DIR/points.ply"),
    GS_CFG_KEY_ENUM(PC, ply_format, "output.ply_format", "binary|ascii", "binary",
                    "points.ply encoding (both exact: doubles / 17 digits)"),
    GS_CFG_KEY_BOOL(PC, patch_csv, "output.patch_metrics", "true",
                    "write RUN_DIR/patches.csv (per-patch search distance, warp residual, ...)"),
    GS_CFG_KEY_INT(PC, example_seam_shifts, "output.example_seam_shifts", 0, 1024, 0, "1",
                   "the example's seam measure (summary.json example_patch_seam_*): 1 = the "
                   "example cut once by lines as far apart as the output's seams; N > 1 also "
                   "pools N cuts shifted by even steps within a patch step, 0 every field step "
                   "(example_patch_seam_*_shifted: the measure's level with no seam wherever "
                   "the output's seams fall; N times the cost)"),
    GS_CFG_KEY_BOOL(PC, mesh, "output.mesh", "false",
                    "also write RUN_DIR/mesh.ply (points -> implicit grid -> OpenVDB mesh)"),
    GS_CFG_KEY_BOOL(PC, preview, "output.preview", "true",
                    "write RUN_DIR/preview.png: the example and the output (up to twice the "
                    "example's extent) meshed and rendered side by side"),
    GS_CFG_KEY_REAL(PC, mesh_voxel, "output.mesh_voxel", 0.1, 100, 0, "1",
                    "mesh grid voxel in units of the input spacing"),
    GS_CFG_KEY_REAL(PC, mesh_max_samples, "output.mesh_max_samples", 1e3, 4e9, 0, "2e8",
                    "refuse a mesh grid with more samples than this (4 bytes each + 16 scratch)"),
    GS_CFG_RUN_KEYS(PC, run, "points"),
};
#undef PC

static void points_validate(const void *vcfg, gs_cfg_ctx *ctx)
{
    const points_config *c = vcfg;
    int user = kind_is_user(c);
    if ((user || kind_is(c, "heightfield")) && !c->path[0])
        gs_cfg_report(ctx, "input.path", "is required for input.kind = %s", c->kind);
    if (user) {
        if (c->box_lo.n != 3)
            gs_cfg_report(ctx, "input.box_lo", "needs 3 numbers (x y z) for input.kind = %s, got %lld",
                          c->kind, (long long)c->box_lo.n);
        if (c->box_hi.n != 3)
            gs_cfg_report(ctx, "input.box_hi", "needs 3 numbers (x y z) for input.kind = %s, got %lld",
                          c->kind, (long long)c->box_hi.n);
        if (c->box_lo.n == 3 && c->box_hi.n == 3)
            for (int a = 0; a < 3; a++)
                if (!(c->box_hi.v[a] > c->box_lo.v[a]) && !(a == (c->up[0] - 'x') &&
                                                             c->box_hi.v[a] >= c->box_lo.v[a]))
                    gs_cfg_report(ctx, "input.box_hi", "must exceed input.box_lo on axis %c "
                                  "(%g <= %g)", 'x' + a, c->box_hi.v[a], c->box_lo.v[a]);
    } else {
        if (c->size.n != 2)
            gs_cfg_report(ctx, "input.size", "needs 2 numbers (x y), got %lld", (long long)c->size.n);
        if (c->spacing <= 0)
            gs_cfg_report(ctx, "input.spacing", "must be > 0 for generated examples");
    }
    if (kind_is(c, "mesh") && c->spacing <= 0)
        gs_cfg_report(ctx, "input.spacing", "must be > 0 to sample a mesh");
    if (c->out_size.n != 0 && c->out_size.n != 2)
        gs_cfg_report(ctx, "points.out_size", "needs 2 numbers or none, got %lld",
                      (long long)c->out_size.n);
    if (c->out_size.n && c->out_points > 0)
        gs_cfg_report(ctx, "points.out_points", "and points.out_size both set: give one of them");
    if (c->patch_cells && c->overlap_cells && c->overlap_cells >= c->patch_cells)
        gs_cfg_report(ctx, "points.overlap_cells", "must be below points.patch_cells = %lld",
                      (long long)c->patch_cells);
    if (c->patch_cells && c->patch_cells < 3)
        gs_cfg_report(ctx, "points.patch_cells", "must be 0 (auto) or >= 3");
}

const gs_cfg_table points_cfg_table =
    GS_CFG_TABLE("points", points_config, points_keys, points_validate);
