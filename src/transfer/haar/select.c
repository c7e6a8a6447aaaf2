/* select.c - Haar's expected-error selection (select.h): the level spectrum of light it assumes
 * without a prior, and the weighted copy it selects on. */
#include "select.h"
#include "cubemap.h"
#include "haar.h"
#include <math.h>

enum { FACE = CUBE_RES * CUBE_RES };

_Static_assert(CUBE_RES == 1 << (TRANSPORT_LEVELS - 1), "transport_band_sigma has one entry per Haar level of a face");

/* The RMS light coefficient per elevation band and Haar level: over the four probes with a sun or
 * lamp (city, interior, night, sunrise: a source about 34,000 times the mean, SOURCES.md of the shared
 * data), each of 24 rotations (yaw in 15-degree steps, pitch -15/0/15, so a probe's sun stands for
 * suns within 15 degrees of its elevation), the three channels and the coefficients of the light the
 * solid-angle measure builds (L_j w_j) whose support centre lies in the band: the mean square
 * relative to that probe's mean square at its finest level, averaged over the probes (an arithmetic
 * mean: a sun in any probe's band is a sun that band can hold), square root; from level 3 on no band
 * above the horizon below half the largest of those (a lamp overhead or a noon sun can stand where
 * the four have none). Measured with tools/level_spectrum.sh --bands; no asset is read at run time.
 *
 * Why by elevation (docs/design/shadows.md has the measurements): a level's figure alone weighs a
 * coefficient below the horizon, where the ground is smooth, like one beside a low sun, where a
 * floor's transport is small (its cosine) but the sun is 34,000 times the sky. A sun a yaw rotation
 * moves keeps its band. The probes without a sun are left out:
 * their steep sky spectra weigh the coarse levels so much that a shadowed vertex loses the details
 * around the sun. */
const float transport_band_sigma[TRANSPORT_BANDS][TRANSPORT_LEVELS] = {
    { 0.402f, 0.0516f, 0, 0, 0.0133f, 0.00502f, 0.00205f },  /* -90..-75 */
    { 0, 0, 0, 0.033f, 0.0123f, 0.00449f, 0.00171f },        /* -75..-60 */
    { 0, 0, 0.0667f, 0.0209f, 0.00783f, 0.00285f, 0.00103f }, /* -60..-45 */
    { 0, 0, 0, 0.0394f, 0.0134f, 0.00354f, 0.00121f },       /* -45..-30 */
    { 0, 0, 1.01f, 0, 0.247f, 0.159f, 0.129f },              /* -30..-15 */
    { 0, 0, 0, 1.26f, 1.62f, 1.45f, 1.18f },                 /* -15..0 */
    { 2.59f, 1.61f, 0, 2.11f, 2.28f, 1.97f, 1.58f },         /* 0..15 */
    { 0, 0, 1.78f, 0, 1.29f, 1.15f, 0.941f },                /* 15..30 */
    { 0, 0, 0, 1.27f, 1.14f, 1.06f, 0.912f },                /* 30..45 */
    { 0, 0, 2.21f, 2.54f, 2.24f, 2.12f, 1.82f },             /* 45..60 */
    { 0, 0, 0, 1.7f, 1.94f, 1.98f, 1.72f },                  /* 60..75 */
    { 4.58f, 2.41f, 0, 0, 1.14f, 1.06f, 0.912f },            /* 75..90 */
};

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

/* The elevation band of the centre of index i's support: level l >= 1 coefficients of a face cover
 * 64 / 2^(l-1) texel squares, the scaling coefficient the face. */
int transport_band(uint32_t i) {
    uint32_t qi, qj;
    haar_unmorton(i % FACE, &qi, &qj);
    int l = transport_level(i), h = l ? 1 << (l - 1) : 1, s = CUBE_RES / h;
    float d[3];
    cube_dir(CUBE_RES, (int)(i / FACE), (float)((qi % (uint32_t)h) + 0.5f) * (float)s, (float)((qj % (uint32_t)h) + 0.5f) * (float)s, d);
    int b = (int)floor((asin(fmax(-1.0, fmin(1.0, d[1]))) * 180 / M_PI + 90) / 15);
    return b < 0 ? 0 : b >= TRANSPORT_BANDS ? TRANSPORT_BANDS - 1 : b;
}

float transport_sigma(uint32_t i) { return transport_band_sigma[transport_band(i)][transport_level(i)]; }

/* See select.h. Scaling each coefficient by its sigma before the magnitude selection picks the set
 * that minimises the expected error. sigma is its level's and band's (transport_sigma), or with a prior
 * (prior.h) its own per channel (prior_channel). Non-finite inputs stay non-finite, so sparse_select
 * skips them. */
int haar_select_expected(const float *r, const float *g, const float *b, const prt_transport *t, const float *sigma,
                         unsigned smooth, uint32_t *idx, float *keys, float *wc) {
    float *wr = wc, *wg = wc + CUBE_TEXELS, *wb = wc + 2 * CUBE_TEXELS;
    if (t->prior) {
        prior_channel(r, t->prior, 0, t->qbits, smooth, wr);
        prior_channel(g, t->prior, 1, t->qbits, smooth, wg);
        prior_channel(b, t->prior, 2, t->qbits, smooth, wb);
    } else
        for (int j = 0; j < CUBE_TEXELS; j++) {
            wr[j] = r[j] * sigma[j]; wg[j] = g[j] * sigma[j]; wb[j] = b[j] * sigma[j];
        }
    return sparse_select(wr, wg, wb, CUBE_TEXELS, t->N, idx, keys);
}
