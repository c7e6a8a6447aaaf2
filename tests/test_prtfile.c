/* test_prtfile.c - prtfile.h: a hand-built prt_data (two materials with different K,
 * transport in 8-, 16- and 32-bit form) survives a write/read round trip field by
 * field and re-writes to identical bytes; damaged files (truncated at many lengths,
 * flipped bytes, wrong magic, wrong version, empty, missing, a directory) and crafted
 * files with a valid checksum but out-of-range indices each fail with one line naming
 * the file; failed writes leave no file behind; the same bytes read from memory
 * (prtfile_read_memory) give the same data and the same messages. The transport lives in a Haar
 * transfer section (transfer.h), written and validated by that module. Mapped loading:
 * prtfile_read leaves the runs and coefficients in windows of the file (data_map), which hold the
 * same values as the copies prtfile_read_memory makes and shade the same vertex colours; a file
 * without the padding (older files) maps when its array is aligned and is copied when not; bad
 * padding is refused; no read, failed or not, leaves a mapping of its file behind; the threaded CRC
 * equals zlib's. */
#include "harness.h"
#include "transport_fixture.h"
#include "prtfile.h"
#include "prtio.h"
#include "runtime.h"
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

static void *xcalloc(size_t n, size_t s) { return calloc(n ? n : 1, s); }

/* The test data: 5 vertices, 3 triangles; vertices 0-2 use material 0 (K = 1), 3-4
 * material 1 (K = 3), so 9 vectors. Vector i holds i % 5 coefficients at ascending
 * wavelet indices spread over blocks (some sharing a block). */
static void make_data(prt_data *d, int qbits) {
    memset(d, 0, sizeof *d);
    prt_scene *sc = &d->scene;
    prt_mesh *m = &sc->mesh;
    int nv = 5, nt = 3;
    m->nverts = nv;
    m->ntris = nt;
    m->pos = xcalloc(3 * nv, sizeof(float));
    m->nrm = xcalloc(3 * nv, sizeof(float));
    m->tris = xcalloc(3 * nt, sizeof(uint32_t));
    m->mat = xcalloc(nv, sizeof(uint16_t));
    for (int i = 0; i < 3 * nv; i++) {
        m->pos[i] = 0.25f * i - 1.f;
        m->nrm[i] = (i % 3 == 1) ? 1.f : 0.f;
    }
    uint32_t tris[9] = { 0, 1, 2, 2, 3, 4, 0, 2, 4 };
    memcpy(m->tris, tris, sizeof tris);
    for (int v = 0; v < nv; v++) m->mat[v] = v < 3 ? 0 : 1;
    sc->nmaterials = 2;
    sc->materials[0] = (brdf_params){ .type = BRDF_LAMBERT, .kd = { 0.8f, 0.7f, 0.6f } };
    sc->materials[1] = (brdf_params){ .type = BRDF_LAFORTUNE, .kd = { 0.1f, 0.2f, 0.3f }, .ks = { 0.5f, 0.5f, 0.5f },
                                      .n = 50, .nu = 10, .nv = 100, .alpha = 0.2f, .nlobes = 2,
                                      .lobe = { { -1, -1, 1, 20 }, { -0.5f, -0.5f, 1, 5 } } };
    strcpy(sc->material_spec[0], "lambert:kd=0.8,0.7,0.6");
    strcpy(sc->material_spec[1], "lafortune:kd=0.1,0.2,0.3;lobe=-1,-1,1,20;lobe=-0.5,-0.5,1,5");
    sc->floor_first_vertex = 3;
    for (int k = 0; k < 3; k++) { sc->bmin[k] = -1.f - k; sc->bmax[k] = 2.f + k; }
    sc->load_stats = (mesh_load_stats){ 10, 11, 12, 13, 14, 0 };

    int Ks[2] = { 1, 3 }, res[2] = { 4, 3 };
    for (int f = 0; f < 2; f++) {
        brdf_factor *F = &d->factors[f];
        F->K = Ks[f];
        F->res = res[f];
        F->param = f ? BRDF_PARAM_POLAR : BRDF_PARAM_GRID;
        size_t cnt = (size_t)res[f] * res[f] * Ks[f] * 3;
        F->light = xcalloc(cnt, sizeof(float));
        F->view = xcalloc(cnt, sizeof(float));
        for (size_t i = 0; i < cnt; i++) { F->light[i] = 0.01f * i + f; F->view[i] = -0.02f * i; }
        F->nsigma = 5 + f;
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < BRDF_MAX_SIGMA; k++) F->sigma[c][k] = k < F->nsigma ? 1.f / (k + 1 + c) : 0.f;
        for (int k = 0; k <= BRDF_MAX_SIGMA; k++) F->rel_rms[k] = k <= F->nsigma ? 1.f / (k + 1) : 0.f;
        F->lambertian = f == 0;
        F->seconds = 0.125 + f;
    }

    /* One Haar transfer covering both materials (bits 0 and 1). */
    transfer_config cfg = tfx_haar_cfg(8, qbits);
    prt_transport *t = &prt_data_add_transfer(d, transfer_find("haar"), &cfg, 3)->transport;
    t->nverts = nv;
    t->nvecs = 9;
    t->N = 8;
    t->qbits = qbits;
    t->vec_first = xcalloc(nv + 1, sizeof(uint32_t));
    for (int v = 0; v < nv; v++) t->vec_first[v + 1] = t->vec_first[v] + (uint32_t)Ks[m->mat[v]];
    t->coef_first = xcalloc(t->nvecs + 1, sizeof(uint32_t));
    t->run_first = xcalloc(t->nvecs + 1, sizeof(uint32_t));
    t->scale = xcalloc(3 * t->nvecs, sizeof(float));
    uint32_t idx[64], nc = 0;
    uint8_t runs[128];
    uint32_t nr = 0;
    for (int i = 0; i < t->nvecs; i++) {
        int n = i % 5;
        for (int k = 0; k < n; k++) idx[nc + k] = (uint32_t)(i * 7 + k * 200);   /* k*200: some pairs share a block */
        for (int k = 0; k < n; k++) {
            uint32_t b = idx[nc + k] / 256;
            if (k > 0 && idx[nc + k - 1] / 256 == b) runs[2 * nr - 1]++;
            else { runs[2 * nr] = (uint8_t)b; runs[2 * nr + 1] = 0; nr++; }
        }
        nc += n;
        t->coef_first[i + 1] = nc;
        t->run_first[i + 1] = nr;
        for (int ch = 0; ch < 3; ch++) t->scale[3 * i + ch] = qbits == 32 ? 1.f : 0.001f * (i + 1) * (ch + 1);
    }
    t->runs = xcalloc(2 * nr, 1);
    memcpy(t->runs, runs, 2 * nr);
    if (qbits == 8) {
        t->packed = xcalloc(nc, sizeof(uint32_t));
        for (uint32_t c = 0; c < nc; c++) t->packed[c] = sparse_pack8(idx[c] % 256, (int)c - 5, -(int)c, 100 - (int)c);
    } else {
        t->offs = xcalloc(nc, 1);
        for (uint32_t c = 0; c < nc; c++) t->offs[c] = (uint8_t)(idx[c] % 256);
        if (qbits == 16) {
            t->q16 = xcalloc(3 * nc, sizeof(int16_t));
            for (uint32_t c = 0; c < 3 * nc; c++) t->q16[c] = (int16_t)(1000 * (int)c - 20000);
        } else {
            t->f32 = xcalloc(3 * nc, sizeof(float));
            for (uint32_t c = 0; c < 3 * nc; c++) t->f32[c] = 0.5f * c - 3.25f;
        }
    }
    d->vis_res = 128;
    d->gather_res = 32;
    prt_stats *s = &d->stats;
    s->t_brdf = 1.5; s->t_visibility = 2.5; s->t_transport = 3.5;
    for (int b = 0; b < PRT_MAX_BOUNCES; b++) { s->t_bounce[b] = 0.1 * b; s->bounce_energy[b] = 0.01 * b; }
    s->t_write = 0.25; s->t_total = 9.75;
    s->rays_traced = 123456789012L; s->rays_hit = 987654321L; s->hit_fraction = 0.008;
    s->bounces = 2; s->trunc_rel_err = 0.0123; s->peak_rss_bytes = (size_t)3 << 30;
    snprintf(d->plan, sizeof d->plan, "direct: K=1/3 terms\nbounces: 2 (gather 32)\n");
}

#define SAME_ARR(a, b, n) ((a) && (b) && memcmp((a), (b), (n) * sizeof *(a)) == 0)

/* Field-by-field equality of everything a prt_data holds. */
static void check_same_transport(const prt_transport *s, const prt_transport *t, int qbits);

static void check_equal(const prt_data *a, const prt_data *b, int qbits) {
    const prt_mesh *ma = &a->scene.mesh, *mb = &b->scene.mesh;
    CHECK(ma->nverts == mb->nverts && ma->ntris == mb->ntris, "mesh sizes (%d)", qbits);
    CHECK(SAME_ARR(ma->pos, mb->pos, 3 * ma->nverts) && SAME_ARR(ma->nrm, mb->nrm, 3 * ma->nverts), "positions, normals");
    CHECK(SAME_ARR(ma->tris, mb->tris, 3 * ma->ntris) && SAME_ARR(ma->mat, mb->mat, ma->nverts), "triangles, materials");
    CHECK(a->scene.nmaterials == b->scene.nmaterials);
    CHECK(a->scene.floor_first_vertex == b->scene.floor_first_vertex);
    CHECK(memcmp(a->scene.bmin, b->scene.bmin, sizeof a->scene.bmin) == 0 && memcmp(a->scene.bmax, b->scene.bmax, sizeof a->scene.bmax) == 0);
    CHECK(memcmp(&a->scene.load_stats, &b->scene.load_stats, sizeof a->scene.load_stats) == 0, "load stats");
    for (int i = 0; i < a->scene.nmaterials; i++) {
        const brdf_params *p = &a->scene.materials[i], *q = &b->scene.materials[i];
        CHECK(p->type == q->type && p->n == q->n && p->nu == q->nu && p->nv == q->nv && p->alpha == q->alpha &&
              p->nlobes == q->nlobes && memcmp(p->kd, q->kd, sizeof p->kd) == 0 && memcmp(p->ks, q->ks, sizeof p->ks) == 0 &&
              memcmp(p->lobe, q->lobe, sizeof p->lobe) == 0, "material %d params", i);
        CHECK(strcmp(a->scene.material_spec[i], b->scene.material_spec[i]) == 0, "spec %d", i);
        const brdf_factor *f = &a->factors[i], *g = &b->factors[i];
        CHECK(f->K == g->K && f->res == g->res && f->param == g->param && f->nsigma == g->nsigma &&
              f->lambertian == g->lambertian && f->seconds == g->seconds, "factor %d fields", i);
        CHECK(memcmp(f->sigma, g->sigma, sizeof f->sigma) == 0 && memcmp(f->rel_rms, g->rel_rms, sizeof f->rel_rms) == 0, "factor %d sigma", i);
        size_t cnt = (size_t)f->res * f->res * f->K * 3;
        CHECK(SAME_ARR(f->light, g->light, cnt) && SAME_ARR(f->view, g->view, cnt), "factor %d maps", i);
    }
    CHECK(a->ntransfers == b->ntransfers, "transfer count %d vs %d", a->ntransfers, b->ntransfers);
    for (int i = 0; i < a->ntransfers && i < b->ntransfers; i++) {
        const prt_transfer *x = &a->transfers[i], *y = &b->transfers[i];
        CHECK(x->ops == y->ops && x->materials == y->materials && memcmp(&x->cfg, &y->cfg, sizeof x->cfg) == 0,
              "transfer %d representation, mask and config", i);
        check_same_transport(&x->transport, &y->transport, qbits);
        CHECK(x->direct.nvecs == y->direct.nvecs, "direct set present in both or neither");
        if (x->direct.nvecs && y->direct.nvecs) check_same_transport(&x->direct, &y->direct, qbits);
    }
    CHECK(a->vis_res == b->vis_res && a->gather_res == b->gather_res);
    CHECK(memcmp(&a->stats, &b->stats, sizeof a->stats) == 0, "stats");
    CHECK(strcmp(a->plan, b->plan) == 0, "plan");
}

/* Field-by-field equality of two transport sets. */
static void check_same_transport(const prt_transport *s, const prt_transport *t, int qbits) {
    CHECK(s->nverts == t->nverts && s->nvecs == t->nvecs && s->N == t->N && s->qbits == t->qbits, "transport sizes");
    size_t nc = s->coef_first[s->nvecs], nr = s->run_first[s->nvecs];
    CHECK(SAME_ARR(s->vec_first, t->vec_first, s->nverts + 1) && SAME_ARR(s->coef_first, t->coef_first, s->nvecs + 1) &&
          SAME_ARR(s->run_first, t->run_first, s->nvecs + 1), "transport offsets");
    CHECK(SAME_ARR(s->runs, t->runs, 2 * nr) && SAME_ARR(s->scale, t->scale, 3 * s->nvecs), "runs, scales");
    if (qbits == 8) CHECK(SAME_ARR(s->packed, t->packed, nc) && !t->offs && !t->q16 && !t->f32, "8-bit coefficients");
    if (qbits == 16) CHECK(SAME_ARR(s->offs, t->offs, nc) && SAME_ARR(s->q16, t->q16, 3 * nc) && !t->packed && !t->f32, "16-bit");
    if (qbits == 32) CHECK(SAME_ARR(s->offs, t->offs, nc) && SAME_ARR(s->f32, t->f32, 3 * nc) && !t->packed && !t->q16, "float");
    CHECK(!t->stage_count && !t->stage_idx && !t->stage_val);
}

static void spit(const char *path, const void *b, size_t n) {
    FILE *f = fopen(path, "wb");
    fwrite(b, 1, n, f);
    fclose(f);
}

static int count_files(const char *dir, const char *needle) {
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (strstr(e->d_name, needle)) n++;
    if (d) closedir(d);
    return n;
}

/* Lines of /proc/self/maps naming path: this process's mappings of that file. */
static int mappings_of(const char *path) {
    FILE *f = fopen("/proc/self/maps", "r");
    char line[4096];
    int n = 0;
    while (f && fgets(line, sizeof line, f))
        if (strstr(line, path)) n++;
    if (f) fclose(f);
    return n;
}

/* Reading path fails with one line that names it (and contains want, if given). */
static void expect_fail(const char *path, const char *name, const char *want, const char *what) {
    prt_data d;
    prt_error err = { { 0 } };
    int rc = prtfile_read(path, &d, &err);
    CHECK(rc == -1, "%s: read should fail", what);
    CHECK(strstr(err.msg, name) != NULL, "%s: message '%s' names the file", what, err.msg);
    CHECK(strchr(err.msg, '\n') == NULL, "%s: one line", what);
    if (want) CHECK(strstr(err.msg, want) != NULL, "%s: message '%s' should say '%s'", what, err.msg, want);
    CHECK(d.scene.mesh.pos == NULL && d.ntransfers == 0, "%s: nothing left allocated", what);
    CHECK(mappings_of(path) == 0, "%s: no mapping of the file left", what);
}

/* Offset of section tag's contents in a file image (walking the section headers). */
static size_t section(const unsigned char *b, size_t n, const char *tag) {
    size_t pos = 16;
    while (pos + 12 <= n - 4) {
        uint64_t len;
        memcpy(&len, b + pos + 4, 8);
        if (memcmp(b + pos, tag, 4) == 0) return pos + 12;
        pos += 12 + len;
    }
    return 0;
}

/* Writes a copy of the file image with 4 bytes at off replaced by v and a fresh CRC. */
static void patch32(const char *path, const unsigned char *b, size_t n, size_t off, uint32_t v) {
    unsigned char *c = malloc(n);
    memcpy(c, b, n);
    memcpy(c + off, &v, 4);
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), c, (uInt)(n - 4));
    memcpy(c + n - 4, &crc, 4);
    spit(path, c, n);
    free(c);
}

/* Writes the q-bit test data to DIR/rtQ.prt (if not there yet) and returns its path. */
static const char *written(int q) {
    static char path[4][512];
    char *p = path[q / 8 - 1 < 3 ? q / 8 - 1 : 3];
    snprintf(p, 512, "%s/rt%d.prt", check_tmpdir(), q);
    struct stat st;
    if (stat(p, &st) != 0) {
        prt_data a;
        prt_error err;
        make_data(&a, q);
        CHECK(prtfile_write(p, &a, &err) == 0, "%s", err.msg);
        prt_data_free(&a);
    }
    return p;
}

/* Round trips at 8, 16 and 32 bits: field by field, and re-written bytes identical. */
static void round_trip(void) {
    const char *dir = check_tmpdir();
    char path[512], path2[512];
    prt_error err;
    for (int q = 8; q <= 32; q *= 2) {
        prt_data a, b;
        make_data(&a, q);
        snprintf(path, sizeof path, "%s/rt%d.prt", dir, q);
        CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
        CHECK(prtfile_read(path, &b, &err) == 0, "%s", err.msg);
        if (b.scene.mesh.pos) check_equal(&a, &b, q);
        /* Re-writing what was read gives the same bytes. */
        snprintf(path2, sizeof path2, "%s/rt%d_again.prt", dir, q);
        CHECK(prtfile_write(path2, &b, &err) == 0, "%s", err.msg);
        size_t n1 = 0, n2 = 0;
        unsigned char *b1 = (unsigned char *)check_read_file(path, &n1), *b2 = (unsigned char *)check_read_file(path2, &n2);
        CHECK(n1 == n2 && n1 > 0 && memcmp(b1, b2, n1) == 0, "re-written file identical (%d-bit)", q);
        free(b1);
        free(b2);
        prt_data_free(&a);
        prt_data_free(&b);
        CHECK(b.scene.mesh.pos == NULL && b.ntransfers == 0 && b.factors[1].light == NULL, "freed and zeroed");
    }
    CHECK(count_files(dir, ".tmp.") == 0, "no temporaries after writes");
}

/* The optional direct-only set (inside the transfer section) round-trips beside the total
 * transport, and a file without it reads with an empty direct set. */
static void direct_set(void) {
    char path[512];
    prt_error err;
    prt_data a, b, c;
    make_data(&a, 8);
    make_data(&c, 8);
    a.transfers[0].direct = c.transfers[0].transport;    /* same layout, moved in */
    memset(&c.transfers[0].transport, 0, sizeof c.transfers[0].transport);
    prt_data_free(&c);
    snprintf(path, sizeof path, "%s/dirt.prt", check_tmpdir());
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    CHECK(prtfile_read(path, &b, &err) == 0, "%s", err.msg);
    if (b.scene.mesh.pos) check_equal(&a, &b, 8);
    CHECK(b.ntransfers == 1 && b.transfers[0].direct.nvecs == a.transfers[0].transport.nvecs, "direct set read back");
    prt_data_free(&b);
    CHECK(prtfile_read(written(8), &b, &err) == 0 && b.transfers[0].direct.nvecs == 0 && b.transfers[0].direct.packed == NULL,
          "no direct set: empty set");
    prt_data_free(&b);
    prt_data_free(&a);
}

/* Truncated at many lengths, then single flipped bytes: one line each. */
static void truncated_and_flipped(void) {
    char bad[512];
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(written(16), &n);
    CHECK(n > 200, "file size %zu", n);
    snprintf(bad, sizeof bad, "%s/bad.prt", check_tmpdir());
    size_t cuts[] = { 0, 1, 3, 4, 10, 16, 19, 20, 27, 100, n / 2, n - 5, n - 4, n - 1 };
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        spit(bad, img, cuts[i]);
        char what[64];
        snprintf(what, sizeof what, "truncated to %zu bytes", cuts[i]);
        expect_fail(bad, "bad.prt", cuts[i] == 0 ? "empty" : cuts[i] < 4 ? "not a prt file" : "truncated", what);
    }
    size_t flips[] = { 0, 5, 9, 20, 40, n / 3, n / 2, n - 30, n - 2 };
    for (size_t i = 0; i < sizeof flips / sizeof flips[0]; i++) {
        img[flips[i]] ^= 0x10;
        spit(bad, img, n);
        img[flips[i]] ^= 0x10;
        char what[64];
        snprintf(what, sizeof what, "byte %zu flipped", flips[i]);
        /* Past the header every flip is caught by the checksum. */
        expect_fail(bad, "bad.prt", flips[i] >= 16 ? "corrupt (checksum mismatch)" : NULL, what);
    }
    free(img);
}

/* Wrong magic, a newer version, trailing bytes, a missing file, a directory. */
static void header(void) {
    const char *dir = check_tmpdir();
    char bad[512];
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(written(16), &n);
    snprintf(bad, sizeof bad, "%s/bad.prt", dir);
    memcpy(img, "PRTX", 4);
    spit(bad, img, n);
    memcpy(img, "PRTF", 4);
    expect_fail(bad, "bad.prt", "not a prt file", "wrong magic");
    img[4] = 7;
    spit(bad, img, n);
    img[4] = PRTFILE_VERSION;
    expect_fail(bad, "bad.prt", "bad.prt: version 7 not supported (expected 2 to 3)", "wrong version");
    img[4] = 1;
    spit(bad, img, n);
    img[4] = PRTFILE_VERSION;
    expect_fail(bad, "bad.prt", "bad.prt: written by an older prt (file version 1); precompute it again", "version 1");
    unsigned char *longer = malloc(n + 3);
    memcpy(longer, img, n);
    memset(longer + n, 0, 3);
    spit(bad, longer, n + 3);
    free(longer);
    expect_fail(bad, "bad.prt", "corrupt", "trailing bytes");
    snprintf(bad, sizeof bad, "%s/missing.prt", dir);
    expect_fail(bad, "missing.prt", "cannot open", "missing file");
    snprintf(bad, sizeof bad, "%s/adir.prt", dir);
    mkdir(bad, 0755);
    expect_fail(bad, "adir.prt", NULL, "a directory");
    free(img);
}

/* Bytes of the Haar section before its transport: N, qbits, order, material mask, direct flag. */
#define TRANSFER_HEAD (12 + 8 + 1)

/* Crafted files: valid checksum, contents out of range. */
static void crafted(void) {
    char bad[512];
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(written(16), &n);
    snprintf(bad, sizeof bad, "%s/crafted.prt", check_tmpdir());
    size_t mesh = section(img, n, "MESH"), matl = section(img, n, "MATL"), haar = section(img, n, "HAAR");
    CHECK(mesh && matl && haar, "sections found");
    size_t tran = haar + TRANSFER_HEAD;
    int nv = 5, nvec = 9;
    size_t tris = mesh + 8 + 24 * (size_t)nv, mats = tris + 36;
    size_t k0 = matl + 4 + 4 + 24 + 16 + 4 + 64 + 4 + strlen("lambert:kd=0.8,0.7,0.6");   /* material 0's K */
    size_t vecf = tran + 32, coeff = vecf + 4 * (nv + 1), runf = coeff + 4 * (nvec + 1), runs = runf + 4 * (nvec + 1);
    struct { size_t off; uint32_t v; const char *want; const char *what; } crafts[] = {
        { tris, 5, "triangle", "triangle index = nverts" },
        { tris + 8, 0xffffffffu, "triangle", "triangle index 2^32-1" },
        { mats, 2 | (0u << 16), "material", "vertex material = nmaterials" },
        { mesh, 0x7ffffff0u, "mesh size", "huge vertex count" },
        { mesh, 100000000u, "MESH section too short", "vertex count larger than the section" },
        { mesh + 8, 0x7fc00000u, "non-finite", "NaN position" },
        { k0, 65, "K = 65", "K = 65" },
        { k0, 2, NULL, "K disagrees with the vertices' vector counts" },
        { k0 + 4, 100000, "resolution", "BRDF map resolution 100000" },
        { vecf + 4, 2, "vector", "vertex 0 with 2 vectors (K = 1)" },
        { coeff + 4 * 2, 0, "coefficient", "coefficient offsets decreasing" },
        { runf + 4 * 9, 99, NULL, "run offsets past the runs" },
        { runs, 96 | (0u << 8), "block", "block 96" },
        { tran + 16, 1000, NULL, "coefficient total inflated" },
        { tran + 12, 12, "quantization", "qbits 12" },
        { tran + 8, 0, "N = 0", "N = 0" },
        { tran, 4, NULL, "transport vertex count differs from the mesh" },
        { haar, 9, "disagree", "config N differs from the transport's (was META vs TRAN)" },
        { haar + 8, 3, "order", "Haar transfer with an order" },
        { haar + 12, 1, "material 1 has no transfer", "mask without material 1" },
        { haar + 12, 7, "beyond", "mask naming material 2 of 2" },
    };
    for (size_t i = 0; i < sizeof crafts / sizeof crafts[0]; i++) {
        /* Keep the other bytes of a 4-byte window when patching a smaller field. */
        uint32_t v = crafts[i].v;
        if (crafts[i].off == mats) { uint16_t hi; memcpy(&hi, img + mats + 2, 2); v = (v & 0xffff) | (uint32_t)hi << 16; }
        if (crafts[i].off == runs) v = (v & 0xff) | (uint32_t)img[runs + 1] << 8 | (uint32_t)img[runs + 2] << 16 | (uint32_t)img[runs + 3] << 24;
        patch32(bad, img, n, crafts[i].off, v);
        char what[160];
        snprintf(what, sizeof what, "crafted: %s", crafts[i].what);
        expect_fail(bad, "crafted.prt", crafts[i].want, what);
    }
    /* A run claiming one more coefficient than the vector has. */
    prt_data a;
    make_data(&a, 16);
    const prt_transport *t = &a.transfers[0].transport;
    size_t r = 0;
    for (int i = 0; i < nvec; i++)
        if (t->run_first[i + 1] > t->run_first[i]) { r = t->run_first[i]; break; }
    unsigned char *c = malloc(n);
    memcpy(c, img, n);
    c[runs + 2 * r + 1] += 1;
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), c, (uInt)(n - 4));
    memcpy(c + n - 4, &crc, 4);
    spit(bad, c, n);
    free(c);
    expect_fail(bad, "crafted.prt", "runs cover", "crafted: run longer than its vector");
    prt_data_free(&a);
    free(img);
}

/* Failed writes leave nothing behind. */
static void failed_writes(void) {
    const char *dir = check_tmpdir();
    char path[512];
    prt_error err;
    prt_data a;
    make_data(&a, 8);
    snprintf(path, sizeof path, "%s/nodir/x.prt", dir);
    CHECK(prtfile_write(path, &a, &err) == -1 && strstr(err.msg, "nodir/x.prt"), "%s", err.msg);
    a.scene.mesh.tris[4] = 99;   /* the writer refuses what the reader would */
    snprintf(path, sizeof path, "%s/refused.prt", dir);
    CHECK(prtfile_write(path, &a, &err) == -1 && strstr(err.msg, "refused.prt") && strstr(err.msg, "triangle"), "%s", err.msg);
    a.scene.mesh.tris[4] = 3;
    a.factors[1].view[2] = NAN;
    CHECK(prtfile_write(path, &a, &err) == -1 && strstr(err.msg, "non-finite"), "%s", err.msg);
    struct stat st;
    CHECK(stat(path, &st) != 0, "no file after a refused write");
    CHECK(count_files(dir, ".tmp.") == 0 && count_files(dir, "refused") == 0, "no temporaries after failed writes");
    snprintf(path, sizeof path, "%s/adir.prt", dir);   /* a directory in the way: rename fails */
    mkdir(path, 0755);
    a.factors[1].view[2] = 0;
    CHECK(prtfile_write(path, &a, &err) == -1 && strstr(err.msg, "adir.prt"), "%s", err.msg);
    CHECK(count_files(dir, ".tmp.") == 0, "no temporary after a failed rename");
    prt_data_free(&a);
}


/* Several transfers: prt_data_transfer is the first transfer with a light kernel; a file
 * holding only a non-linear one (vmf) is valid (its tests write one), and then it is NULL. */
static void transfers_rule(void) {
    const transfer_ops *vmf = transfer_find("vmf");
    prt_data a;
    make_data(&a, 8);
    CHECK(prt_data_transfer(&a) == &a.transfers[0], "the sparse transfer is the first with a light kernel");
    const transfer_ops *keep = a.transfers[0].ops;
    if (vmf) {
        a.transfers[0].ops = vmf;
        CHECK(prt_data_transfer(&a) == NULL, "no sparse transfer: NULL");
        a.transfers[0].ops = keep;
    }
    prt_data_free(&a);
}

/* prtfile_read_memory on a file's bytes: the data field by field; on damaged bytes (truncated,
 * flipped, empty) the same message as prtfile_read on that file, with the name for the path; the
 * bytes are only read. */
static void from_memory(void) {
    prt_error err = { { 0 } }, ferr = { { 0 } };
    for (int q = 8; q <= 32; q *= 2) {
        size_t n = 0;
        unsigned char *img = (unsigned char *)check_read_file(written(q), &n), *copy = malloc(n ? n : 1);
        memcpy(copy, img, n);
        prt_data a, b;
        make_data(&a, q);
        CHECK(prtfile_read_memory("mem.prt", img, n, &b, &err) == 0, "%d-bit from memory: %s", q, err.msg);
        if (b.scene.mesh.pos) check_equal(&a, &b, q);
        CHECK(memcmp(img, copy, n) == 0, "%d-bit: the bytes are not written", q);
        prt_data_free(&a);
        prt_data_free(&b);
        free(copy);
        free(img);
    }
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(written(16), &n);
    char bad[512];
    snprintf(bad, sizeof bad, "%s/bad.prt", check_tmpdir());
    size_t cuts[] = { 0, 3, 19, n / 2, n - 1 }, flips[] = { 5, 9, n / 2 };
    for (int i = 0; i < 8; i++) {
        size_t len = i < 5 ? cuts[i] : n, at = i < 5 ? 0 : flips[i - 5];
        if (i >= 5) img[at] ^= 0x10;
        spit(bad, img, len);
        prt_data d, e;
        int rm = prtfile_read_memory("mem.prt", img, len, &d, &err), rf = prtfile_read(bad, &e, &ferr);
        if (i >= 5) img[at] ^= 0x10;
        char want[sizeof ferr.msg + 16];
        const char *tail = strstr(ferr.msg, "bad.prt");
        snprintf(want, sizeof want, "mem.prt%s", tail ? tail + strlen("bad.prt") : "?");
        CHECK(rm == -1 && rf == -1, "case %d (%zu bytes, flip at %zu): both refused", i, len, at);
        CHECK(!strcmp(err.msg, want), "case %d: '%s', the file's '%s'", i, err.msg, ferr.msg);
        CHECK(d.scene.mesh.pos == NULL && d.ntransfers == 0, "case %d: nothing left allocated", i);
    }
    free(img);
}

/* ---- mapped loading ---------------------------------------------------------------------------- */

/* The coefficient values of a set (packed, q16 or f32). */
static const void *values_of(const prt_transport *t) {
    return t->qbits == 8 ? (const void *)t->packed : t->qbits == 16 ? (const void *)t->q16 : (const void *)t->f32;
}

/* True when t's runs and values lie in its data_map window (the mapped path). */
static bool in_window(const prt_transport *t) {
    uintptr_t a = (uintptr_t)t->data_map, b = a + t->data_mapped, v = (uintptr_t)values_of(t), r = (uintptr_t)t->runs;
    return t->data_map && v >= a && v < b && r >= a && r < b;
}

/* The cpu runtime's vertex colours of d (its direct-only set with direct) under a fixed light cube
 * that varies texel to texel, toward one eye; malloc'd, 3 per vertex. */
static float *shade(const prt_data *d, bool direct) {
    prt_error err = { { 0 } };
    float *cube = malloc(3 * CUBE_TEXELS * sizeof *cube), *rgb = calloc(3 * (size_t)d->scene.mesh.nverts, sizeof *rgb);
    for (int i = 0; i < 3 * CUBE_TEXELS; i++) cube[i] = 1.f + (float)((i * 7919) % 1000) / 250.f;
    prt_runtime *rt = runtime_create(d, &(runtime_desc){ .backend = "cpu", .threads = 1, .direct_only = direct }, &err);
    int ok = rt && runtime_set_light_cube(rt, cube, &err) == 0 && runtime_shade_vertices(rt, (float[3]){ 0.3f, 2.f, 4.f }, rgb, &err) == 0;
    CHECK(ok, "cpu runtime shades: %s", err.msg);
    runtime_destroy(rt);
    free(cube);
    return rgb;
}

/* The 8-bit test data with the direct-only set (the total's vectors again) at DIR/name. */
static const char *written_direct(const char *name) {
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", check_tmpdir(), name);
    prt_data a, c;
    prt_error err;
    make_data(&a, 8);
    make_data(&c, 8);
    a.transfers[0].direct = c.transfers[0].transport;
    memset(&c.transfers[0].transport, 0, sizeof c.transfers[0].transport);
    prt_data_free(&c);
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    prt_data_free(&a);
    return path;
}

/* prtfile_read (mapped) against prtfile_read_memory (copied) at 8, 16 and 32 bits and with the
 * direct-only set: every array equal (check_equal), the mapped sets in windows of the file with the
 * values 64-byte aligned (the writer's padding), the copies on the heap; the cpu runtime's vertex
 * colours equal bit for bit (total and direct-only); once freed, no mapping of the file is left. */
static void mapped(void) {
    const char *paths[4] = { written(8), written(16), written(32), written_direct("mapped_dirt.prt") };
    for (int k = 0; k < 4; k++) {
        int q = k < 3 ? 8 << k : 8;
        prt_error err = { { 0 } };
        size_t n = 0;
        unsigned char *img = (unsigned char *)check_read_file(paths[k], &n);
        prt_data m, c;
        int rm = prtfile_read(paths[k], &m, &err);
        CHECK(rm == 0, "mapped read: %s", err.msg);
        int rc = prtfile_read_memory("copy.prt", img, n, &c, &err);
        CHECK(rc == 0, "copied read: %s", err.msg);
        if (rm == 0 && rc == 0) {
            check_equal(&c, &m, q);
            for (int set = 0; set < (k == 3 ? 2 : 1); set++) {
                const prt_transport *tm = set ? &m.transfers[0].direct : &m.transfers[0].transport;
                const prt_transport *tc = set ? &c.transfers[0].direct : &c.transfers[0].transport;
                CHECK(in_window(tm) && (uintptr_t)values_of(tm) % 64 == 0, "%s, set %d: mapped, values 64-byte aligned", paths[k], set);
                CHECK(tc->data_map == NULL && tc->runs && values_of(tc), "%s, set %d: the copy on the heap", paths[k], set);
            }
            CHECK(mappings_of(paths[k]) >= 1, "%s: while loaded, its windows map the file", paths[k]);
            for (int direct = 0; direct < (k == 3 ? 2 : 1); direct++) {
                float *a = shade(&m, direct), *b = shade(&c, direct), top = 0;
                for (int i = 0; i < 3 * m.scene.mesh.nverts; i++) top = a[i] > top ? a[i] : top;
                CHECK(top > 0 && memcmp(a, b, 3 * (size_t)m.scene.mesh.nverts * sizeof *a) == 0,
                      "%s%s: vertex colours equal bit for bit (max %g)", paths[k], direct ? " (direct only)" : "", top);
                free(a);
                free(b);
            }
        }
        if (rm == 0) prt_data_free(&m);
        if (rc == 0) prt_data_free(&c);
        CHECK(mappings_of(paths[k]) == 0, "%s: freed, no mapping of it left", paths[k]);
        free(img);
    }
}

/* Offset in the 8- or 16/32-bit test file image of the total set's padding (its u8 count), and the
 * HAAR section's contents. */
static size_t pad_offset(const unsigned char *img, size_t n, int q, size_t *haar) {
    prt_data a;
    make_data(&a, q);
    const prt_transport *t = &a.transfers[0].transport;
    size_t nr = t->run_first[t->nvecs];
    *haar = section(img, n, "HAAR");
    size_t at = *haar + TRANSFER_HEAD + 32 + 4 * ((size_t)t->nverts + 1) + 8 * ((size_t)t->nvecs + 1) + 2 * nr + 12 * (size_t)t->nvecs;
    prt_data_free(&a);
    return at;
}

/* The file image as an older prt wrote it (version 2, no padding, flag bit 2 clear), with an unknown section of
 * j bytes before HAAR (readers skip it) to move the arrays; fresh lengths and CRC. *len: its size. */
static unsigned char *unpadded(const unsigned char *img, size_t n, size_t j, size_t *len, size_t *values_at) {
    size_t haar, at = pad_offset(img, n, 8, &haar), cut = 1 + img[at];
    unsigned char *o = calloc(n + 12 + j, 1);
    size_t h = haar - 12, w = 0;
    memcpy(o, img, h);
    memcpy(o + h, "JUNK", 4);
    uint64_t jl = j;
    memcpy(o + h + 4, &jl, 8);
    w = h + 12 + j;
    memcpy(o + w, img + h, at - h);
    w += at - h;
    memcpy(o + w, img + at + cut, n - 4 - at - cut);
    w += n - 4 - at - cut;
    *values_at = at + 12 + j;
    uint64_t payload, seclen;
    memcpy(&payload, o + 8, 8);
    payload = payload + 12 + j - cut;
    memcpy(o + 8, &payload, 8);
    memcpy(&seclen, o + haar + j + 4, 8);   /* HAAR's header now starts at haar - 12 + 12 + j */
    seclen -= cut;
    memcpy(o + haar + j + 4, &seclen, 8);
    o[haar + 12 + j + 20] &= (unsigned char)~4;
    uint32_t version = PRTFILE_VERSION_OLDEST;   /* as the prt before the padding wrote it */
    memcpy(o + 4, &version, 4);
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), o, (uInt)w);
    memcpy(o + w, &crc, 4);
    *len = w + 4;
    return o;
}

/* Files from before the padding: mapped when the values happen to be 4-byte aligned, copied when
 * not; either way the same data as the padded file read from memory. */
static void mapped_older_files(void) {
    prt_error err = { { 0 } };
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(written(8), &n);
    prt_data want;
    CHECK(prtfile_read_memory("padded.prt", img, n, &want, &err) == 0, "%s", err.msg);
    char path[512];
    snprintf(path, sizeof path, "%s/older.prt", check_tmpdir());
    int seen[2] = { 0, 0 };
    for (size_t j = 0; j < 4; j++) {
        size_t len, vat;
        unsigned char *o = unpadded(img, n, j, &len, &vat);
        spit(path, o, len);
        free(o);
        prt_data d;
        CHECK(prtfile_read(path, &d, &err) == 0, "older file, junk %zu: %s", j, err.msg);
        if (d.scene.mesh.pos) {
            check_equal(&want, &d, 8);
            bool aligned = vat % 4 == 0;
            seen[aligned]++;
            CHECK(aligned ? in_window(&d.transfers[0].transport) : d.transfers[0].transport.data_map == NULL,
                  "older file with values at %zu: %s", vat, aligned ? "mapped" : "copied");
            prt_data_free(&d);
        }
        CHECK(mappings_of(path) == 0, "older file: no mapping left");
    }
    CHECK(seen[0] == 3 && seen[1] == 1, "both paths taken (%d copied, %d mapped)", seen[0], seen[1]);
    prt_data_free(&want);
    free(img);
}

/* Padding longer than 63 bytes or not zero (with a valid CRC): refused with one line. */
static void mapped_bad_padding(void) {
    char bad[512];
    snprintf(bad, sizeof bad, "%s/badpad.prt", check_tmpdir());
    int nonzero = 0;
    for (int q = 8; q <= 32; q *= 2) {
        size_t n = 0, haar;
        unsigned char *img = (unsigned char *)check_read_file(written(q), &n);
        size_t at = pad_offset(img, n, q, &haar);
        uint32_t w;
        memcpy(&w, img + at, 4);
        CHECK(img[at] < 64 && (q != 8 || (at + 1 + img[at]) % 64 == 0), "%d-bit: pad count %u puts the values on 64 bytes", q, img[at]);
        patch32(bad, img, n, at, (w & ~0xffu) | 64u);
        expect_fail(bad, "badpad.prt", "bad padding", "pad count 64");
        if (img[at] > 0) {
            nonzero++;
            patch32(bad, img, n, at, w | 0x100u);
            expect_fail(bad, "badpad.prt", "bad padding", "a pad byte not zero");
        }
        free(img);
    }
    CHECK(nonzero > 0, "some file had padding to spoil");
}

/* prtio_crc_threads equals zlib's crc32 over the same bytes: one chunk, exactly one, one byte past,
 * several, on 1 and 2 threads. */
static void crc_threads(void) {
    size_t big = (size_t)40 << 20;
    unsigned char *b = malloc(big);
    uint32_t x = 12345;
    for (size_t i = 0; i < big; i++) { x = x * 1664525u + 1013904223u; b[i] = (unsigned char)(x >> 24); }
    size_t lens[] = { 0, 5, (size_t)16 << 20, ((size_t)16 << 20) + 1, big };
    for (size_t i = 0; i < sizeof lens / sizeof lens[0]; i++)
        for (int th = 1; th <= 2; th++) {
            unsigned long want = crc32(crc32(0L, Z_NULL, 0), b, (uInt)lens[i]);
            CHECK(prtio_crc_threads(b, lens[i], th, false) == want, "%zu bytes on %d threads", lens[i], th);
        }
    free(b);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(round_trip);
    CHECK_CASE(direct_set);
    CHECK_CASE(truncated_and_flipped);
    CHECK_CASE(header);
    CHECK_CASE(crafted);
    CHECK_CASE(failed_writes);
    CHECK_CASE(transfers_rule);
    CHECK_CASE(from_memory);
    CHECK_CASE(mapped);
    CHECK_CASE(mapped_older_files);
    CHECK_CASE(mapped_bad_padding);
    CHECK_CASE(crc_threads);
    return check_summary();
}
