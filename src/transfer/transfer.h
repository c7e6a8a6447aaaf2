/* transfer.h - transfer representations: the seam between what precompute stores
 * per vertex and what a runtime does with a light. (CONTRACT STUB: the full
 * table of operations is being written; this function is stable.) */
#ifndef PRT_TRANSFER_H
#define PRT_TRANSFER_H
#include "common.h"
#include "cubemap.h"

struct prt_data;

/* The light vector for d's transfer representation from the probe resampled to the
 * 6x64x64 cube (cube_rgb: [CUBE_TEXELS][3] radiance): Haar wavelets quantized to 16 bits,
 * or spherical harmonics. Returns an aligned [CUBE_TEXELS][4] array (free()), NULL on OOM. */
float (*transfer_light_vector(const struct prt_data *d, const float *cube_rgb))[4];
#endif
