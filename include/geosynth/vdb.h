/* OpenVDB bridge (src/io/vdb_bridge.cpp, the only C++ in geosynth). */
#ifndef GEOSYNTH_VDB_H
#define GEOSYNTH_VDB_H

#ifdef __cplusplus
extern "C" {
#endif

const char *gs_vdb_library_version(void);

#ifdef __cplusplus
}
#endif
#endif
