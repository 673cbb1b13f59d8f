/* Program and file-format versions. */
#ifndef GEOSYNTH_VERSION_H
#define GEOSYNTH_VERSION_H

#define GS_VERSION_STRING "0.1.0"
/* Bumped whenever the HDF5 layout changes incompatibly; readers reject newer. */
#define GS_FORMAT_VERSION 1

#endif
