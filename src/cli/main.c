/* geosynth command line entry point. */
#include <stdio.h>
#include <string.h>

#include "geosynth/error.h"
#include "geosynth/par.h"

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    if (gs_par_rank() == 0)
        printf("geosynth\n");
    gs_par_finalize();
    return 0;
}
