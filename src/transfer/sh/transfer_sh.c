/* transfer_sh.c - spherical harmonics, the low-frequency baseline that
 * all-frequency PRT replaces (shbasis.h). A vector's order^2 coefficients sit at
 * indices 0..order^2-1 of the sparse family's storage (index l(l+1)+m), so the
 * runtimes' T x L kernels are the Haar ones. Transport texels already include
 * their solid angle (Eq. 3), so they project as c_i = sum_j T_j Y_i(w_j); the light
 * (mean radiance per texel) as L_i = sum_j L_j Y_i(w_j) dw_j; then sum_i L_i c_i
 * approximates sum_j L_j T_j for band-limited signals. */
#include "transfer.h"
#include "prtfile.h"
#include "shbasis.h"
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)
#define SH_MIN 3
#define SH_MAX 10
#define SH_DEFAULT 6

/* The sparse family's N and qbits, and the order (default SH_DEFAULT). */
static int sh_configure(transfer_config *cfg, prt_error *err) {
    if (transfer_sparse_configure(cfg, err)) return -1;
    if (cfg->order == 0) cfg->order = SH_DEFAULT;
    if (cfg->order < SH_MIN || cfg->order > SH_MAX)
        return prt_fail(err, "spherical-harmonic order = %d (must be %d..%d)", cfg->order, SH_MIN, SH_MAX);
    return 0;
}

static void sh_describe(const transfer_config *cfg, char *buf, size_t cap) {
    snprintf(buf, cap, "spherical harmonics of order %d (%d coefficients; N=%d)", cfg->order, cfg->order * cfg->order,
             cfg->N);
}

/* scratch gets the order^2 coefficients first (SH_MAX^2 <= TRANSFER_SCRATCH_FLOATS). */
static void sh_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    sh_project_cube(texels, CUBE_RES, cfg->order, false, scratch);
    memset(coeffs, 0, sizeof(float) * CUBE_TEXELS);
    memcpy(coeffs, scratch, sizeof(float) * (size_t)(cfg->order * cfg->order));
}

static void sh_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    sh_light_from_cube(cube_rgb, CUBE_RES, cfg->order, L);
}

/* The order bounds the indices: nothing at or beyond order^2. */
static bool sh_validate(const struct prt_data *d, const prt_transfer *tr, char *why) {
    if (tr->cfg.order < SH_MIN || tr->cfg.order > SH_MAX) return BAD(why, "bad spherical-harmonic order %d", tr->cfg.order);
    return transfer_sparse_validate(d, tr, (uint32_t)(tr->cfg.order * tr->cfg.order), why);
}

const transfer_ops transfer_sh = {
    .name = "sh",
    .title = "spherical harmonics",
    .tag = TRANSFER_TAG('S', 'H', 'R', 'M'),
    .configure = sh_configure,
    .describe = sh_describe,
    .project_transport = sh_project_transport,
    .compress = transfer_sparse_compress,
    .project_light = sh_project_light,
    .write = transfer_sparse_write,
    .read = transfer_sparse_read,
    .validate = sh_validate,
    .release = transfer_sparse_release,
    .light_range = transport_light_range,
    .glsl = &transfer_sparse_glsl,
};
