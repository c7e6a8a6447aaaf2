/* compare.c - how far a PRT result is from the path-traced reference (compare.h).
 *
 * The study of accuracy against time needs one number per run that does not
 * depend on the exposure of the scene: the relative RMS error (L2 error over L2
 * norm of the reference), and a worst case that is not dominated by black
 * pixels (max relative error over items brighter than 1% of the mean). Both are
 * defined precisely in compare.h. Images come through image_read (OIIO); per-vertex
 * values through a small CSV reader, because vertex colours are the quantity PRT
 * actually computes (Eq. 5) before rasterization blurs them. */
#include "compare.h"
#include "image.h"
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Metrics of a vs reference b (see header); rel_err optional per-item output. */
int cmp_arrays(const float *a, const float *b, long n, int ch, cmp_result *out, float *rel_err, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->ref_noise = -1;
    out->worst_item = -1;
    out->items = n;
    double sum_d2 = 0, sum_b2 = 0, sum_bn = 0;
    for (long i = 0; i < n * ch; i++) {
        if (!isfinite(a[i])) return prt_fail(err, "A has a non-finite value at item %ld", i / ch);
        if (!isfinite(b[i])) return prt_fail(err, "B has a non-finite value at item %ld", i / ch);
    }
    for (long i = 0; i < n; i++) {
        double d2 = 0, b2 = 0;
        for (int c = 0; c < ch; c++) {
            double d = (double)a[i * ch + c] - b[i * ch + c];
            d2 += d * d;
            b2 += (double)b[i * ch + c] * b[i * ch + c];
        }
        sum_d2 += d2;
        sum_b2 += b2;
        sum_bn += sqrt(b2);
    }
    if (sum_b2 == 0) {
        if (sum_d2 != 0) return prt_fail(err, "the reference B is all zero but A is not: relative error undefined");
        if (rel_err) memset(rel_err, 0, sizeof(float) * (size_t)n);
        return 0;
    }
    out->rel_rmse = sqrt(sum_d2 / sum_b2);
    double floor_ = 0.01 * sum_bn / (double)n;   /* 1% of the mean item norm, > 0 here */
    for (long i = 0; i < n; i++) {
        double d2 = 0, b2 = 0;
        for (int c = 0; c < ch; c++) {
            double d = (double)a[i * ch + c] - b[i * ch + c];
            d2 += d * d;
            b2 += (double)b[i * ch + c] * b[i * ch + c];
        }
        double bn = sqrt(b2), e = sqrt(d2) / (bn > floor_ ? bn : floor_);
        if (rel_err) rel_err[i] = (float)e;
        if (bn > floor_) {
            out->items_in_max++;
            if (e > out->max_rel_err || out->worst_item < 0) { out->max_rel_err = e; out->worst_item = (int)i; }
        }
    }
    return 0;
}

/* Turbo colour map (Google, 2019) by its published polynomial fit (Ruofei Du): display rgb in [0,1]. */
void cmp_colormap(float t, float rgb[3]) {
    static const double kr[6] = { 0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943 };
    static const double kg[6] = { 0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604 };
    static const double kb[6] = { 0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973 };
    double x = t < 0 || t != t ? 0 : (t > 1 ? 1 : t), p[6] = { 1, x, x * x, x * x * x, x * x * x * x, x * x * x * x * x };
    const double *k[3] = { kr, kg, kb };
    for (int c = 0; c < 3; c++) {
        double v = 0;
        for (int i = 0; i < 6; i++) v += k[c][i] * p[i];
        rgb[c] = (float)(v < 0 ? 0 : v > 1 ? 1 : v);
    }
}

/* sRGB display value -> linear (image_write encodes linear back to sRGB for PNG). */
static float srgb_to_linear(float v) { return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f); }

typedef struct vrow { int id; float v[7]; } vrow;   /* r, g, b, stderr r, g, b, facing */
static int vrow_cmp(const void *x, const void *y) {
    int a = ((const vrow *)x)->id, b = ((const vrow *)y)->id;
    return (a > b) - (a < b);
}

/* Reads the whole file into a NUL-terminated buffer (caller frees). */
static char *slurp(const char *path, size_t *len, prt_error *err) {
    FILE *f = fopen(path, "rb");
    if (!f) { prt_fail(err, "%s: cannot open: %s", path, strerror(errno)); return NULL; }
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    for (;;) {
        if (!buf) { fclose(f); prt_fail(err, "%s: out of memory", path); return NULL; }
        n += fread(buf + n, 1, cap - n - 1, f);
        if (n < cap - 1) break;
        cap *= 2;
        char *nb = realloc(buf, cap);
        if (!nb) free(buf);
        buf = nb;
    }
    if (ferror(f)) { fclose(f); free(buf); prt_fail(err, "%s: read error", path); return NULL; }
    fclose(f);
    buf[n] = 0;
    *len = n;
    return buf;
}

/* Splits line (modified in place) at commas into at most max fields; returns the count. */
static int split_csv(char *line, char **fields, int max) {
    int n = 0;
    char *p = line;
    for (;;) {
        while (*p == ' ' || *p == '\t') p++;
        if (n < max) fields[n] = p;
        n++;
        char *c = strchr(p, ',');
        char *end = c ? c : p + strlen(p);
        while (end > p && (end[-1] == ' ' || end[-1] == '\t' || end[-1] == '\r')) end--;
        if (c) { *end = 0; p = c + 1; }
        else { *end = 0; break; }
    }
    return n;
}

/* Frees a vertex table (a zeroed one is fine). */
void cmp_vertices_free(cmp_vertices *v) {
    free(v->ids);
    free(v->rgb);
    free(v->se);
    free(v->facing);
    memset(v, 0, sizeof *v);
}

/* Column roles of a per-vertex CSV: vertex, r, g, b, stderr_r, stderr_g, stderr_b, facing. */
enum { CSV_NCOL = 8 };
static const char *const csv_names[CSV_NCOL] = { "vertex", "r", "g", "b", "stderr_r", "stderr_g", "stderr_b", "facing" };

/* Maps the header's named columns into col[role] (-1 absent; unknown columns are ignored;
 * the three stderr columns count only together). Returns 0, or -1 when r, g or b is missing. */
static int csv_header(char **f, int nf, int col[CSV_NCOL], const char *path, int lineno, prt_error *err) {
    for (int k = 0; k < CSV_NCOL; k++) col[k] = -1;
    for (int i = 0; i < nf; i++)
        for (int k = 0; k < CSV_NCOL; k++)
            if (!strcmp(f[i], csv_names[k])) col[k] = i;
    if (col[1] < 0 || col[2] < 0 || col[3] < 0) return prt_fail(err, "%s:%d: header has no r, g, b columns", path, lineno);
    if (col[4] < 0 || col[5] < 0 || col[6] < 0) col[4] = col[5] = col[6] = -1;
    return 0;
}

/* Parses the nf fields f of one data row into r (its id defaults to row, facing to 1).
 * Returns 0, or -1 with a "path:line:" message. */
static int csv_row(char **f, int nf, const int col[CSV_NCOL], size_t row, vrow *r, const char *path, int lineno,
                   prt_error *err) {
    r->id = (int)row;
    r->v[6] = 1.f;
    for (int k = 0; k < CSV_NCOL; k++) {
        if (col[k] < 0) continue;
        if (col[k] >= nf) return prt_fail(err, "%s:%d: missing column '%s'", path, lineno, csv_names[k]);
        char *end;
        errno = 0;
        if (k == 0) {
            long id = strtol(f[col[k]], &end, 10);
            if (errno || end == f[col[k]] || *end || id < 0 || id > 2000000000L)
                return prt_fail(err, "%s:%d: bad vertex id '%s'", path, lineno, f[col[k]]);
            r->id = (int)id;
        } else {
            double v = strtod(f[col[k]], &end);
            if (end == f[col[k]] || *end || !isfinite(v) || (k == 7 && v != 0 && v != 1))
                return prt_fail(err, "%s:%d: bad %s '%s' in column '%s'", path, lineno,
                                k == 7 ? "flag (0 or 1)" : "number", f[col[k]], csv_names[k]);
            r->v[k - 1] = (float)v;
        }
    }
    return 0;
}

/* Sorts the rows by vertex id, rejects a vertex listed twice, and fills out (stderr and facing
 * only when their columns exist). Returns 0, or -1 with out freed. */
static int csv_table(vrow *rows, size_t nrows, const int col[CSV_NCOL], cmp_vertices *out, const char *path,
                     prt_error *err) {
    if (nrows == 0) return prt_fail(err, "%s: no vertex rows", path);
    qsort(rows, nrows, sizeof *rows, vrow_cmp);
    for (size_t i = 1; i < nrows; i++)
        if (rows[i].id == rows[i - 1].id) return prt_fail(err, "%s: vertex %d listed twice", path, rows[i].id);
    out->ids = malloc(sizeof(int) * nrows);
    out->rgb = malloc(sizeof(float) * 3 * nrows);
    if (col[4] >= 0) out->se = malloc(sizeof(float) * 3 * nrows);
    if (col[7] >= 0) out->facing = malloc(nrows);
    if (!out->ids || !out->rgb || (col[4] >= 0 && !out->se) || (col[7] >= 0 && !out->facing)) {
        cmp_vertices_free(out);
        return prt_fail(err, "%s: out of memory", path);
    }
    for (size_t i = 0; i < nrows; i++) {
        out->ids[i] = rows[i].id;
        for (int c = 0; c < 3; c++) {
            out->rgb[3 * i + c] = rows[i].v[c];
            if (out->se) out->se[3 * i + c] = rows[i].v[3 + c];
        }
        if (out->facing) out->facing[i] = rows[i].v[6] != 0;
    }
    out->n = (int)nrows;
    return 0;
}

/* Per-vertex CSV reader (see header). */
int cmp_read_vertex_csv(const char *path, cmp_vertices *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    size_t len;
    char *text = slurp(path, &len, err);
    if (!text) return -1;
    int col[CSV_NCOL] = { 0, 1, 2, 3, -1, -1, -1, -1 };
    vrow *rows = NULL;
    size_t nrows = 0, cap = 0;
    int lineno = 0, header_seen = 0, rc = -1;
    char *p = text;
    while (*p) {
        char *nl = strchr(p, '\n');
        if (nl) *nl = 0;
        lineno++;
        char *line = p;
        p = nl ? nl + 1 : p + strlen(p);
        while (*line == ' ' || *line == '\t') line++;
        if (!*line || *line == '\r' || *line == '#') continue;
        char *f[32];
        int nf = split_csv(line, f, 32);
        if (nf > 32) nf = 32;
        if (!header_seen && (isalpha((unsigned char)f[0][0]) || f[0][0] == '_')) {
            if (csv_header(f, nf, col, path, lineno, err)) goto done;
            header_seen = 1;
            continue;
        }
        header_seen = 1;
        if (nrows == cap) {
            cap = cap ? 2 * cap : 1024;
            vrow *nr = realloc(rows, cap * sizeof *rows);
            if (!nr) { prt_fail(err, "%s: out of memory", path); goto done; }
            rows = nr;
        }
        if (csv_row(f, nf, col, nrows, &rows[nrows], path, lineno, err)) goto done;
        nrows++;
    }
    rc = csv_table(rows, nrows, col, out, path, err);
done:
    free(rows);
    free(text);
    return rc;
}

/* Writes the false-colour map of per-pixel relative errors e[w*h]. */
static int write_error_image(const char *path, const float *e, int w, int h, prt_error *err) {
    prt_image im = { 0 };
    if (image_alloc(&im, w, h, 3, err)) return -1;
    for (long i = 0; i < (long)w * h; i++) {
        float t = e[i] > 0 ? (float)((log10(e[i]) + 3.0) / 3.0) : 0.f, rgb[3];
        cmp_colormap(t, rgb);
        for (int c = 0; c < 3; c++) im.data[3 * i + c] = srgb_to_linear(rgb[c]);
    }
    image_desc d = { 0 };
    int rc = image_write(path, &im, &d, err);
    image_free(&im);
    return rc;
}

static bool is_csv(const char *path) {
    char ext[16];
    prt_path_ext(path, ext);
    return !strcmp(ext, "csv");
}

/* Keeps only the vertices B marks as facing the eye, in place (rows stay sorted); returns
 * how many were dropped, or -1 when none faces the eye. */
static long keep_facing(cmp_vertices *va, cmp_vertices *vb) {
    long skipped = 0;
    int m = 0;
    for (int i = 0; i < vb->n; i++) {
        if (!vb->facing[i]) { skipped++; continue; }
        va->ids[m] = va->ids[i];
        memmove(va->rgb + 3 * m, va->rgb + 3 * i, sizeof(float) * 3);
        memmove(vb->rgb + 3 * m, vb->rgb + 3 * i, sizeof(float) * 3);
        if (vb->se) memmove(vb->se + 3 * m, vb->se + 3 * i, sizeof(float) * 3);
        m++;
    }
    if (m == 0) return -1;
    va->n = vb->n = m;
    return skipped;
}

/* Prefixes err's message with "a vs b: "; returns -1. */
static int fail_pair(const char *a, const char *b, prt_error *err) {
    char msg[sizeof err->msg];
    snprintf(msg, sizeof msg, "%s", err->msg);
    return prt_fail(err, "%s vs %s: %s", a, b, msg);
}

/* Compares two per-vertex CSV files (the same vertices; B's facing column, unless
 * desc->all_vertices, selects which count). Returns 0, or -1 with err set. */
static int cmp_csv_files(const char *a, const char *b, const cmp_desc *desc, cmp_result *out, prt_error *err) {
    cmp_vertices va = { 0 }, vb = { 0 };
    int rc = -1;
    if (cmp_read_vertex_csv(a, &va, err)) goto done;
    if (cmp_read_vertex_csv(b, &vb, err)) goto done;
    if (va.n != vb.n) { prt_fail(err, "%s has %d vertices but %s has %d", a, va.n, b, vb.n); goto done; }
    for (int i = 0; i < va.n; i++)
        if (va.ids[i] != vb.ids[i]) {
            prt_fail(err, "%s and %s list different vertices (vertex %d vs %d)", a, b, va.ids[i], vb.ids[i]);
            goto done;
        }
    long skipped = 0;
    if (vb.facing && !desc->all_vertices && (skipped = keep_facing(&va, &vb)) < 0) {
        prt_fail(err, "%s: no vertex faces the eye", b);
        goto done;
    }
    if (cmp_arrays(va.rgb, vb.rgb, va.n, 3, out, NULL, err)) { fail_pair(a, b, err); goto done; }
    out->skipped = skipped;
    if (out->worst_item >= 0) out->worst_item = va.ids[out->worst_item];
    if (vb.se) {
        double s2 = 0, b2 = 0;
        for (long i = 0; i < 3L * vb.n; i++) { s2 += (double)vb.se[i] * vb.se[i]; b2 += (double)vb.rgb[i] * vb.rgb[i]; }
        out->ref_noise = b2 > 0 ? sqrt(s2 / b2) : 0;
    }
    rc = 0;
done:
    cmp_vertices_free(&va);
    cmp_vertices_free(&vb);
    return rc;
}

/* Compares two RGB images of one size; writes the false-colour error map to error_image
 * when it is not NULL. Returns 0, or -1 with err set. */
static int cmp_image_files(const char *a, const char *b, const char *error_image, cmp_result *out, prt_error *err) {
    prt_image ima = { 0 }, imb = { 0 };
    float *e = NULL;
    int rc = -1;
    if (image_read(a, &ima, err)) goto done;
    if (image_read(b, &imb, err)) goto done;
    if (ima.w != imb.w || ima.h != imb.h) {
        prt_fail(err, "size mismatch: %s is %dx%d but %s is %dx%d", a, ima.w, ima.h, b, imb.w, imb.h);
        goto done;
    }
    if (ima.c != 3 || imb.c != 3) { prt_fail(err, "%s, %s: expected RGB images", a, b); goto done; }
    long n = (long)ima.w * ima.h;
    e = prt_calloc((size_t)n, sizeof(float), err);
    if (!e) goto done;
    if (cmp_arrays(ima.data, imb.data, n, 3, out, e, err)) { fail_pair(a, b, err); goto done; }
    out->ref_noise = -1;
    out->width = ima.w;
    if (error_image && write_error_image(error_image, e, ima.w, ima.h, err)) goto done;
    rc = 0;
done:
    free(e);
    image_free(&ima);
    image_free(&imb);
    return rc;
}

/* Compares two files (see header): both per-vertex CSV, or both images. */
int cmp_files(const char *a, const char *b, const cmp_desc *desc, cmp_result *out, prt_error *err) {
    static const cmp_desc k_default = { 0 };
    if (!desc) desc = &k_default;
    memset(out, 0, sizeof *out);
    bool ca = is_csv(a), cb = is_csv(b);
    if (ca != cb)
        return prt_fail(err, "cannot compare %s with %s: one is a per-vertex CSV and the other an image",
                        ca ? a : b, ca ? b : a);
    if (!ca) return cmp_image_files(a, b, desc->error_image, out, err);
    if (desc->error_image)
        return prt_fail(err, "%s: an error image needs two images, not per-vertex CSV files", desc->error_image);
    return cmp_csv_files(a, b, desc, out, err);
}
