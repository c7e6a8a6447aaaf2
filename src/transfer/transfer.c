/* transfer.c - transfer representations (transfer.h). STUB: replaced by the table. */
#include "transfer.h"
#include "light.h"
#include "prtfile.h"
#include "shbasis.h"
#include <stdlib.h>

float (*transfer_light_vector(const struct prt_data *d, const float *cube_rgb))[4] {
    float (*L)[4] = light_alloc();
    if (!L) return NULL;
    if (d->sh_order > 0) sh_light_from_cube(cube_rgb, CUBE_RES, d->sh_order, L);
    else light_from_cube(cube_rgb, NULL, L, NULL);
    return L;
}
