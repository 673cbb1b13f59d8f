// The one C++ file: every OpenVDB include lives here, behind extern "C".
// It is the plugin geosynth-vdb.so (include/geosynth/plugin.h): entry point
// gs_vdbp_X implements gs_vdb_X of include/geosynth/vdb.h, which src/io/vdb.c
// forwards here. Every entry point wraps its body in GS_VDB_GUARD so no C++
// exception crosses into C.
// Imath half conversions without the lookup table: the table lives in
// libImath, which is not on the link line (only libopenvdb is).
#define IMATH_HALF_NO_LOOKUP_TABLE
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>

// error.h and mem.h are plain C headers without extern "C" guards.
#include "geosynth/error.h"
#include "geosynth/mem.h"
#include "geosynth/vdb.h"
#include "plugins/plugin_api.h"

struct gs_vdb_grid {
    openvdb::FloatGrid::Ptr grid;
    std::string name; // getName() returns a copy; gs_vdb_grid_name hands out this one
};

namespace {

std::once_flag vdb_once;

// Threads per rank: OpenVDB's TBB pool would otherwise take every core of the
// node on every rank. GS_THREADS (or OMP_NUM_THREADS, which the job scripts in
// jobs/ set from SLURM_CPUS_PER_TASK) caps it; unset = TBB's default.
int threads_from_env()
{
    for (const char *name : {"GS_THREADS", "OMP_NUM_THREADS"}) {
        const char *v = std::getenv(name);
        if (v && *v) {
            long n = std::strtol(v, nullptr, 10);
            if (n >= 1 && n <= 4096)
                return (int)n;
        }
    }
    return 0;
}

void vdb_init()
{
    std::call_once(vdb_once, [] {
        openvdb::initialize();
        int n = threads_from_env();
        if (n > 0) // lives until exit, like the pool it limits
            new tbb::global_control(tbb::global_control::max_allowed_parallelism, (size_t)n);
    });
}

// Converts the exception in flight into a raised gs_err.
gs_err raise_current(const char *func, const char *what)
{
    try {
        throw;
    } catch (const openvdb::IoError &e) {
        return gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, func, "%s: OpenVDB I/O: %s", what,
                              e.what());
    } catch (const std::bad_alloc &) {
        return gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, func,
                              "%s: out of memory inside OpenVDB", what);
    } catch (const std::exception &e) {
        return gs_error_raise(GS_ERR_LIB, __FILE__, __LINE__, func, "%s: OpenVDB: %s", what,
                              e.what());
    } catch (...) {
        return gs_error_raise(GS_ERR_LIB, __FILE__, __LINE__, func,
                              "%s: unknown C++ exception in OpenVDB", what);
    }
}

#define GS_VDB_GUARD(what, ...)                                                             \
    do {                                                                                      \
        try {                                                                                 \
            vdb_init();                                                                       \
            __VA_ARGS__                                                                       \
        } catch (...) {                                                                       \
            return raise_current(__func__, (what));                                           \
        }                                                                                     \
    } while (0)

using DenseXYZ = openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ>;

openvdb::math::Transform::Ptr make_transform(double voxel, const double origin[3])
{
    auto xf = openvdb::math::Transform::createLinearTransform(voxel);
    xf->postTranslate(openvdb::Vec3d(origin[0], origin[1], origin[2]));
    return xf;
}

openvdb::CoordBBox dense_bbox(const gs_vdb_dense *d)
{
    return openvdb::CoordBBox(openvdb::Coord(0, 0, 0),
                              openvdb::Coord((int)d->nx - 1, (int)d->ny - 1, (int)d->nz - 1));
}

gs_err check_dense(const gs_vdb_dense *d, const char *what)
{
    GS_CHECK(d && d->v, GS_ERR_ARG, "%s: dense field has no data", what);
    GS_CHECK(d->nx >= 1 && d->ny >= 1 && d->nz >= 1 && d->nx <= INT32_MAX && d->ny <= INT32_MAX &&
                 d->nz <= INT32_MAX,
             GS_ERR_ARG, "%s: dense field of %zux%zux%zu samples: expected sizes in [1, 2^31)",
             what, d->nx, d->ny, d->nz);
    GS_CHECK(std::isfinite(d->voxel) && d->voxel > 0, GS_ERR_ARG,
             "%s: voxel size %g: expected a finite value > 0", what, d->voxel);
    for (int k = 0; k < 3; k++)
        GS_CHECK(std::isfinite(d->origin[k]), GS_ERR_ARG, "%s: origin is not finite", what);
    return GS_OK;
}

// What users' tools cannot guess: the up axis and the units (docs/FORMATS.md).
void axis_meta(openvdb::GridBase &g)
{
    g.insertMeta("up_axis", openvdb::StringMetadata("z"));
    g.insertMeta("units", openvdb::StringMetadata("world units: the example's (voxel size = sample spacing)"));
}

// Grid over the dense box, stored box in metadata.
openvdb::FloatGrid::Ptr grid_from_dense(const gs_vdb_dense *d, float tolerance)
{
    auto grid = openvdb::FloatGrid::create(d->background);
    grid->setTransform(make_transform(d->voxel, d->origin));
    DenseXYZ dense(dense_bbox(d), d->v);
    openvdb::tools::copyFromDense(dense, *grid, tolerance);
    grid->insertMeta("gs_dense_min", openvdb::Vec3IMetadata(openvdb::Vec3i(0, 0, 0)));
    grid->insertMeta("gs_dense_max", openvdb::Vec3IMetadata(openvdb::Vec3i(
                                         (int)d->nx - 1, (int)d->ny - 1, (int)d->nz - 1)));
    axis_meta(*grid);
    return grid;
}

// serial: no TBB (the reader runs in a forked child, src/io/vdb.c, where a
// pool the parent started has no threads).
gs_err dense_from_grid(const openvdb::FloatGrid &grid, const char *what, gs_vdb_dense *out,
                       bool serial = false)
{
    const openvdb::math::Transform &xf = grid.transform();
    openvdb::Vec3d vs = xf.voxelSize();
    const auto &mt = xf.mapType();
    namespace vm = openvdb::math;
    bool axis_aligned = mt == vm::UniformScaleMap::mapType() ||
                        mt == vm::UniformScaleTranslateMap::mapType() ||
                        mt == vm::ScaleMap::mapType() || mt == vm::ScaleTranslateMap::mapType() ||
                        mt == vm::TranslationMap::mapType();
    GS_CHECK(axis_aligned &&
                 std::fabs(vs[0] - vs[1]) <= 1e-9 * vs[0] &&
                 std::fabs(vs[0] - vs[2]) <= 1e-9 * vs[0],
             GS_ERR_FORMAT,
             "%s: grid '%s' has a %s transform with voxel size %g x %g x %g: expected a "
             "uniform axis-aligned linear transform",
             what, grid.getName().c_str(), xf.mapType().c_str(), vs[0], vs[1], vs[2]);
    openvdb::CoordBBox box;
    auto mn = grid.getMetadata<openvdb::Vec3IMetadata>("gs_dense_min");
    auto mx = grid.getMetadata<openvdb::Vec3IMetadata>("gs_dense_max");
    if (mn && mx) {
        box = openvdb::CoordBBox(openvdb::Coord(mn->value()), openvdb::Coord(mx->value()));
    } else if (serial) {
        for (auto it = grid.cbeginValueOn(); it; ++it)
            box.expand(it.getBoundingBox());
    } else {
        box = grid.evalActiveVoxelBoundingBox();
    }
    GS_CHECK(!box.empty(), GS_ERR_FORMAT, "%s: grid '%s' has no active voxels", what,
             grid.getName().c_str());
    openvdb::Coord dim = box.dim();
    GS_CALL(gs_vdb_dense_alloc(out, (size_t)dim.x(), (size_t)dim.y(), (size_t)dim.z()));
    openvdb::Vec3d o = xf.indexToWorld(box.min());
    out->origin[0] = o[0];
    out->origin[1] = o[1];
    out->origin[2] = o[2];
    out->voxel = vs[0];
    out->background = grid.background();
    DenseXYZ dense(box, out->v);
    openvdb::tools::copyToDense(grid, dense, serial);
    return GS_OK;
}

} // namespace

extern "C" const char *gs_vdbp_library_version(void) { return openvdb::getLibraryVersionString(); }

extern "C" gs_err gs_vdbp_grid_from_dense(const gs_vdb_dense *d, const char *name, float tolerance,
                                         gs_vdb_grid_t *out)
{
    GS_CALL(check_dense(d, name ? name : "grid"));
    GS_VDB_GUARD(name ? name : "grid", {
        auto g = grid_from_dense(d, tolerance);
        g->setName(name ? name : "");
        *out = new gs_vdb_grid{g, g->getName()};
        return GS_OK;
    });
}

extern "C" gs_err gs_vdbp_grid_to_dense(gs_vdb_grid_t g, gs_vdb_dense *out)
{
    GS_CHECK(g && g->grid, GS_ERR_ARG, "no grid");
    GS_VDB_GUARD(g->name.c_str(), {
        GS_CALL(dense_from_grid(*g->grid, "grid", out));
        return GS_OK;
    });
}

extern "C" void gs_vdbp_grid_destroy(gs_vdb_grid_t *g)
{
    if (g && *g) {
        delete *g;
        *g = nullptr;
    }
}

extern "C" const char *gs_vdbp_grid_name(gs_vdb_grid_t g)
{
    return g ? g->name.c_str() : "";
}

extern "C" size_t gs_vdbp_grid_active_voxels(gs_vdb_grid_t g)
{
    return g && g->grid ? (size_t)g->grid->activeVoxelCount() : 0;
}

extern "C" gs_err gs_vdbp_write(const char *path, const gs_vdb_grid_t *grids, int n)
{
    GS_CHECK(path && path[0], GS_ERR_ARG, "vdb output path is empty");
    GS_CHECK(n >= 1 && grids, GS_ERR_ARG, "%s: no grid to write", path);
    for (int i = 0; i < n; i++)
        GS_CHECK(grids[i] && grids[i]->grid, GS_ERR_ARG, "%s: grid %d is missing", path, i);
    std::string tmp = std::string(path) + ".tmp";
    GS_VDB_GUARD(path, {
        openvdb::GridPtrVec vec;
        for (int i = 0; i < n; i++)
            vec.push_back(grids[i]->grid);
        try {
            openvdb::io::File file(tmp);
            file.write(vec);
            file.close();
        } catch (...) {
            std::remove(tmp.c_str());
            throw;
        }
        if (std::rename(tmp.c_str(), path) != 0) {
            int e = errno;
            std::remove(tmp.c_str());
            GS_RAISE(GS_ERR_IO, "%s: cannot rename temporary file into place: %s", path,
                     std::strerror(e));
        }
        return GS_OK;
    });
}

extern "C" gs_err gs_vdbp_read(const char *path, const char *name, gs_vdb_grid_t *out)
{
    GS_CHECK(path && path[0], GS_ERR_ARG, "vdb path is empty");
    FILE *f = std::fopen(path, "rb");
    GS_CHECK(f, GS_ERR_IO, "%s: cannot open VDB file: %s", path, std::strerror(errno));
    std::fclose(f);
    GS_VDB_GUARD(path, {
        openvdb::io::File file(path);
        file.open();
        auto metas = file.readAllGridMetadata();
        std::string avail, pick;
        bool level_set = false;
        for (const auto &m : *metas) {
            avail += (avail.empty() ? "" : ", ") + std::string("'") + m->getName() + "' (" +
                     m->type() + ")";
            bool is_float = m->type() == openvdb::FloatGrid::gridType();
            if (pick.empty() && is_float && (!name || m->getName() == name))
                pick = m->getName();
            // unnamed: a level set before any other float grid (geosynth's field.vdb also
            // holds the fog volume "density", which is no distance)
            if (!name && is_float && !level_set && m->getGridClass() == openvdb::GRID_LEVEL_SET) {
                pick = m->getName();
                level_set = true;
            }
            if (name && m->getName() == name && !is_float) {
                file.close();
                GS_RAISE(GS_ERR_FORMAT, "%s: grid '%s' is a %s: expected a float grid", path,
                         name, m->type().c_str());
            }
        }
        if (pick.empty()) {
            file.close();
            if (name)
                GS_RAISE(GS_ERR_ARG, "%s: no grid named '%s'; the file holds: %s", path, name,
                         avail.empty() ? "no grids" : avail.c_str());
            GS_RAISE(GS_ERR_FORMAT, "%s: no float grid; the file holds: %s", path,
                     avail.empty() ? "no grids" : avail.c_str());
        }
        auto base = file.readGrid(pick);
        file.close();
        auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
        GS_CHECK(grid, GS_ERR_FORMAT, "%s: grid '%s' is not a float grid", path, pick.c_str());
        *out = new gs_vdb_grid{grid, grid->getName()};
        return GS_OK;
    });
}

extern "C" gs_err gs_vdbp_write_dense(const char *path, const char *name, const gs_vdb_dense *d)
{
    gs_vdb_grid_t g = nullptr;
    GS_CALL(gs_vdbp_grid_from_dense(d, name, 0.0f, &g));
    gs_err err = gs_vdbp_write(path, &g, 1);
    gs_vdbp_grid_destroy(&g);
    GS_CALL(err);
    return GS_OK;
}

extern "C" gs_err gs_vdbp_read_dense(const char *path, const char *name, gs_vdb_dense *out)
{
    std::memset(out, 0, sizeof *out);
    gs_vdb_grid_t g = nullptr;
    GS_CALL(gs_vdbp_read(path, name, &g));
    gs_err err = GS_OK;
    try {
        err = dense_from_grid(*g->grid, path, out, true);
    } catch (...) {
        err = raise_current(__func__, path);
    }
    gs_vdbp_grid_destroy(&g);
    GS_CALL(err);
    return GS_OK;
}

namespace {

// Upper bound of the distance from any point of the box [lo, hi] to the
// mesh: distance to a vertex subset bounds the distance to the surface from
// above, measured on a coarse lattice and widened by the lattice half-diagonal
// (distance is 1-Lipschitz).
double max_distance_bound(const gs_mesh *m, const double lo[3], const double hi[3])
{
    const int c = 12;
    size_t stride = m->nverts > 2048 ? m->nverts / 2048 : 1;
    double step[3], maxd = 0;
    for (int k = 0; k < 3; k++)
        step[k] = (hi[k] - lo[k]) / (c - 1);
    for (int iz = 0; iz < c; iz++)
        for (int iy = 0; iy < c; iy++)
            for (int ix = 0; ix < c; ix++) {
                double p[3] = {lo[0] + ix * step[0], lo[1] + iy * step[1], lo[2] + iz * step[2]};
                double best = HUGE_VAL;
                for (size_t i = 0; i < m->nverts; i += stride) {
                    const float *v = m->pos + 3 * i;
                    double dx = v[0] - p[0], dy = v[1] - p[1], dz = v[2] - p[2];
                    best = std::min(best, dx * dx + dy * dy + dz * dz);
                }
                maxd = std::max(maxd, best);
            }
    double half = 0.5 * std::sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]);
    return std::sqrt(maxd) + half;
}

} // namespace

extern "C" gs_err gs_vdbp_mesh_to_distance(const gs_mesh *m, const char *what,
                                          const gs_vdb_distance_opts *opts, gs_vdb_dense *out)
{
    const char *w = what ? what : "mesh";
    std::memset(out, 0, sizeof *out);
    GS_CHECK(opts && opts->samples >= 4 && opts->samples <= 4096, GS_ERR_ARG,
             "%s: distance field resolution %d: expected samples along the longest axis in "
             "[4, 4096]",
             w, opts ? opts->samples : 0);
    GS_CHECK(std::isfinite(opts->margin), GS_ERR_ARG, "%s: margin is not finite", w);
    GS_CALL(gs_mesh_validate(m, w));
    GS_CHECK(m->ntris > 0, GS_ERR_ARG, "%s: mesh has no triangles", w);
    if (opts->is_signed)
        GS_CALL(gs_mesh_require_closed(m, w, "signed distance field"));
    float flo[3], fhi[3];
    gs_mesh_bbox(m, flo, fhi);
    double longest = 0;
    for (int k = 0; k < 3; k++)
        longest = std::max(longest, (double)fhi[k] - flo[k]);
    GS_CHECK(longest > 0, GS_ERR_ARG, "%s: mesh bounding box is a single point", w);
    double margin = opts->margin < 0 ? 0.1 * longest : opts->margin;
    double voxel = (longest + 2 * margin) / (opts->samples - 1);
    size_t n[3];
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        lo[k] = flo[k] - margin;
        double ext = (double)fhi[k] - flo[k] + 2 * margin;
        n[k] = (size_t)std::ceil(ext / voxel - 1e-9) + 1;
        n[k] = std::max<size_t>(n[k], 2);
        hi[k] = lo[k] + (n[k] - 1) * voxel;
    }
    GS_CALL(gs_vdb_dense_alloc(out, n[0], n[1], n[2]));
    for (int k = 0; k < 3; k++)
        out->origin[k] = lo[k];
    out->voxel = voxel;
    double bound = max_distance_bound(m, lo, hi);
    float band = (float)(std::ceil(bound / voxel) + 3.0);
    try {
        vdb_init();
        auto xf = make_transform(voxel, lo);
        std::vector<openvdb::Vec3s> pts(m->nverts);
        for (size_t i = 0; i < m->nverts; i++)
            pts[i] = openvdb::Vec3s(m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]);
        std::vector<openvdb::Vec3I> tris(m->ntris);
        for (size_t t = 0; t < m->ntris; t++)
            tris[t] = openvdb::Vec3I(m->tris[3 * t], m->tris[3 * t + 1], m->tris[3 * t + 2]);
        std::vector<openvdb::Vec4I> quads;
        openvdb::FloatGrid::Ptr grid;
        if (opts->is_signed)
            grid = openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(*xf, pts, tris,
                                                                                 quads, band, band);
        else
            grid = openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(*xf, pts, tris,
                                                                                   quads, band);
        out->background = grid->background();
        DenseXYZ dense(dense_bbox(out), out->v);
        openvdb::tools::copyToDense(*grid, dense);
    } catch (...) {
        gs_err e = raise_current(__func__, w);
        gs_vdb_dense_destroy(out);
        return e;
    }
    size_t clamped = 0, total = n[0] * n[1] * n[2];
    float limit = std::fabs(out->background) * (1.0f - 1e-6f);
    for (size_t i = 0; i < total; i++)
        clamped += std::fabs(out->v[i]) >= limit;
    if (clamped) {
        gs_vdb_dense_destroy(out);
        GS_RAISE(GS_ERR_INTERNAL,
                 "%s: %zu of %zu distance samples are clamped at the band limit %g (band %g "
                 "voxels, bound %g)",
                 w, clamped, total, (double)limit, (double)band, bound);
    }
    return GS_OK;
}

extern "C" gs_err gs_vdbp_dense_to_mesh(const gs_vdb_dense *d, double isovalue, double adaptivity,
                                       gs_mesh *out)
{
    std::memset(out, 0, sizeof *out);
    GS_CALL(check_dense(d, "dense field"));
    GS_CHECK(std::isfinite(isovalue) && adaptivity >= 0 && adaptivity <= 1, GS_ERR_ARG,
             "isovalue %g / adaptivity %g: expected a finite isovalue and adaptivity in [0, 1]",
             isovalue, adaptivity);
    std::vector<openvdb::Vec3s> pts;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    GS_VDB_GUARD("volume to mesh", {
        auto grid = grid_from_dense(d, -1.0f); // every sample active
        openvdb::tools::volumeToMesh(*grid, pts, tris, quads, isovalue, adaptivity);
    });
    size_t nt = tris.size() + 2 * quads.size();
    GS_CALL(gs_mesh_alloc(out, pts.size(), nt, 0));
    for (size_t i = 0; i < pts.size(); i++)
        for (int k = 0; k < 3; k++)
            out->pos[3 * i + k] = pts[i][k];
    // OpenVDB winds polygons with normals towards larger values (outward for
    // a level set; tests/unit/test_vdb.c checks the enclosed volume is
    // positive). Quads are split along their shorter diagonal.
    size_t t = 0;
    auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
        out->tris[3 * t] = a;
        out->tris[3 * t + 1] = b;
        out->tris[3 * t + 2] = c;
        t++;
    };
    for (const auto &tr : tris)
        emit(tr[0], tr[1], tr[2]);
    for (const auto &q : quads) {
        double d02 = (pts[q[0]] - pts[q[2]]).lengthSqr(), d13 = (pts[q[1]] - pts[q[3]]).lengthSqr();
        if (d02 <= d13) {
            emit(q[0], q[1], q[2]);
            emit(q[0], q[2], q[3]);
        } else {
            emit(q[0], q[1], q[3]);
            emit(q[1], q[2], q[3]);
        }
    }
    return GS_OK;
}

// Redistancing's distances: the exact distance from every sample within
// half_width voxels of the zero surface to that surface as a triangle mesh
// (OpenVDB volumeToMesh at iso 0, adaptivity 0: what levelSetRebuild meshes
// and what contour.ply is made of), found without mesh-to-volume:
//  - seeds: every triangle gives its exact distance (closest point on the
//    triangle) to the samples of its bounding box (rounded outward);
//  - layers: then ceil(half_width) + 1 times, every sample next to one that
//    changed in the last layer (26 neighbours) tries the triangles those
//    took, all at once (each layer reads the previous one's), keeping the
//    nearest; a sphere around each triangle spares most exact distances.
// Against a brute-force distance to every triangle it is within 0.05 voxels
// (tests/unit/test_vdb.c), OpenVDB's levelSetRebuild 0.38, at about a third
// of its CPU.
// Ties between triangles go to the smaller vertex coordinates, not to the
// triangle's number, so the result depends on the mesh's geometry alone,
// not on its order: with a fixed number of layers a sample's value depends
// only on the triangles and samples within redist_reach() voxels of it, which
// is what lets gs_vdbp_redistance compute a window of the field and give the
// same values for any split of the planes. Samples are in the box's own
// index space (the grid's, no world transform), distances in voxels.
namespace {

struct redist_tri {
    float p[9]; // the three vertices, in the order the mesh gives them
    float c[3], r; // a sphere around them (centroid, radius plus a margin)
};

// Squared distance from point q to triangle t (Ericson, Real-Time Collision
// Detection 5.1.5: the Voronoi region of the closest feature), in double.
double tri_dist2(const redist_tri &t, const double q[3])
{
    double a[3], b[3], c[3], ab[3], ac[3], ap[3];
    for (int k = 0; k < 3; k++) {
        a[k] = t.p[k], b[k] = t.p[3 + k], c[k] = t.p[6 + k];
        ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = q[k] - a[k];
    }
    auto dot = [](const double *u, const double *v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
    auto d2to = [&](const double *p) {
        double e0 = q[0] - p[0], e1 = q[1] - p[1], e2 = q[2] - p[2];
        return e0 * e0 + e1 * e1 + e2 * e2;
    };
    double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0)
        return d2to(a);
    double bp[3] = {q[0] - b[0], q[1] - b[1], q[2] - b[2]};
    double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3)
        return d2to(b);
    double vc = d1 * d4 - d3 * d2, r[3];
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 / (d1 - d3);
        for (int k = 0; k < 3; k++) r[k] = a[k] + v * ab[k];
        return d2to(r);
    }
    double cp[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]};
    double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6)
        return d2to(c);
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double w = d2 / (d2 - d6);
        for (int k = 0; k < 3; k++) r[k] = a[k] + w * ac[k];
        return d2to(r);
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int k = 0; k < 3; k++) r[k] = b[k] + w * (c[k] - b[k]);
        return d2to(r);
    }
    double den = 1 / (va + vb + vc), v = vb * den, w = vc * den;
    for (int k = 0; k < 3; k++) r[k] = a[k] + ab[k] * v + ac[k] * w;
    return d2to(r);
}

// Whether triangle t is surely farther from q than sqrt(d2): q is farther
// from the sphere around t (the cheap test that spares most exact distances).
bool far_from(const redist_tri &t, const double q[3], float d2)
{
    double e0 = q[0] - t.c[0], e1 = q[1] - t.c[1], e2 = q[2] - t.c[2];
    double b = t.r + std::sqrt((double)d2);
    return e0 * e0 + e1 * e1 + e2 * e2 > b * b;
}

// Triangle t before u in the tie order (vertex coordinates, lexicographic).
bool tri_before(const redist_tri &t, const redist_tri &u)
{
    return std::lexicographical_compare(t.p, t.p + 9, u.p, u.p + 9);
}

// Layers of the propagation for a band of half_width voxels, and the reach
// of one sample's value (the seeds' voxel, the layers, a cell of the mesh).
int redist_layers(double half_width)
{
    return (int)std::ceil(half_width) + 1;
}
int redist_reach(double half_width)
{
    return 1 + redist_layers(half_width) + 2;
}

// The distances in voxels (at most half_width, half_width where no
// triangle came within reach) of the n[0] x n[1] x n[2] samples at index
// (x, y, z) + lo (x fastest) to the triangles tris (index space), into dist.
void mesh_band_distance(const std::vector<redist_tri> &tris, const int64_t lo[3], const size_t n[3],
                        double half_width, float *dist)
{
    const size_t sy = n[0], sz = n[0] * n[1], total = sz * n[2];
    const uint32_t none = UINT32_MAX;
    std::vector<uint32_t> best(total, none);
    std::vector<float> bd2(total, INFINITY); // squared distance to best
    auto offer = [&](size_t i, uint32_t t, const double q[3]) -> bool {
        if (far_from(tris[t], q, bd2[i]))
            return false;
        float e = (float)tri_dist2(tris[t], q);
        uint32_t b = best[i];
        if (e < bd2[i] || (e == bd2[i] && b != none && b != t && tri_before(tris[t], tris[b]))) {
            best[i] = t, bd2[i] = e;
            return true;
        }
        return false;
    };
    // seeds
    std::vector<uint8_t> mark(total, 0); // 1: changed in the last layer
    for (uint32_t t = 0; t < (uint32_t)tris.size(); t++) {
        int64_t b0[3], b1[3];
        for (int k = 0; k < 3; k++) {
            float mn = std::min({tris[t].p[k], tris[t].p[3 + k], tris[t].p[6 + k]});
            float mx = std::max({tris[t].p[k], tris[t].p[3 + k], tris[t].p[6 + k]});
            b0[k] = std::max<int64_t>((int64_t)std::floor(mn) - lo[k], 0);
            b1[k] = std::min<int64_t>((int64_t)std::ceil(mx) - lo[k], (int64_t)n[k] - 1);
        }
        for (int64_t z = b0[2]; z <= b1[2]; z++)
            for (int64_t y = b0[1]; y <= b1[1]; y++)
                for (int64_t x = b0[0]; x <= b1[0]; x++) {
                    double q[3] = {(double)(x + lo[0]), (double)(y + lo[1]), (double)(z + lo[2])};
                    size_t i = (size_t)x + sy * (size_t)y + sz * (size_t)z;
                    if (offer(i, t, q))
                        mark[i] = 1;
                }
    }
    std::vector<uint32_t> changed;
    for (size_t i = 0; i < total; i++)
        if (mark[i])
            changed.push_back((uint32_t)i);
    // layers: the samples next to one that changed in the last layer, each
    // against the triangles those took (the others' it has tried before)
    const float cut = (float)(half_width * half_width);
    // f(j) for every sample j of the 3x3x3 block around sample i (i itself
    // included) that lies inside the box, z, then y, then x ascending
    auto each_neighbour = [&](size_t i, auto &&f) {
        const size_t x = i % sy, y = (i / sy) % n[1], z = i / sz;
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    if ((dx < 0 && x == 0) || (dx > 0 && x + 1 == n[0]) || (dy < 0 && y == 0) ||
                        (dy > 0 && y + 1 == n[1]) || (dz < 0 && z == 0) || (dz > 0 && z + 1 == n[2]))
                        continue;
                    f(i + (size_t)((int64_t)dx + (int64_t)sy * dy + (int64_t)sz * dz));
                }
    };
    std::vector<uint32_t> todo;
    struct redist_upd {
        uint32_t i, t;
        float e;
    };
    std::vector<redist_upd> upd;
    std::fill(mark.begin(), mark.end(), 0);
    for (int layer = 0; layer < redist_layers(half_width) && !changed.empty(); layer++) {
        todo.clear();
        for (size_t i : changed) {
            if (bd2[i] >= cut)
                continue; // beyond the band: carries nothing in
            mark[i] |= 2; // a carrier
            each_neighbour(i, [&](size_t j) {
                if (!(mark[j] & 1)) {
                    mark[j] |= 1;
                    todo.push_back((uint32_t)j);
                }
            });
        }
        upd.clear();
        for (size_t j : todo) {
            size_t x = j % sy, y = (j / sy) % n[1], z = j / sz;
            double q[3] = {(double)((int64_t)x + lo[0]), (double)((int64_t)y + lo[1]),
                           (double)((int64_t)z + lo[2])};
            uint32_t own = best[j], tb = own;
            float eb = bd2[j];
            uint32_t seen[27];
            int ns = 0;
            each_neighbour(j, [&](size_t k) {
                if (!(mark[k] & 2))
                    return;
                uint32_t t = best[k];
                if (t == own)
                    return;
                for (int s = 0; s < ns; s++)
                    if (seen[s] == t)
                        return;
                seen[ns++] = t;
                if (far_from(tris[t], q, eb))
                    return;
                float e = (float)tri_dist2(tris[t], q);
                if (e < eb || (e == eb && tb != none && tri_before(tris[t], tris[tb])))
                    tb = t, eb = e;
            });
            if (tb != own)
                upd.push_back({(uint32_t)j, tb, eb});
        }
        for (size_t j : todo)
            mark[j] = 0;
        for (size_t i : changed)
            mark[i] = 0;
        changed.clear();
        for (const redist_upd &u : upd) {
            best[u.i] = u.t, bd2[u.i] = u.e;
            changed.push_back(u.i);
        }
    }
    for (size_t i = 0; i < total; i++)
        dist[i] = best[i] == none ? (float)half_width
                                  : std::min((float)half_width, (float)std::sqrt((double)bd2[i]));
}

} // namespace

// Propagated distances are exact only next to the surface: farther out a
// sample's triangle comes from a neighbour, not always the closest (with
// OpenVDB's levelSetRebuild, used before, about 0.1% of neighbour steps
// exceeded one voxel, up to 1.8 on grid.ini), while a distance field (and
// the example's) never steps more than a voxel. This lowers every
// magnitude to an upper bound of the distance to the same surface (linear
// zero crossings, as the contour mesh): across a sign change the distance to
// the crossing on that edge, |a| h / (|a| + |b|); then |a| <= |b| + h
// between neighbours of one sign (forward and backward raster sweeps until
// nothing changes). Signs and crossings on the edges that set the bound stay;
// afterwards no axis step exceeds h. v: x fastest, n[0] x n[1] x n[2].
// Reach: a magnitude is lowered only by values within ceil(max |v| / h) + 1
// samples of it (every step of a chain adds h), which is what lets
// gs_vdbp_redistance run it on a window of the field.
static void lipschitz_bound(float *v, const size_t n[3], float h)
{
    const size_t sy = n[0], sz = n[0] * n[1], slab = sz;
    std::vector<float> orig(3 * slab); // original values of slices z-1, z, z+1
    auto copy_slice = [&](size_t z, size_t k) {
        std::memcpy(&orig[(k % 3) * slab], v + z * sz, slab * sizeof(float));
    };
    copy_slice(0, 0);
    if (n[2] > 1)
        copy_slice(1, 1);
    for (size_t z = 0; z < n[2]; z++) {
        if (z >= 1 && z + 1 < n[2])
            copy_slice(z + 1, z + 1); // over slice z-2's, no longer needed
        const float *cur = &orig[(z % 3) * slab];
        for (size_t y = 0; y < n[1]; y++)
            for (size_t x = 0; x < n[0]; x++) {
                size_t i = x + n[0] * y;
                float a = cur[i], m = std::fabs(a), cap = m;
                auto edge = [&](float b) {
                    if ((a < 0) != (b < 0)) {
                        float s = m + std::fabs(b);
                        if (s > h)
                            cap = std::min(cap, h * m / s);
                    }
                };
                if (x > 0) edge(cur[i - 1]);
                if (x + 1 < n[0]) edge(cur[i + 1]);
                if (y > 0) edge(cur[i - n[0]]);
                if (y + 1 < n[1]) edge(cur[i + n[0]]);
                if (z > 0) edge(orig[((z - 1) % 3) * slab + i]);
                if (z + 1 < n[2]) edge(orig[((z + 1) % 3) * slab + i]);
                if (cap < m)
                    v[z * sz + i] = a < 0 ? -cap : cap;
            }
    }
    // the sweeps: forward (neighbours at -x, -y, -z) then backward (+x, +y,
    // +z), each in raster order, as nested loops (no index arithmetic per voxel)
    for (bool changed = true; changed;) {
        changed = false;
        for (size_t z = 0; z < n[2]; z++)
            for (size_t y = 0; y < n[1]; y++) {
                float *row = v + z * sz + y * sy;
                for (size_t x = 0; x < n[0]; x++) {
                    float a = row[x], m = std::fabs(a), lim = m;
                    if (x > 0 && (a < 0) == (row[x - 1] < 0))
                        lim = std::min(lim, std::fabs(row[x - 1]) + h);
                    if (y > 0 && (a < 0) == (row[x - sy] < 0))
                        lim = std::min(lim, std::fabs(row[x - sy]) + h);
                    if (z > 0 && (a < 0) == (row[x - sz] < 0))
                        lim = std::min(lim, std::fabs(row[x - sz]) + h);
                    if (lim < m) {
                        row[x] = a < 0 ? -lim : lim;
                        changed = true;
                    }
                }
            }
        for (size_t z = n[2]; z-- > 0;)
            for (size_t y = n[1]; y-- > 0;) {
                float *row = v + z * sz + y * sy;
                for (size_t x = n[0]; x-- > 0;) {
                    float a = row[x], m = std::fabs(a), lim = m;
                    if (x + 1 < n[0] && (a < 0) == (row[x + 1] < 0))
                        lim = std::min(lim, std::fabs(row[x + 1]) + h);
                    if (y + 1 < n[1] && (a < 0) == (row[x + sy] < 0))
                        lim = std::min(lim, std::fabs(row[x + sy]) + h);
                    if (z + 1 < n[2] && (a < 0) == (row[x + sz] < 0))
                        lim = std::min(lim, std::fabs(row[x + sz]) + h);
                    if (lim < m) {
                        row[x] = a < 0 ? -lim : lim;
                        changed = true;
                    }
                }
            }
    }
}

namespace {

gs_err check_redistance(const gs_vdb_dense *d, int pad, double half_width, const char *what)
{
    GS_CALL(check_dense(d, what));
    GS_CHECK(pad >= 1 && pad <= 64 && std::isfinite(half_width) && half_width >= 1 &&
                 half_width <= 64 && d->nx + 2 * (size_t)pad < INT32_MAX &&
                 d->ny + 2 * (size_t)pad < INT32_MAX && d->nz + 2 * (size_t)pad < INT32_MAX,
             GS_ERR_ARG, "%s: padding %d, half width %g of a %zux%zux%zu field: expected a "
             "padding in [1, 64] and a half width in [1, 64] voxels", what, pad, half_width,
             d->nx, d->ny, d->nz);
    return GS_OK;
}

// Index space of both entry points below: sample (x, y, z) of d is voxel
// (x + pad, y + pad, z + pad); world = d->origin + (index - pad) * voxel.
openvdb::math::Transform::Ptr padded_transform(const gs_vdb_dense *d, int pad)
{
    double o[3];
    for (int k = 0; k < 3; k++)
        o[k] = d->origin[k] - pad * d->voxel;
    return make_transform(d->voxel, o);
}

} // namespace

extern "C" gs_err gs_vdbp_redistance(const gs_vdb_dense *d, int pad, double half_width,
                                    size_t z0, size_t z1, float *out)
{
    GS_CALL(check_redistance(d, pad, half_width, "redistance"));
    GS_CHECK(z0 < z1 && z1 <= d->nz && out, GS_ERR_ARG,
             "redistance: planes [%zu, %zu) of a field of %zu: expected 0 <= z0 < z1 <= nz", z0,
             z1, d->nz);
    GS_VDB_GUARD("redistance", {
        const int64_t nx = (int64_t)d->nx, ny = (int64_t)d->ny, nz = (int64_t)d->nz;
        // the window the bound needs (its reach), and the box the distances
        // need around it (their reach, at least the field's own padding)
        const int64_t reach = (int64_t)std::ceil(half_width) + 1;
        const int64_t w0 = std::max<int64_t>(0, (int64_t)z0 - reach),
                      w1 = std::min<int64_t>(nz, (int64_t)z1 + reach);
        const int64_t m = std::max<int64_t>(pad, redist_reach(half_width));
        const int64_t b0 = std::max<int64_t>(-pad, w0 - m), b1 = std::min<int64_t>(nz + pad, w1 + m);
        // the box, padded with the field's edge values (x, y and beyond its
        // z ends) so the surface stays open at the box faces
        const size_t px = (size_t)(nx + 2 * pad), py = (size_t)(ny + 2 * pad), pz = (size_t)(b1 - b0);
        // mesh_band_distance indexes the box's samples (and the triangles)
        // with uint32: a larger piece is refused, not wrapped
        const double box = (double)px * (double)py * (double)pz;
        GS_CHECK(box <= (double)GS_VDB_REDIST_MAX_SAMPLES, GS_ERR_ARG,
                 "redistance: planes [%zu, %zu) of a %zux%zux%zu field need a padded box of "
                 "%zux%zux%zu = %.0f samples: expected at most %llu (32-bit sample indices); "
                 "split the planes into smaller pieces", z0, z1, d->nx, d->ny, d->nz, px, py, pz,
                 box, (unsigned long long)GS_VDB_REDIST_MAX_SAMPLES);
        std::vector<redist_tri> tris;
        {
            std::vector<float> box(px * py * pz);
            for (size_t z = 0; z < pz; z++) {
                int64_t sz = std::min<int64_t>(std::max<int64_t>(b0 + (int64_t)z, 0), nz - 1);
                for (size_t y = 0; y < py; y++) {
                    int64_t sy = std::min<int64_t>(std::max<int64_t>((int64_t)y - pad, 0), ny - 1);
                    const float *src = d->v + (size_t)nx * ((size_t)sy + (size_t)ny * (size_t)sz);
                    float *dst = &box[px * (y + py * z)];
                    for (int x = 0; x < pad; x++)
                        dst[x] = src[0], dst[px - 1 - x] = src[nx - 1];
                    std::memcpy(dst + pad, src, (size_t)nx * sizeof(float));
                }
            }
            // the zero surface as OpenVDB meshes it, in the box's index
            // space (sample (x, y, z) at (x + pad, y + pad, z + pad): the
            // same coordinates in every window, so the same triangles)
            auto grid = openvdb::FloatGrid::create(d->background);
            openvdb::CoordBBox bb(openvdb::Coord(0, 0, (int)(b0 + pad)),
                                  openvdb::Coord((int)px - 1, (int)py - 1, (int)(b1 + pad) - 1));
            DenseXYZ dense(bb, box.data());
            openvdb::tools::copyFromDense(dense, *grid, -1.0f); // every sample active
            std::vector<float>().swap(box);
            std::vector<openvdb::Vec3s> pts;
            std::vector<openvdb::Vec3I> tri3;
            std::vector<openvdb::Vec4I> quads;
            openvdb::tools::volumeToMesh(*grid, pts, tri3, quads, 0.0, 0.0);
            grid.reset();
            tris.reserve(tri3.size() + 2 * quads.size());
            auto add = [&](uint32_t a, uint32_t b, uint32_t c) {
                redist_tri t;
                for (int k = 0; k < 3; k++) {
                    t.p[k] = pts[a][k], t.p[3 + k] = pts[b][k], t.p[6 + k] = pts[c][k];
                    t.c[k] = (t.p[k] + t.p[3 + k] + t.p[6 + k]) / 3;
                }
                float r2 = 0;
                for (int v = 0; v < 3; v++) {
                    float e0 = t.p[3 * v] - t.c[0], e1 = t.p[3 * v + 1] - t.c[1], e2 = t.p[3 * v + 2] - t.c[2];
                    r2 = std::max(r2, e0 * e0 + e1 * e1 + e2 * e2);
                }
                t.r = std::sqrt(r2) + 1e-3f; // beyond any rounding of the above
                tris.push_back(t);
            };
            for (const auto &t : tri3)
                add(t[0], t[1], t[2]);
            for (const auto &q : quads) { // split as gs_vdbp_dense_to_mesh splits them
                if ((pts[q[0]] - pts[q[2]]).lengthSqr() <= (pts[q[1]] - pts[q[3]]).lengthSqr()) {
                    add(q[0], q[1], q[2]);
                    add(q[0], q[2], q[3]);
                } else {
                    add(q[0], q[1], q[3]);
                    add(q[1], q[2], q[3]);
                }
            }
        }
        GS_CHECK(tris.size() < (size_t)UINT32_MAX, GS_ERR_ARG,
                 "redistance: planes [%zu, %zu) of a %zux%zux%zu field: %zu contour triangles: "
                 "expected fewer than %llu (32-bit triangle indices); split the planes into "
                 "smaller pieces", z0, z1, d->nx, d->ny, d->nz, tris.size(),
                 (unsigned long long)UINT32_MAX);
        // in raster order of their centres' samples, as the samples are
        // visited (the order changes no value: ties go by geometry)
        std::stable_sort(tris.begin(), tris.end(), [](const redist_tri &a, const redist_tri &b) {
            for (int k = 2; k >= 0; k--) {
                float fa = std::floor(a.c[k]), fb = std::floor(b.c[k]);
                if (fa != fb)
                    return fa < fb;
            }
            return false;
        });
        // the window's distances with the field's signs (inside: < 0),
        // bounded, then its planes [z0, z1)
        std::vector<float> win((size_t)nx * (size_t)ny * (size_t)(w1 - w0));
        {
            const size_t bn[3] = {px, py, pz};
            const int64_t lo[3] = {0, 0, b0 + pad};
            std::vector<float> dist(px * py * pz);
            mesh_band_distance(tris, lo, bn, half_width, dist.data());
            std::vector<redist_tri>().swap(tris);
            const float h = (float)d->voxel, bg = (float)(half_width * d->voxel);
            for (int64_t z = w0; z < w1; z++)
                for (int64_t y = 0; y < ny; y++) {
                    const float *dr = &dist[(size_t)pad + px * ((size_t)(y + pad) + py * (size_t)(z - b0))];
                    const float *sr = d->v + (size_t)nx * ((size_t)y + (size_t)ny * (size_t)z);
                    float *wr = &win[(size_t)nx * ((size_t)y + (size_t)ny * (size_t)(z - w0))];
                    for (int64_t x = 0; x < nx; x++) {
                        float a = std::min(dr[x] * h, bg);
                        wr[x] = sr[x] < 0 ? -a : a;
                    }
                }
        }
        const size_t wn[3] = {(size_t)nx, (size_t)ny, (size_t)(w1 - w0)};
        lipschitz_bound(win.data(), wn, (float)d->voxel);
        std::memcpy(out, &win[(size_t)nx * (size_t)ny * (z0 - (size_t)w0)],
                    (size_t)nx * (size_t)ny * (z1 - z0) * sizeof(float));
        return GS_OK;
    });
}

extern "C" gs_err gs_vdbp_level_set_write(const gs_vdb_dense *d, int pad, double half_width,
                                         const char *name, const char *path)
{
    GS_CALL(check_redistance(d, pad, half_width, path ? path : "level set"));
    GS_CHECK(path && path[0], GS_ERR_ARG, "level set: output path is empty");
    GS_VDB_GUARD(path, {
        const float bg = (float)(half_width * d->voxel);
        auto ls = openvdb::FloatGrid::create(bg);
        ls->setTransform(padded_transform(d, pad));
        openvdb::CoordBBox box(openvdb::Coord(pad, pad, pad),
                               openvdb::Coord((int)d->nx - 1 + pad, (int)d->ny - 1 + pad,
                                              (int)d->nz - 1 + pad));
        {
            // samples at the background's magnitude are inactive (-bg inside,
            // made so below), the band active, as a level set's tree
            DenseXYZ dense(box, d->v);
            openvdb::tools::copyFromDense(dense, *ls, 0.0f);
            for (auto leaf = ls->tree().beginLeaf(); leaf; ++leaf)
                for (auto it = leaf->beginValueOn(); it; ++it)
                    if (*it <= -bg)
                        it.setValueOff();
            openvdb::tools::pruneLevelSet(ls->tree());
        }
        ls->setName(name ? name : "surface");
        ls->setGridClass(openvdb::GRID_LEVEL_SET);
        ls->insertMeta("gs_dense_min", openvdb::Vec3IMetadata(openvdb::Vec3i(pad, pad, pad)));
        ls->insertMeta("gs_dense_max", openvdb::Vec3IMetadata(openvdb::Vec3i(
                                           (int)d->nx - 1 + pad, (int)d->ny - 1 + pad,
                                           (int)d->nz - 1 + pad)));
        axis_meta(*ls);
        // a fog volume "density" beside it (0 outside, rising to 1 across the band inside,
        // 1 in the interior): what Blender's and most renderers' default volume shader
        // reads, so the file renders without a shader of one's own (docs/FORMATS.md)
        openvdb::FloatGrid::Ptr fog = ls->deepCopy();
        openvdb::tools::sdfToFogVolume(*fog);
        fog->setName("density");
        gs_vdb_grid w[2] = {{ls, ls->getName()}, {fog, fog->getName()}};
        gs_vdb_grid *wp[2] = {&w[0], &w[1]};
        GS_CALL(gs_vdbp_write(path, wp, 2));
        return GS_OK;
    });
}
