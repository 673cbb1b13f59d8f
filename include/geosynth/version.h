/* geosynth program and file-format versions.
 *
 * GS_VERSION_STRING is the program version written into every HDF5 file
 * (/geosynth@program_version) and printed by --version.
 * GS_FORMAT_VERSION is the version of the HDF5 layout (/geosynth@format_version).
 * Bump it when a reader of the previous version would misread a new file;
 * readers accept files up to their own GS_FORMAT_VERSION and reject newer ones
 * with "upgrade geosynth".
 */
#ifndef GEOSYNTH_VERSION_H
#define GEOSYNTH_VERSION_H

#define GS_VERSION_STRING "0.1.0"
#define GS_FORMAT_VERSION 1

#endif
