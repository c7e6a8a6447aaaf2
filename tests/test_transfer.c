/* test_transfer.c - the transfer-representation seam (transfer.h).
 *
 * The table lists haar, sh, vmf and cpca, finds them by name, tag and kind and refuses unknown ones;
 * each fills exactly its kind's table; configure parses each representation's options text (its
 * defaults from empty options, one line naming the key for each refusal); for each linear
 * representation the inner product of project_light and project_transport (the runtime's
 * sum_i L_i T_i, Eq. 4 in the representation's basis) matches the analytic integral of a known
 * light against a known transport, and the compressed vector through the CPU kernel (light_range)
 * matches the dense sum; each linear representation's file section round-trips through prtfile
 * and its validator refuses indices beyond its basis; a version-1 file is refused with one line
 * saying to precompute again; no source outside a representation's folder names one. */
#include "harness.h"
#include "cubemap.h"
#include "linear.h"
#include "prtfile.h"
#include "transfer.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* The representation of that name (the table's; a failed check when absent). */
static const transfer_ops *rep(const char *name) {
    const transfer_ops *o = transfer_find(name);
    CHECK(o != NULL, "no %s in the table", name);
    return o;
}

/* The table: the three representations, by index, name, tag and kind; nothing else. */
static void table(void) {
    const transfer_ops *haar = rep("haar"), *sh = rep("sh"), *vmf = rep("vmf"), *cpca = rep("cpca");
    if (!haar || !sh || !vmf || !cpca) return;
    CHECK(transfer_count() == 4, "%d representations", transfer_count());
    CHECK(transfer_at(0) == haar && transfer_at(1) == sh && transfer_at(2) == vmf && transfer_at(3) == cpca, "haar, sh, vmf, cpca");
    CHECK(transfer_find("sg") == NULL && transfer_find("") == NULL && transfer_find(NULL) == NULL, "unknown names refused");
    CHECK(transfer_find("HAAR") == NULL, "names are case-sensitive");
    CHECK(transfer_by_tag(haar->tag) == haar && transfer_by_tag(sh->tag) == sh && transfer_by_tag(vmf->tag) == vmf, "by tag");
    CHECK(transfer_by_tag(0) == NULL && transfer_by_tag(TRANSFER_TAG('M', 'E', 'S', 'H')) == NULL, "no section tags");
    CHECK(haar->tag != sh->tag && vmf->tag != haar->tag && vmf->tag != sh->tag && cpca->tag != haar->tag &&
          cpca->tag != sh->tag && cpca->tag != vmf->tag, "distinct tags");
    CHECK(transfer_by_tag(cpca->tag) == cpca, "cpca by tag");
    CHECK(transfer_default(TRANSFER_LINEAR) == haar && transfer_default(TRANSFER_VIEW) == vmf, "the defaults of each kind");
    char names[64];
    transfer_names(0, names, sizeof names);
    CHECK(!strcmp(names, "haar, sh, vmf, cpca"), "names: %s", names);
    transfer_names(0, names, 6);
    CHECK(!strcmp(names, "haar,"), "truncated: %s", names);
    transfer_names(TRANSFER_LINEAR, names, sizeof names);
    CHECK(!strcmp(names, "haar, sh, cpca"), "linear names: %s", names);
    transfer_names(TRANSFER_VIEW, names, sizeof names);
    CHECK(!strcmp(names, "vmf"), "view names: %s", names);
    for (int i = 0; i < transfer_count(); i++) {
        const transfer_ops *o = transfer_at(i);
        CHECK(o->name && o->title && o->label && o->configure && o->describe && o->write && o->read && o->validate &&
              o->release && o->bytes, "%s fills the common part", o->name);
        CHECK((o->kind == TRANSFER_LINEAR) == (o->linear != NULL) && (o->kind == TRANSFER_VIEW) == (o->view != NULL),
              "%s fills exactly its kind's table", o->name);
        const transfer_linear *l = o->linear;
        if (l) {
            CHECK(l->init_set && l->project_transport && l->compress && l->project_light && (l->light_range || l->light),
                  "%s fills the linear table", o->name);
            CHECK(!l->glsl || (l->glsl->decode && l->glsl->fragment && l->glsl->buffers && l->glsl->thread && l->glsl->warp),
                  "%s GLSL", o->name);
        }
        if (o->view) CHECK(o->view->fit && o->view->precompute && o->view->shade_vertices, "%s fills the view table", o->name);
        for (const transfer_option *opt = o->options; opt && opt->key; opt++)
            CHECK(opt->help && (!opt->flag || !strncmp(opt->flag, "--", 2)) &&
                  (opt->kind == TRANSFER_OPT_INT ? opt->lo <= opt->hi : opt->words != NULL) &&
                  (opt->kind != TRANSFER_OPT_SWITCH || !opt->flag || opt->value),
                  "%s option %s: help, flag, range or words", o->name, opt->key);
    }
}

/* configure from options text: defaults, each option, and one line naming the key for each refusal. */
static void configure(void) {
    const transfer_ops *haar = rep("haar"), *sh = rep("sh"), *vmf = rep("vmf");
    if (!haar || !sh || !vmf) return;
    prt_error err;
    transfer_config c;
    transfer_setup s = { 0 };
    CHECK(haar->configure(&s, &c, &err) == 0, "%s", err.msg);
    linear_config lc = linear_config_of(&c);
    CHECK(lc.N == LINEAR_DEFAULT_N && lc.qbits == 8 && lc.order == 0 && lc.measure == LINEAR_MEASURE_SOLID_ANGLE,
          "haar defaults: N %d, %d bits, order %d, measure %d", lc.N, lc.qbits, lc.order, lc.measure);
    CHECK(sh->configure(&s, &c, &err) == 0 && linear_config_of(&c).order == 6 && linear_config_of(&c).N == 128, "sh defaults");
    s.options = "measure=texels";
    CHECK(haar->configure(&s, &c, &err) == 0 && linear_config_of(&c).measure == 0, "measure=texels: %s", err.msg);
    s = (transfer_setup){ .options = "order=4,", .N = 9, .qbits = 32 };
    lc = (sh->configure(&s, &c, &err) == 0) ? linear_config_of(&c) : (linear_config){ 0 };
    CHECK(lc.order == 4 && lc.N == 9 && lc.qbits == 32, "sh order=4 with N 9 at 32 bits: %s", err.msg);
    transfer_config c1, c2;
    s = (transfer_setup){ .options = "level=1,samples=16" };
    CHECK(vmf->configure(&s, &c1, &err) == 0, "%s", err.msg);
    s.options = "samples=16,level=1";
    CHECK(vmf->configure(&s, &c2, &err) == 0 && !memcmp(&c1, &c2, sizeof c1), "the same options give the same bytes");
    struct { const transfer_ops *o; transfer_setup s; const char *want; } bad[] = {
        { sh, { .options = "order=2" }, "order = '2' (must be 3..10)" },
        { sh, { .options = "order=11" }, "order = '11'" },
        { sh, { .options = "order=x" }, "order = 'x'" },
        { haar, { .options = "order=3" }, "unknown option 'order'" },
        { haar, { .options = "select=best" }, "select = 'best' (must be expected|magnitude)" },
        { haar, { .options = "measure" }, "'measure' has no value" },
        { haar, { .options = "measure=texels,select=expected" }, "(select=expected) needs the solid-angle measure" },
        { haar, { .options = "select=magnitude", .light_prior = "city.exr" }, "a light prior weighs" },
        { haar, { .N = -1 }, "N = -1" },
        { sh, { .N = CUBE_TEXELS + 1 }, "N = 24577" },
        { haar, { .qbits = 12 }, "qbits = 12" },
        { sh, { .light_prior = "city.exr" }, "light prior" },
        { vmf, { .options = "lobes=5" }, "lobes = '5' (must be 1..4)" },
        { vmf, { .N = 64 }, "do not apply" },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err.msg[0] = 0;
        CHECK(bad[i].o->configure(&bad[i].s, &c, &err) == -1 && strstr(err.msg, bad[i].want) && !strchr(err.msg, '\n'),
              "%s refusal %zu: '%s'", bad[i].o->name, i, err.msg);
    }
    /* the scene's light prior with a selection that cannot use it: left out, not refused */
    s = (transfer_setup){ .options = "select=magnitude", .light_prior = "city.exr", .light_prior_scene = true };
    CHECK(haar->configure(&s, &c, &err) == 0, "the scene's prior with select=magnitude: %s", err.msg);
    char line[256];
    s = (transfer_setup){ .N = 64, .qbits = 16 };
    haar->configure(&s, &c, &err);
    haar->describe(&c, line, sizeof line);
    CHECK(!strcmp(line, "Haar wavelets, N=64 of 24576 coefficients per vector, 16-bit, per steradian"), "%s", line);
    s = (transfer_setup){ .options = "order=4" };
    sh->configure(&s, &c, &err);
    sh->describe(&c, line, sizeof line);
    CHECK(!strcmp(line, "spherical harmonics of order 4 (16 coefficients; N=128)"), "%s", line);
}

/* The known light and transport: L(w) = a + b.w per channel (band-limited: bands 0 and 1) and
 * T(w) = max(n.w, 0) with solid angle (Eq. 3 for an unoccluded Lambert vertex with g = 1). Their
 * integral is exact: int (a + b.w) max(n.w, 0) dw = a pi + (2 pi / 3) b.n. */
static const float k_a[3] = { 1.0f, 0.5f, 2.0f };
static const float k_b[3][3] = { { 0.5f, 0.3f, -0.2f }, { -0.4f, 0.1f, 0.25f }, { 0.0f, 0.9f, 0.0f } };

static void known_signals(const float n[3], float *cube_rgb, float *T) {
    for (int j = 0; j < CUBE_TEXELS; j++) {
        float w[3];
        cube_texel_dir(CUBE_RES, j, w);
        int f = j % (CUBE_RES * CUBE_RES);
        double dw = cube_texel_solid_angle(CUBE_RES, f % CUBE_RES, f / CUBE_RES);
        double nw = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
        T[j] = (float)(nw > 0 ? nw * dw : 0);
        for (int ch = 0; ch < 3; ch++) cube_rgb[3 * j + ch] = k_a[ch] + k_b[ch][0] * w[0] + k_b[ch][1] * w[1] + k_b[ch][2] * w[2];
    }
}

/* sum_i L_i T_i of ops (projected light and transport, dense) against the analytic integral and
 * the texel-domain sum sum_j L_j T_j; then the compressed vector through the CPU kernel. */
static void inner_product(const transfer_ops *ops, const char *options, double bound_analytic) {
    prt_error err;
    transfer_config cfg;
    transfer_setup setup = { .options = options, .N = CUBE_TEXELS, .qbits = 32 };
    CHECK(ops->configure(&setup, &cfg, &err) == 0, "%s", err.msg);
    const transfer_linear *lin = ops->linear;
    float n[3] = { 1, 2, 0.5f };
    float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; k++) n[k] /= len;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *T = malloc(sizeof(float) * CUBE_TEXELS);
    float *c = malloc(sizeof(float) * 3 * CUBE_TEXELS), *scratch = malloc(sizeof(float) * TRANSFER_SCRATCH_FLOATS);
    known_signals(n, cube, T);
    float (*L)[4] = transfer_light_alloc();
    lin->project_light(&cfg, cube, L);
    /* the same transport in every channel (g = 1, grey) */
    lin->project_transport(&cfg, T, c, scratch);
    memcpy(c + CUBE_TEXELS, c, sizeof(float) * CUBE_TEXELS);
    memcpy(c + 2 * CUBE_TEXELS, c, sizeof(float) * CUBE_TEXELS);
    double dense[3], absLT[3];
    for (int ch = 0; ch < 3; ch++) {
        double s = 0, texel = 0, absT = 0;
        absLT[ch] = 0;
        for (int i = 0; i < CUBE_TEXELS; i++) {
            s += (double)L[i][ch] * c[i];
            absLT[ch] += fabs((double)L[i][ch] * c[i]);
            texel += (double)cube[3 * i + ch] * T[i];
            absT += fabs(c[i]);
        }
        dense[ch] = s;
        double exact = k_a[ch] * M_PI + 2 * M_PI / 3 * (k_b[ch][0] * n[0] + k_b[ch][1] * n[1] + k_b[ch][2] * n[2]);
        CHECK_NEAR(s, exact, bound_analytic * fabs(exact), "%s channel %d against the analytic integral", ops->name, ch);
        /* Haar is orthonormal: by Parseval the wavelet-domain sum equals the texel-domain one up to
         * the light's 16-bit step (max |L| / 32767 per coefficient, half of it at most). */
        if (!strcmp(ops->name, "haar")) {
            double maxL = 0;
            for (int i = 0; i < CUBE_TEXELS; i++) maxL = fmax(maxL, fabs(L[i][ch]));
            CHECK_NEAR(s, texel, absT * maxL / 32767 / 2 + 1e-5 * fabs(texel), "haar channel %d: Parseval", ch);
        }
        printf("%s: channel %d: sum L_i T_i %.6f, analytic %.6f (rel %.2e), texel sum %.6f\n", ops->name, ch, s, exact,
               fabs(s - exact) / fabs(exact), texel);
    }
    /* Compressed (every non-zero kept, float) and run through the CPU kernel: the dense sum. */
    int one = 1;
    prt_transport t = { 0 };
    CHECK(lin->init_set(&cfg, &(transfer_linear_run){ 0 }, &t, 1, &one, &err) == 0, "%s", err.msg);
    void *ts = malloc(transport_scratch_size());
    double e2 = lin->compress(&t, 0, c, c + CUBE_TEXELS, c + 2 * CUBE_TEXELS, ts);
    /* nothing dropped, nothing quantized: the returned error sums only double rounding (~1e-16 of
     * the vector's energy, itself ~1e-2 here); 1e-12 is slack */
    CHECK_LE(e2, 1e-12, "%s: nothing lost with every coefficient kept in float", ops->name);
    CHECK(transport_finish(&t, &err) == 0, "%s", err.msg);
    int order = linear_config_of(&cfg).order;
    if (!strcmp(ops->name, "sh"))
        CHECK(transport_ncoefs(&t) <= (size_t)(3 * order * order), "sh keeps at most 3 order^2 values: %zu", transport_ncoefs(&t));
    float g[3] = { 0, 0, 0 };
    lin->light_range(&t, (const float (*)[4])L, g, 0, 1);
    /* The kernel sums n products in float: the rounding bound (n + 1) u sum |L_i T_i| (u = 2^-24). */
    double nterms = (double)t.coef_first[1];
    for (int ch = 0; ch < 3; ch++)
        CHECK_NEAR(g[ch], dense[ch], (nterms + 1) * 5.96e-8 * absLT[ch] + 1e-7,
                   "%s kernel channel %d", ops->name, ch);
    transport_free(&t);
    free(ts); free(cube); free(T); free(c); free(scratch); free(L);
}

/* Haar: the light is thresholded at 1e-12 and 16-bit, the transport exact: within 1e-4 relative of the
 * analytic value (the 64^2 cube's texel-centre quadrature of the cosine and the light's 16-bit step;
 * measured up to 1.6e-5). */
static void inner_product_haar(void) { inner_product(rep("haar"), "measure=texels", 1e-4); }
/* SH order 4: the light is band-limited (bands 0, 1), so the product integral is exact in the basis up
 * to the cube's discrete orthonormality and quadrature: within 1e-4 relative (measured up to 9e-6). */
static void inner_product_sh(void) { inner_product(rep("sh"), "order=4", 1e-4); }

/* A one-triangle scene with a Lambert material (K = 1) and a transfer of ops over it, each vertex's
 * vector projected from the cosine transport of a different normal and compressed (N, qbits). */
static void make_data(prt_data *d, const transfer_ops *ops, int N, int qbits, const char *options) {
    memset(d, 0, sizeof *d);
    d->scene.floor_first_vertex = -1;
    prt_mesh *m = &d->scene.mesh;
    m->nverts = 3;
    m->ntris = 1;
    m->pos = calloc(9, sizeof(float));
    m->nrm = calloc(9, sizeof(float));
    m->tris = calloc(3, sizeof(uint32_t));
    m->mat = calloc(3, sizeof(uint16_t));
    for (int v = 0; v < 3; v++) {
        m->pos[3 * v + v] = 1;
        m->nrm[3 * v + (v + 1) % 3] = 1;
        m->tris[v] = (uint32_t)v;
    }
    d->scene.nmaterials = 1;
    d->scene.materials[0] = (brdf_params){ .type = BRDF_LAMBERT, .kd = { 0.5f, 0.5f, 0.5f } };
    strcpy(d->scene.material_spec[0], "lambert:kd=0.5");
    brdf_factor *f = &d->factors[0];
    f->K = 1;
    f->res = 2;
    f->nsigma = 1;
    f->lambertian = true;
    f->light = calloc(12, sizeof(float));
    f->view = calloc(12, sizeof(float));
    for (int i = 0; i < 12; i++) f->light[i] = f->view[i] = 0.5f;
    d->vis_res = 128;
    d->gather_res = 32;
    prt_error err;
    transfer_config cfg;
    transfer_setup setup = { .options = options, .N = N, .qbits = qbits };
    CHECK(ops->configure(&setup, &cfg, &err) == 0, "%s", err.msg);
    prt_transfer *tr = prt_data_add_transfer(d, ops, &cfg, 1);
    int nv[3] = { 1, 1, 1 };
    CHECK(ops->linear->init_set(&cfg, &(transfer_linear_run){ 0 }, &tr->transport, 3, nv, &err) == 0, "%s", err.msg);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *T = malloc(sizeof(float) * CUBE_TEXELS);
    float *c = malloc(sizeof(float) * 3 * CUBE_TEXELS), *scratch = malloc(sizeof(float) * TRANSFER_SCRATCH_FLOATS);
    void *ts = malloc(transport_scratch_size());
    for (int v = 0; v < 3; v++) {
        known_signals(m->nrm + 3 * v, cube, T);
        ops->linear->project_transport(&cfg, T, c, scratch);
        for (int i = 0; i < CUBE_TEXELS; i++) c[CUBE_TEXELS + i] = 0.5f * c[i], c[2 * CUBE_TEXELS + i] = 0.25f * c[i];
        ops->linear->compress(&tr->transport, v, c, c + CUBE_TEXELS, c + 2 * CUBE_TEXELS, ts);
    }
    CHECK(transport_finish(&tr->transport, &err) == 0, "%s", err.msg);
    free(cube); free(T); free(c); free(scratch); free(ts);
}

/* Write, read, compare the transfer field by field, re-write to identical bytes. */
static void section_round_trip(const transfer_ops *ops, int N, int qbits, const char *options) {
    prt_error err;
    prt_data a, b;
    make_data(&a, ops, N, qbits, options);
    char path[512], path2[512];
    snprintf(path, sizeof path, "%s/%s%d.prt", check_tmpdir(), ops->name, qbits);
    snprintf(path2, sizeof path2, "%s/%s%d_again.prt", check_tmpdir(), ops->name, qbits);
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    CHECK(prtfile_read(path, &b, &err) == 0, "%s", err.msg);
    if (b.ntransfers == 1) {
        const prt_transfer *x = &a.transfers[0], *y = &b.transfers[0];
        /* what the file keeps of the config: the linear fields (the precompute's own options are not stored) */
        linear_config lx = linear_config_of(&x->cfg), ly = linear_config_of(&y->cfg);
        CHECK(y->ops == ops && y->materials == 1 && !memcmp(&lx, &ly, sizeof lx), "%s representation and config", ops->name);
        const prt_transport *s = &x->transport, *t = &y->transport;
        size_t nc = transport_ncoefs(s);
        CHECK(t->nvecs == 3 && transport_ncoefs(t) == nc && transport_nruns(t) == transport_nruns(s), "%s sizes", ops->name);
        float *d1 = malloc(sizeof(float) * 3 * CUBE_TEXELS), *d2 = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        for (int i = 0; i < 3; i++) {
            transport_decode(s, i, d1, d1 + CUBE_TEXELS, d1 + 2 * CUBE_TEXELS);
            transport_decode(t, i, d2, d2 + CUBE_TEXELS, d2 + 2 * CUBE_TEXELS);
            CHECK(!memcmp(d1, d2, sizeof(float) * 3 * CUBE_TEXELS), "%s vector %d decodes identically", ops->name, i);
        }
        free(d1); free(d2);
        CHECK(y->direct.nvecs == 0, "no direct set");
        CHECK(prtfile_write(path2, &b, &err) == 0, "%s", err.msg);
        size_t n1 = 0, n2 = 0;
        unsigned char *b1 = (unsigned char *)check_read_file(path, &n1), *b2 = (unsigned char *)check_read_file(path2, &n2);
        CHECK(n1 == n2 && n1 > 0 && !memcmp(b1, b2, n1), "%s re-written identically", ops->name);
        /* the section carries the representation's own tag */
        uint32_t tag = ops->tag;
        CHECK(memmem(b1, n1, &tag, 4) != NULL, "%s tag in the file", ops->name);
        free(b1); free(b2);
    } else {
        CHECK(0, "%s: %d transfers read", ops->name, b.ntransfers);
    }
    prt_data_free(&a);
    prt_data_free(&b);
}

static void section_haar(void) {
    section_round_trip(rep("haar"), 64, 8, "measure=texels");
    section_round_trip(rep("haar"), 200, 16, NULL);
}

/* SH, and its validator: an index at order^2 or beyond is refused (write and read share it). */
static void section_sh(void) {
    section_round_trip(rep("sh"), 128, 8, "order=4");
    section_round_trip(rep("sh"), 9, 32, "order=3");
    prt_error err;
    prt_data a;
    make_data(&a, rep("sh"), 128, 32, "order=4");
    prt_transport *t = &a.transfers[0].transport;
    /* vector 0's last coefficient moved from index < 16 to 16 (same block 0, still ascending) */
    uint32_t c = t->coef_first[1] - 1;
    t->offs[c] = 16;
    char path[512];
    snprintf(path, sizeof path, "%s/sh_bad.prt", check_tmpdir());
    CHECK(prtfile_write(path, &a, &err) == -1 && strstr(err.msg, "beyond the basis (16)"), "%s", err.msg);
    linear_config lc = linear_config_of(&a.transfers[0].cfg);
    lc.order = 5;   /* 25 coefficients: the same index is fine, but the config must match */
    linear_store(&a.transfers[0].cfg, &lc, sizeof lc);
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    prt_data_free(&a);
}

/* A version-1 file (the version field of a written file patched, CRC refreshed) is refused with one
 * line: the library's message and the CLI's. */
static void version1(void) {
    prt_error err;
    prt_data a, b;
    make_data(&a, rep("haar"), 64, 8, NULL);
    char path[512], old[512];
    snprintf(path, sizeof path, "%s/v2.prt", check_tmpdir());
    snprintf(old, sizeof old, "%s/v1.prt", check_tmpdir());
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    prt_data_free(&a);
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(path, &n);
    uint32_t v;
    memcpy(&v, img + 4, 4);
    CHECK(v == PRTFILE_VERSION && PRTFILE_VERSION == 3, "written as version %u", v);
    v = 1;
    memcpy(img + 4, &v, 4);
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), img, (uInt)(n - 4));
    memcpy(img + n - 4, &crc, 4);
    FILE *f = fopen(old, "wb");
    fwrite(img, 1, n, f);
    fclose(f);
    free(img);
    char want[700];
    snprintf(want, sizeof want, "%s: written by an older prt (file version 1); precompute it again", old);
    CHECK(prtfile_read(old, &b, &err) == -1 && !strcmp(err.msg, want), "message '%s'", err.msg);
    CHECK(b.ntransfers == 0 && b.scene.mesh.pos == NULL, "nothing left allocated");
    char cmd[1200], out[2048];
    snprintf(cmd, sizeof cmd, "%s info %s", check_prt_bin(), old);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 1, "prt info exit status %d", rc);
    CHECK(strstr(out, want) != NULL && strchr(out, '\n') == out + strlen(out) - 1, "one line: '%s'", out);
}

/* The basis order is the representation's business: no sh_order left in the sources. */
static void no_sh_order(void) {
    char out[4096];
    int rc = check_run("grep -rln sh_order src gpu brdf", out, sizeof out);
    CHECK(rc == 1 && out[0] == 0, "sh_order still in: %s", out);
}

/* Nothing outside a representation's folder names it (transfer.h): no lookup of a representation by a
 * literal name, no test of which table it is, none of its headers, no name constant; transfer.c,
 * the table, declares their tables; cpca's folder builds on Haar's basis and may include its headers. Run from the repository's root (as make test does). */
static void seam(void) {
    char out[8192];
    const char *cmd =
        "grep -rnE 'transfer_find\\(\"|strcmp\\([^)]*\"(haar|sh|vmf|cpca)\"|&transfer_(haar|sh|vmf|cpca)\\b|"
        "GLOSSY_VMF|PATH_VMF|have_vmf|CKPT_PASS_VMF|t_vmf|"
        "#include \"(haar|haar_run|light|prior|refit|vmf|vmfpass|geogrid|phash|shbasis|linear|cpca)\\.h\"' "
        "src gpu brdf --include='*.c' --include='*.h' --include='*.cpp' | "
        "grep -vE '^src/transfer/(haar|sh|vmf|linear|cpca)/|^src/transfer/transfer\\.c:'";
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 1 && out[0] == 0, "a representation named outside its folder:\n%s", out);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(table);
    CHECK_CASE(configure);
    CHECK_CASE(inner_product_haar);
    CHECK_CASE(inner_product_sh);
    CHECK_CASE(section_haar);
    CHECK_CASE(section_sh);
    CHECK_CASE(version1);
    CHECK_CASE(no_sh_order);
    CHECK_CASE(seam);
    return check_summary();
}
