/* Linked into SANITIZE builds only (Makefile): dlclose() that keeps every
 * library loaded. Open MPI 4.1 unloads its plugins (mca_*.so, PMIx and hwloc
 * components) in MPI_Finalize, so LeakSanitizer, which reports at exit, sees
 * their start-up allocations as '<unknown module>' and tests/lsan.supp cannot
 * match them by library name. Open MPI 4.1 has no parameter to keep them
 * (mca_base_component_disable_dlclose arrived later). Exported from the
 * executable (-Wl,--export-dynamic-symbol=dlclose), so it interposes the C
 * library's for every shared library the program loads. */
int dlclose(void *handle);

int dlclose(void *handle)
{
    (void)handle;
    return 0;
}
