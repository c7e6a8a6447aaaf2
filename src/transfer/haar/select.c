/* select.c - Haar's expected-error selection (select.h): the level spectrum of light it assumes
 * without a prior, and the weighted copy it selects on. */
#include "select.h"
#include <math.h>

enum { FACE = CUBE_RES * CUBE_RES };

_Static_assert(CUBE_RES == 1 << (TRANSPORT_LEVELS - 1), "transport_level_sigma has one entry per Haar level of a face");

/* The RMS light coefficient per Haar level relative to the finest, sqrt of the geometric mean over
 * the four probes with a sun or lamp (city, interior, night, sunrise: a source about 34,000 times
 * the mean, /work/shared/data/SOURCES.md) of each probe's mean squared coefficient per level, over 24
 * rotations (yaw in 15-degree steps, pitch -30/0/30), the three channels and the six faces, of the
 * light the solid-angle measure builds (L_j w_j). Per probe sigma_0^2 / sigma_6^2 is 11.7, 8.8, 8.5,
 * 3.8: a sun alone is flat over the levels (a point of value a has one coefficient a/s per level of
 * s x s blocks, among (64/s)^2 per face: the mean square a^2/4096 at every level), and the sky adds
 * to the coarse ones. Probes without a sun are far steeper (forest 281, studio 155), but under them
 * the transport's coarse coefficients, which every selection keeps, carry nearly all of T.L.
 * Measured with tools/level_spectrum.sh; the weights need no asset at run time. */
const float transport_level_sigma[TRANSPORT_LEVELS] = { 2.752f, 1.643f, 1.512f, 1.373f, 1.303f, 1.200f, 1.000f };

/* Level of a wavelet index: the number of base-4 digits of its position in the face. */
int transport_level(uint32_t i) {
    uint32_t m = i % FACE;
    int l = 0;
    while (m) { l++; m >>= 2; }
    PRT_CHECK_LT(l, TRANSPORT_LEVELS);
    return l;
}

/* The prior's weighted copy of one channel: c_i sigma_i, less what quantization would lose anyway on
 * the faces of `smooth` (haar_face_shapes). A kept coefficient still errs by its rounding (step = the
 * channel's largest |c| / qmax, sparse.h), and on a face with no occluder edge a dropped one is put
 * back weighted by the transport (corrections.h), so there a coefficient gains its slot only by what
 * exceeds a step: sigma_i^2 (c_i^2 - step^2); else the prior, which weighs a sun's ring heavily, would
 * spend slots on an open floor's many tiny fine coefficients that rounding loses anyway. On a face an
 * occluder's edge crosses, the fine coefficients are the edge and nothing puts them back, so there
 * the term is not taken (docs/design/transport.md has the measurements). Non-finite stays so. */
static void prior_channel(const float *c, const float (*prior)[4], int ch, int qbits, unsigned smooth, float *w) {
    float mx = 0;
    for (int j = 0; j < CUBE_TEXELS; j++)
        if (isfinite(c[j]) && fabsf(c[j]) > mx) mx = fabsf(c[j]);
    int qmax = sparse_qmax(qbits);   /* 0: float, no rounding */
    double step = qmax ? (double)mx / qmax : 0, e2 = step * step;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        double d = (double)c[j] * c[j] - (smooth >> (j / FACE) & 1 ? e2 : 0);
        w[j] = !isfinite(c[j]) ? c[j] : d > 0 ? (float)(sqrt(d) * prior[j][ch]) : 0.f;
    }
}

/* See select.h. Scaling each coefficient by its sigma before the magnitude selection picks the set
 * that minimises the expected error. sigma is its level's (transport_level_sigma), or with a prior
 * (prior.h) its own per channel (prior_channel). Non-finite inputs stay non-finite, so sparse_select
 * skips them. */
int haar_select_expected(const float *r, const float *g, const float *b, const prt_transport *t, unsigned smooth,
                         uint32_t *idx, float *keys, float *wc) {
    float *wr = wc, *wg = wc + CUBE_TEXELS, *wb = wc + 2 * CUBE_TEXELS;
    if (t->prior) {
        prior_channel(r, t->prior, 0, t->qbits, smooth, wr);
        prior_channel(g, t->prior, 1, t->qbits, smooth, wg);
        prior_channel(b, t->prior, 2, t->qbits, smooth, wb);
    } else
        for (int f = 0; f < 6; f++)
            for (int l = 0, lo = 0; l < TRANSPORT_LEVELS; lo = l ? 4 * lo : 1, l++) {   /* level l: [lo, max(1, 4 lo)) */
                float s = transport_level_sigma[l];
                for (int j = f * FACE + lo; j < f * FACE + (l ? 4 * lo : 1); j++) {
                    wr[j] = r[j] * s; wg[j] = g[j] * s; wb[j] = b[j] * s;
                }
            }
    return sparse_select(wr, wg, wb, CUBE_TEXELS, t->N, idx, keys);
}
