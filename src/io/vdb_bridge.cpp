// The one C++ file: every OpenVDB include lives here, behind extern "C".
#include <openvdb/openvdb.h>

#include "geosynth/vdb.h"

extern "C" const char *gs_vdb_library_version(void)
{
    return openvdb::getLibraryVersionString();
}
