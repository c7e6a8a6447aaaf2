/* select.h - Haar's expected-error selection (the policy's select, haar/policy.h): which N of a vector's
 * Haar coefficients of T/w to keep so that the expected squared error of T.L is least.
 *
 * Contract: haar_select_expected scales each coefficient c_i by sigma_i, the RMS light coefficient
 * it will meet, and keeps the N largest of the scaled copy (sparse_select); the stored values are the
 * input's. sigma_i is transport_sigma(i), by i's Haar level and the elevation of its support (the
 * light a probe of the sky and ground brings there, suns included), or with the set's prior (prior.h)
 * the prior's own per coefficient and channel.
 *
 * Why (Wang et al. 2006 section 4.1.1 keeps the largest |c_i|, the L2-best approximation of T): the
 * runtime sees T.L, whose expected error over lights with uncorrelated coefficients of variance
 * sigma_i^2 is sum over dropped i of c_i^2 sigma_i^2 (transport.h, TRANSPORT_SELECT_EXPECTED). */
#ifndef PRT_HAAR_SELECT_H
#define PRT_HAAR_SELECT_H
#include "transport.h"

/* Haar levels of a CUBE_RES face: 0 the scaling coefficient, l >= 1 the details of morton indices
 * [4^(l-1), 4^l) (haar.h), the finest CUBE_RES / 2 x CUBE_RES / 2 blocks at level 6. */
#define TRANSPORT_LEVELS 7
/* Elevation bands of the light's prior: 15 degrees each from -90 (straight down) to +90 (the zenith). */
#define TRANSPORT_BANDS 12
/* sigma per elevation band and Haar level, relative to the finest level of each probe (select.c says
 * how it was measured; tools/level_spectrum.c measures it). 0 where no coefficient's centre lies. */
extern const float transport_band_sigma[TRANSPORT_BANDS][TRANSPORT_LEVELS];
/* The Haar level (0..TRANSPORT_LEVELS-1) of wavelet index i. */
int transport_level(uint32_t i);
/* The elevation band (0..TRANSPORT_BANDS-1) of the centre of wavelet index i's support. */
int transport_band(uint32_t i);
/* The prior's sigma of wavelet index i without a light prior: transport_band_sigma of its band and level. */
float transport_sigma(uint32_t i);

/* Selects up to t->N of the coefficients r, g, b [CUBE_TEXELS] by c_i sigma_i into idx (ascending), the
 * weights' float bits left in keys (2 x CUBE_TEXELS floats) as sparse_select leaves them. sigma:
 * transport_sigma of every index (CUBE_TEXELS, read without a prior); smooth: the faces
 * haar_face_shapes found smooth (read with a prior); wc: 3 x CUBE_TEXELS floats of scratch.
 * Returns how many. */
int haar_select_expected(const float *r, const float *g, const float *b, const prt_transport *t, const float *sigma,
                         unsigned smooth, uint32_t *idx, float *keys, float *wc);
#endif
