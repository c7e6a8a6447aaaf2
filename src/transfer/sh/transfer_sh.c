/* transfer_sh.c - spherical harmonics, the low-frequency baseline that all-frequency PRT replaces
 * (shbasis.h). A vector's order^2 coefficients sit at indices 0..order^2-1 of the linear family's
 * storage (linear.h; index l(l+1)+m), so the runtimes' T x L kernels are the Haar ones. Transport
 * texels already include their solid angle (Eq. 3), so they project as c_i = sum_j T_j Y_i(w_j); the
 * light (mean radiance per texel) as L_i = sum_j L_j Y_i(w_j) dw_j; then sum_i L_i c_i approximates
 * sum_j L_j T_j for band-limited signals. Every vector keeps its N largest by magnitude (at most
 * order^2 are non-zero). Its one option: order=3..10 (default 6; the flag --sh ORDER selects it). */
#include "transfer.h"
#include "linear.h"
#include "shbasis.h"
#include <stdio.h>
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)
#define SH_MIN 3
#define SH_MAX 10
#define SH_DEFAULT 6

static const transfer_option k_options[] = {
    { .key = "order", .kind = TRANSFER_OPT_INT, .lo = SH_MIN, .hi = SH_MAX, .flag = "--sh", .arg = "ORDER", .selects = true,
      .help = "spherical harmonics of ORDER (3..10) instead of Haar wavelets (baseline)" },
    { .key = NULL },
};

static int sh_set(void *user, int i, const char *value, prt_error *err) {
    return transfer_option_int("sh", &k_options[i], value, &((linear_config *)user)->order, err);
}

/* N and qbits of the family, the order (default SH_DEFAULT). A light prior from the command line is
 * refused (nothing here weighs by light); the scene's is left out (sh_begin says so). */
static int sh_configure(const transfer_setup *s, transfer_config *cfg, prt_error *err) {
    linear_config lc;
    memset(cfg, 0, sizeof *cfg);
    if (linear_configure(s, &lc, err)) return -1;
    lc.order = SH_DEFAULT;
    if (transfer_parse_options("sh", k_options, s->options, sh_set, &lc, err)) return -1;
    if (s->light_prior && s->light_prior[0] && !s->light_prior_scene)
        return prt_fail(err, "sh: a light prior weighs an expected-error selection, which spherical harmonics do not make");
    linear_store(cfg, &lc, sizeof lc);
    return 0;
}

static int sh_begin(const transfer_config *cfg, const transfer_setup *s, const transfer_linear_in *in, transfer_linear_run *out,
                    prt_error *err) {
    memset(out, 0, sizeof *out);
    if (s->light_prior && s->light_prior[0] && !in->quiet)
        fprintf(stderr, "note: the scene's light_prior is not used (it weighs the expected-error selection)\n");
    return 0;
}

static void sh_describe(const transfer_config *cfg, char *buf, size_t cap) {
    linear_config lc = linear_config_of(cfg);
    snprintf(buf, cap, "spherical harmonics of order %d (%d coefficients; N=%d)", lc.order, lc.order * lc.order, lc.N);
}

/* scratch gets the order^2 coefficients first (SH_MAX^2 <= TRANSFER_SCRATCH_FLOATS). */
static void sh_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    int order = linear_config_of(cfg).order;
    sh_project_cube(texels, CUBE_RES, order, false, scratch);
    memset(coeffs, 0, sizeof(float) * CUBE_TEXELS);
    memcpy(coeffs, scratch, sizeof(float) * (size_t)(order * order));
}

static void sh_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    sh_light_from_cube(cube_rgb, CUBE_RES, linear_config_of(cfg).order, L);
}

/* The order bounds the indices: nothing at or beyond order^2. */
static bool sh_validate(const struct prt_data *d, const prt_transfer *tr, char *why) {
    int order = linear_config_of(&tr->cfg).order;
    if (order < SH_MIN || order > SH_MAX) return BAD(why, "bad spherical-harmonic order %d", order);
    return linear_validate(d, tr, (uint32_t)(order * order), why);
}

static const transfer_linear k_linear = {
    .begin = sh_begin,
    .init_set = linear_init_set,
    .project_transport = sh_project_transport,
    .compress = linear_compress,
    .vector_bytes = linear_vector_bytes,
    .project_light = sh_project_light,
    .light_range = transport_light_range,
    .glsl = &linear_glsl,
};

const transfer_ops transfer_sh = {
    .name = "sh",
    .title = "spherical harmonics",
    .label = "SH",
    .tag = TRANSFER_TAG('S', 'H', 'R', 'M'),
    .kind = TRANSFER_LINEAR,
    .options = k_options,
    .configure = sh_configure,
    .describe = sh_describe,
    .write = linear_write,
    .read = linear_read,
    .validate = sh_validate,
    .release = linear_release,
    .bytes = linear_bytes,
    .linear = &k_linear,
};
