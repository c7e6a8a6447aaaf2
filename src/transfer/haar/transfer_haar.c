/* transfer_haar.c - the paper's representation (sections 4.1, 4.3): per face orthonormal 2D Haar
 * wavelets of the transport cube, the N best of 24,576 coefficients kept and quantized (the
 * linear family's storage, linear.h), and a light vector in the same wavelet-index order
 * quantized to 16 bits (light.h). By Parseval, sum_i L_i T_i of the full vectors equals
 * sum_j L_j T_j (Eq. 4). Its options and precompute policy: haar_run.h.
 *
 * What the wavelets approximate (measure). The paper transforms the texels T_j of Eq. 3, which
 * carry their solid angle dw_j. A cube texel at a face corner spans a fifth of the solid angle of
 * one at the centre (dw ~ (1 + x^2 + y^2)^-3/2), so even an unoccluded vertex's transport, a smooth
 * cosine lobe over the sphere, is a steep bowl on each face, and the N largest of its Haar
 * coefficients approximate it by block means that miss a point value (a sun) by an amount that
 * depends on which blocks the sun lands in: the floor's mottling and its shimmer as the light
 * turns. The solid-angle measure (the default) transforms T_j / w_j instead, with
 * w_j = (2/res)^2 (1 + x^2 + y^2)^-3/2 the differential solid angle at the texel centre (within
 * 0.025% of the exact dw_j; any fixed positive weight keeps the product exact, since the light
 * vector is built from L_j w_j: sum_j (L_j w_j)(T_j / w_j) = sum_j L_j T_j). The transport per
 * steradian is the cosine times the visibility and the BRDF, flat where the texels were steep, so
 * truncation keeps what varies with visibility. Truncation also drops a share of each face's
 * integral (W's details correlate with T/w's): transport_store puts it back per 16x16-texel block
 * of each face into the coarse coefficients (transport.h, block_level), or on a face with no
 * occluder edge weighted by the transport (smooth_faces). docs/design/representations.md has the
 * measurements behind these choices. The file stores the measure (linear.h, flag bit 1). */
#include "transfer.h"
#include "haar.h"
#include "haar_run.h"
#include "light.h"
#include "linear.h"
#include <math.h>
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

/* The options (haar_run.h); the order is that of `prt precompute --help`. */
enum { OPT_MEASURE, OPT_SELECT, OPT_TEXELS, OPT_REFIT, OPT_SMOOTH, OPT_BUDGET, OPT_YAWS, NOPTS };
static const transfer_option k_options[NOPTS + 1] = {
    [OPT_MEASURE] = { .key = "measure", .kind = TRANSFER_OPT_SWITCH, .words = "solid_angle|texels", .flag = "--texel-measure",
                      .value = "texels",
                      .help = "Haar wavelets of the texels with their solid angle (the paper's;\n"
                              "default: of the transport per steradian, steadier under a sun)" },
    [OPT_SELECT] = { .key = "select", .kind = TRANSFER_OPT_WORD, .words = "expected|magnitude", .flag = "--select",
                     .arg = "expected|magnitude",
                     .help = "which N coefficients a vector keeps: expected (default) the\n"
                             "N largest weighted by the light's typical energy per Haar level\n"
                             "(the least expected error under probes with a sun); magnitude\n"
                             "the N largest (the paper's; what --texel-measure and --sh use)" },
    [OPT_TEXELS] = { .key = "texels", .kind = TRANSFER_OPT_SWITCH, .words = "rays|box", .flag = "--box-texels", .value = "box",
                     .help = "with a light prior, integrate every lighting texel over its area (default: the\n"
                             "prior's brightest texels along rays placed as its light lies inside them)" },
    [OPT_REFIT] = { .key = "refit", .kind = TRANSFER_OPT_SWITCH, .words = "on|off", .flag = "--no-refit", .value = "off",
                    .help = "with a light prior, keep the kept coefficients' own values, put back as\n"
                            "below (default: refit to the prior's light per texel, the least expected\n"
                            "error of T.L as its probes turn; a per-vector budget only)" },
    [OPT_SMOOTH] = { .key = "smooth_faces", .kind = TRANSFER_OPT_SWITCH, .words = "on|off", .flag = "--no-smooth-faces",
                     .value = "off",
                     .help = "put what truncation drops back per 16x16-texel block only (default:\n"
                             "weighted by the transport on faces with no occluder edge, steadier\n"
                             "on an open floor under a turning sun)" },
    [OPT_BUDGET] = { .key = "budget", .kind = TRANSFER_OPT_WORD, .words = "auto|shared|vector|relative", .flag = "--budget",
                     .arg = "shared|vector|relative",
                     .help = "how the N x vectors coefficients are shared out:\n"
                             "shared: the best weights over all vectors win, each vector keeping\n"
                             "N/2 to 4N (a shadow edge more, a smooth one fewer; the same storage\n"
                             "at most); vector: each vector its own N (the paper's); relative:\n"
                             "shared, each weight taken over its vector's own total. shared and\n"
                             "relative are for Haar wavelets only. Default: shared up to 500,000\n"
                             "vectors, vector beyond (a shared budget's staging costs memory and\n"
                             "time) and vector with a light prior" },
    [OPT_YAWS] = { .key = "prior_yaws", .kind = TRANSFER_OPT_INT, .lo = 1, .hi = 3600,
                   .help = "the yaw angles a light prior's probes are turned through (default 360; 1: as they\n"
                           "are, and no refit: nothing varies)" },
};

/* What the options text said, before the defaults that depend on each other are filled. */
typedef struct haar_parse {
    haar_config c;
    bool texels, select_given;
} haar_parse;

static int haar_set(void *user, int i, const char *value, prt_error *err) {
    haar_parse *p = user;
    if (i == OPT_YAWS) return transfer_option_int("haar", &k_options[i], value, &p->c.prior_yaws, err);
    int w = transfer_option_word("haar", &k_options[i], value, err);
    if (w < 0) return -1;
    switch (i) {
    case OPT_MEASURE: p->texels = w == 1; break;
    case OPT_SELECT: p->c.select = w ? TRANSPORT_SELECT_MAGNITUDE : TRANSPORT_SELECT_EXPECTED; p->select_given = true; break;
    case OPT_TEXELS: p->c.box_texels = w == 1; break;
    case OPT_REFIT: p->c.refit = w == 0; break;
    case OPT_SMOOTH: p->c.smooth_faces = w == 0; break;
    default: p->c.budget = w == 0 ? HAAR_BUDGET_AUTO : w == 1 ? TRANSPORT_BUDGET_SHARED : w == 2 ? TRANSPORT_BUDGET_VECTOR
                                                                                          : TRANSPORT_BUDGET_RELATIVE;
    }
    return 0;
}

haar_config haar_config_of(const transfer_config *cfg) {
    haar_config c;
    memcpy(&c, cfg->bytes, sizeof c);
    return c;
}

/* Defaults (haar_run.h): solid angle, expected selection, budget auto, smooth faces, refit, rays; the
 * texel measure selects by magnitude (the expected-error prior was measured on T/w's light). A light
 * prior needs the expected-error selection: refused when asked for, the scene's left out. */
static int haar_configure(const transfer_setup *s, transfer_config *cfg, prt_error *err) {
    _Static_assert(sizeof(haar_config) <= TRANSFER_CONFIG_BYTES, "haar_config fits transfer_config");
    memset(cfg, 0, sizeof *cfg);
    haar_parse p;
    memset(&p, 0, sizeof p);
    p.c.select = TRANSPORT_SELECT_EXPECTED, p.c.budget = HAAR_BUDGET_AUTO, p.c.smooth_faces = p.c.refit = true;
    if (linear_configure(s, &p.c.lin, err) || transfer_parse_options("haar", k_options, s->options, haar_set, &p, err)) return -1;
    if (p.texels && p.select_given && p.c.select == TRANSPORT_SELECT_EXPECTED)
        return prt_fail(err, "haar: --select expected (select=expected) needs the solid-angle measure, not --texel-measure "
                             "(measure=texels): the light it weighs by is T/w's");
    if (p.texels) p.c.select = TRANSPORT_SELECT_MAGNITUDE;
    p.c.lin.measure = p.texels ? 0 : LINEAR_MEASURE_SOLID_ANGLE;
    p.c.smooth_faces = p.c.smooth_faces && !p.texels;
    if (s->light_prior && !s->light_prior_scene && p.c.select != TRANSPORT_SELECT_EXPECTED)
        return prt_fail(err, "haar: a light prior weighs the expected-error selection: not with --select magnitude or "
                             "--texel-measure (select=magnitude, measure=texels)");
    if (s->light_prior && haar_prior_list(s->light_prior, err) < 0) return -1;
    linear_store(cfg, &p.c, sizeof p.c);
    return 0;
}

/* The section (linear.h) with the leading fields; what only a precompute uses is not stored, and reads
 * as the defaults configure gives for the stored measure (so a default config round-trips to its bytes). */
static bool haar_read(prt_reader *r, prt_transfer *tr, char *why) {
    if (!linear_read(r, tr, why)) return false;
    haar_config c;
    memset(&c, 0, sizeof c);   /* padding too: configs compare as bytes */
    c.lin = linear_config_of(&tr->cfg), c.budget = HAAR_BUDGET_AUTO, c.refit = true;
    bool sa = c.lin.measure == LINEAR_MEASURE_SOLID_ANGLE;
    c.select = sa ? TRANSPORT_SELECT_EXPECTED : TRANSPORT_SELECT_MAGNITUDE;
    c.smooth_faces = sa;
    linear_store(&tr->cfg, &c, sizeof c);
    return true;
}

static bool haar_solid_angle(const transfer_config *cfg) { return linear_config_of(cfg).measure == LINEAR_MEASURE_SOLID_ANGLE; }

static void haar_describe(const transfer_config *cfg, char *buf, size_t cap) {
    linear_config lc = linear_config_of(cfg);
    snprintf(buf, cap, "Haar wavelets, N=%d of %d coefficients per vector, %d-bit%s", lc.N, CUBE_TEXELS, lc.qbits,
             haar_solid_angle(cfg) ? ", per steradian" : "");
}

/* Each face transformed on its own (section 4.1.1), wavelet-index order (haar.h); with the
 * solid-angle measure the texels are divided by w_j first (see the header comment). */
static void haar_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    float inv[CUBE_RES * CUBE_RES];
    if (haar_solid_angle(cfg)) haar_face_solid_angle(inv, CUBE_RES, true);
    haar_cube_forward_weighted(texels, CUBE_RES, haar_solid_angle(cfg) ? inv : NULL, coeffs, scratch);
}

/* The paper's relative energy threshold, 16-bit quantization (light.h); texels weighted by w_j with
 * the solid-angle measure. */
void haar_light_vector(const float *cube_rgb, bool solid_angle, float (*L)[4]) {
    float w[CUBE_RES * CUBE_RES];
    light_desc d = { 0 };
    if (solid_angle) {
        haar_face_solid_angle(w, CUBE_RES, false);
        d.face_weight = w;
    }
    light_from_cube(cube_rgb, &d, L, NULL);
}

static void haar_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    haar_light_vector(cube_rgb, haar_solid_angle(cfg), L);
}

static bool haar_validate(const struct prt_data *d, const prt_transfer *tr, char *why) {
    linear_config lc = linear_config_of(&tr->cfg);
    if (lc.order != 0) return BAD(why, "Haar transfer with order %d", lc.order);
    return linear_validate(d, tr, CUBE_TEXELS, why);
}

static const transfer_linear k_linear = {
    .begin = haar_begin,
    .init_set = haar_init_set,
    .key = haar_key,
    .end = haar_end,
    .project_transport = haar_project_transport,
    .compress = linear_compress,
    .vector_bytes = linear_vector_bytes,
    .project_light = haar_project_light,
    .light_range = transport_light_range,
    .glsl = &linear_glsl,
};

const transfer_ops transfer_haar = {
    .name = "haar",
    .title = "Haar wavelets",
    .label = "Haar",
    .tag = TRANSFER_TAG('H', 'A', 'A', 'R'),
    .kind = TRANSFER_LINEAR,
    .options = k_options,
    .configure = haar_configure,
    .describe = haar_describe,
    .write = linear_write,
    .read = haar_read,
    .validate = haar_validate,
    .release = linear_release,
    .bytes = linear_bytes,
    .linear = &k_linear,
};
