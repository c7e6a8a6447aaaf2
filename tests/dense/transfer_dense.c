/* transfer_dense.c - a linear transfer representation made for the tests: the transport cube
 * itself, no basis. project_transport is the identity on the 24,576 texels of Eq. 3 (each
 * carrying its solid angle), project_light the probe's mean radiance per texel, so sum_j L_j T_j
 * is Eq. 4's discrete integral with nothing projected. The linear family's storage keeps N of them
 * per vector (default: all of them, as floats: uncompressed), and its section, validation and
 * kernels are the family's (linear.h). Its only reason to exist is to show that a representation
 * is one folder and one table line: it is in the table of tests/dense/'s test binary alone
 * (table.c), and nothing outside this folder names it. */
#include "transfer.h"
#include "linear.h"
#include <string.h>

/* N (default every texel) and qbits (default 32: floats); no options. */
static int dense_configure(const transfer_setup *s, transfer_config *cfg, prt_error *err) {
    memset(cfg, 0, sizeof *cfg);
    transfer_setup all = *s;
    all.N = s->N ? s->N : CUBE_TEXELS;
    all.qbits = s->qbits ? s->qbits : 32;
    linear_config lc;
    if (linear_configure(&all, &lc, err) || transfer_parse_options("dense", NULL, s->options, NULL, NULL, err)) return -1;
    if (s->light_prior && s->light_prior[0] && !s->light_prior_scene)
        return prt_fail(err, "dense: takes no light prior (it keeps its N largest texels)");
    linear_store(cfg, &lc, sizeof lc);
    return 0;
}

static void dense_describe(const transfer_config *cfg, char *buf, size_t cap) {
    linear_config lc = linear_config_of(cfg);
    snprintf(buf, cap, "dense cube texels, N=%d of %d per vector, %d-bit", lc.N, CUBE_TEXELS, lc.qbits);
}

/* The texels as they are: the texel index is the coefficient index. */
static void dense_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    memcpy(coeffs, texels, sizeof(float) * CUBE_TEXELS);
}

/* The mean radiance per texel: T_j already integrates the texel's solid angle (Eq. 3). */
static void dense_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    for (int j = 0; j < CUBE_TEXELS; j++) {
        for (int c = 0; c < 3; c++) L[j][c] = cube_rgb[3 * j + c];
        L[j][3] = 0;
    }
}

static bool dense_validate(const struct prt_data *d, const prt_transfer *tr, char *why) {
    return linear_validate(d, tr, CUBE_TEXELS, why);
}

static const transfer_linear k_linear = {
    .init_set = linear_init_set,
    .project_transport = dense_project_transport,
    .compress = linear_compress,
    .project_light = dense_project_light,
    .light_range = transport_light_range,
    .glsl = &linear_glsl,
};

const transfer_ops transfer_dense = {
    .name = "dense",
    .title = "dense cube texels",
    .label = "dense",
    .tag = TRANSFER_TAG('D', 'N', 'S', 'E'),
    .kind = TRANSFER_LINEAR,
    .configure = dense_configure,
    .describe = dense_describe,
    .write = linear_write,
    .read = linear_read,
    .validate = dense_validate,
    .release = linear_release,
    .bytes = linear_bytes,
    .linear = &k_linear,
};
