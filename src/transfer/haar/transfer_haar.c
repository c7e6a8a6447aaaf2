/* transfer_haar.c - the paper's representation (sections 4.1, 4.3): per face
 * orthonormal 2D Haar wavelets of the transport cube, the N largest of 24,576
 * coefficients kept and quantized (the sparse family's storage), and a light
 * vector in the same wavelet-index order quantized to 16 bits (light.h). By
 * Parseval, sum_i L_i T_i of the full vectors equals sum_j L_j T_j (Eq. 4).
 *
 * What the wavelets approximate (cfg->measure, issue 10). The paper transforms the
 * texels T_j of Eq. 3, which carry their solid angle dw_j. A cube texel at a face corner
 * spans a fifth of the solid angle of one at the centre (dw ~ (1 + x^2 + y^2)^-3/2), so
 * even an unoccluded vertex's transport, a smooth cosine lobe over the sphere, is a
 * steep bowl on each face, and the N largest of its Haar coefficients approximate it by
 * block means that miss a point value (a sun) by a few percent, by an amount that depends
 * on which blocks the sun lands in: the floor's "mottling" and its shimmer as the light
 * turns. TRANSFER_MEASURE_SOLID_ANGLE (what precompute makes by default) transforms T_j / w_j instead, with
 * w_j = (2/res)^2 (1 + x^2 + y^2)^-3/2 the differential solid angle at the texel centre
 * (within 0.025% of the exact dw_j; any fixed positive weight keeps the product exact, since
 * the light vector is built from L_j w_j: sum_j (L_j w_j)(T_j / w_j) = sum_j L_j T_j). The
 * transport per steradian is the cosine times the visibility and the BRDF, flat where the
 * texels were steep, so truncation keeps what varies with visibility. Measured
 * (docs/design/shadows.md; N = 128, 8-bit): an unoccluded plane under city.exr turned in 1-degree steps
 * (tools/shimmer.sh) keeps its ratio to the exact product within a spread (sd) of 0.13%
 * instead of 2.27%, steps of at most 0.72% instead of 2.85%, but with a uniform -1% bias; on a
 * reduced bunny over a floor the floor's sun-shadow error falls from 12.5% to 5.7%.
 * Truncation also drops a share of each face's integral (W's details correlate with T/w's):
 * transport_store puts it back per 4x4 block of each face, into the coarse coefficients
 * (transport.h, solid_angle and block_level), which moves that bias to about -0.6%; on a face
 * with no occluder edge weighted by the transport instead (smooth_faces), about -0.13%.
 * Files written before issue 10 have no measure flag: measure 0, the texels. */
#include "transfer.h"
#include "haar.h"
#include "light.h"
#include "prtfile.h"
#include <math.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

/* The sparse family's N and qbits; no order; the measure (0, the texels, or solid angle). */
static int haar_configure(transfer_config *cfg, prt_error *err) {
    if (transfer_sparse_configure(cfg, err)) return -1;
    if (cfg->order != 0) return prt_fail(err, "Haar wavelets take no order (got %d)", cfg->order);
    if (cfg->measure != 0 && cfg->measure != TRANSFER_MEASURE_SOLID_ANGLE)
        return prt_fail(err, "Haar measure = %d (must be 0, the texels, or %d, solid angle)", cfg->measure,
                        TRANSFER_MEASURE_SOLID_ANGLE);
    return 0;
}

static bool haar_solid_angle(const transfer_config *cfg) { return cfg->measure == TRANSFER_MEASURE_SOLID_ANGLE; }

static void haar_describe(const transfer_config *cfg, char *buf, size_t cap) {
    snprintf(buf, cap, "Haar wavelets, N=%d of %d coefficients per vector, %d-bit%s", cfg->N, CUBE_TEXELS, cfg->qbits,
             haar_solid_angle(cfg) ? ", per steradian" : "");
}

/* Each face transformed on its own (section 4.1.1), wavelet-index order (haar.h); with the
 * solid-angle measure the texels are divided by w_j first (see the header comment). */
static void haar_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    if (!haar_solid_angle(cfg)) {
        haar_cube_forward(texels, CUBE_RES, coeffs, scratch);
        return;
    }
    enum { NN = CUBE_RES * CUBE_RES };
    float inv[NN];
    haar_face_solid_angle(inv, CUBE_RES, true);
    for (int f = 0; f < 6; f++) {
        for (int k = 0; k < NN; k++) scratch[k] = texels[f * NN + k] * inv[k];
        haar_forward(scratch, CUBE_RES, scratch + NN);
        haar_face_to_morton(scratch, CUBE_RES, coeffs + f * NN);
    }
}

/* Haar, the paper's relative energy threshold, 16-bit quantization (light.h); texels weighted
 * by w_j with the solid-angle measure. */
static void haar_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    float w[CUBE_RES * CUBE_RES];
    light_desc d = { 0 };
    if (haar_solid_angle(cfg)) {
        haar_face_solid_angle(w, CUBE_RES, false);
        d.face_weight = w;
    }
    light_from_cube(cube_rgb, &d, L, NULL);
}

static bool haar_validate(const struct prt_data *d, const prt_transfer *tr, char *why) {
    if (tr->cfg.order != 0) return BAD(why, "Haar transfer with order %d", tr->cfg.order);
    return transfer_sparse_validate(d, tr, CUBE_TEXELS, why);
}

const transfer_ops transfer_haar = {
    .name = "haar",
    .title = "Haar wavelets",
    .tag = TRANSFER_TAG('H', 'A', 'A', 'R'),
    .configure = haar_configure,
    .describe = haar_describe,
    .project_transport = haar_project_transport,
    .compress = transfer_sparse_compress,
    .project_light = haar_project_light,
    .write = transfer_sparse_write,
    .read = transfer_sparse_read,
    .validate = haar_validate,
    .release = transfer_sparse_release,
    .light_range = transport_light_range,
    .glsl = &transfer_sparse_glsl,
};
