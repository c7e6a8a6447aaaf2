/* transfer_haar.c - the paper's representation (sections 4.1, 4.3): per face
 * orthonormal 2D Haar wavelets of the transport cube, the N largest of 24,576
 * coefficients kept and quantized (the sparse family's storage), and a light
 * vector in the same wavelet-index order quantized to 16 bits (light.h). By
 * Parseval, sum_i L_i T_i of the full vectors equals sum_j L_j T_j (Eq. 4). */
#include "transfer.h"
#include "haar.h"
#include "light.h"
#include "prtfile.h"

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

/* The sparse family's N and qbits; no order. */
static int haar_configure(transfer_config *cfg, prt_error *err) {
    if (transfer_sparse_configure(cfg, err)) return -1;
    if (cfg->order != 0) return prt_fail(err, "Haar wavelets take no order (got %d)", cfg->order);
    return 0;
}

static void haar_describe(const transfer_config *cfg, char *buf, size_t cap) {
    snprintf(buf, cap, "Haar wavelets, N=%d of %d coefficients per vector, %d-bit", cfg->N, CUBE_TEXELS, cfg->qbits);
}

/* Each face transformed on its own (section 4.1.1), wavelet-index order (haar.h). */
static void haar_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    haar_cube_forward(texels, CUBE_RES, coeffs, scratch);
}

/* Haar, the paper's relative energy threshold, 16-bit quantization (light.h). */
static void haar_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    light_from_cube(cube_rgb, NULL, L, NULL);
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
