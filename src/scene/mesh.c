/* mesh.c - triangle meshes for prt: a fast OBJ reader, welding, cleanup,
 * smooth normals and the procedural shapes used by tests and the demo.
 *
 * Precomputed radiance transfer stores one transport vector per vertex (Wang,
 * Tran & Luebke 2006, Sec. 3: the transport is sampled at mesh vertices and
 * interpolated), so the vertex set must be exactly the surface's sample set:
 *  - positions that are equal in the file are welded into one vertex, so a
 *    seam does not get two transport vectors and two normals;
 *  - degenerate triangles are dropped (they have no normal and only waste
 *    visibility rays), and vertices no triangle uses are removed (they would be
 *    precomputed for nothing);
 *  - normals are smooth, angle-weighted (Thuermer & Wuethrich 1998), because
 *    the BRDF frame of Eq. 10 is built from them; they are never NaN.
 *
 * The OBJ reader reads the whole file into one buffer and walks it line by
 * line with strtof for coordinates and a hand-written integer parser for face
 * indices; the only allocations are the growing position and index arrays, so
 * the 2.4 MB Stanford bunny loads in a few tens of milliseconds. Welding uses
 * an open-addressing hash of the coordinates' bit patterns (O(n)). */
#include "mesh.h"
#include "vec3.h"
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Largest vertex / triangle count accepted (keeps every index product in int range). */
#define MESH_MAX_ELEMS (1 << 28)
/* Twice the area below which a triangle is degenerate, relative to the squared
 * bounding-box diagonal: a triangle with legs ~1e-6 of the model size, near the
 * limit of float coordinates' precision. */
#define MESH_DEGENERATE_REL 1e-12

/* ---------------------------------------------------------------- growing arrays */

/* Grows *arr (elements of `size` bytes) to hold at least `need`; returns 0 or -1 (OOM). */
static int grow(void **arr, size_t *cap, size_t need, size_t size) {
    if (need <= *cap) return 0;
    size_t c = *cap ? *cap : 1024;
    while (c < need) c *= 2;
    void *p = realloc(*arr, c * size);
    if (!p) return -1;
    *arr = p;
    *cap = c;
    return 0;
}

/* ---------------------------------------------------------------- OBJ parsing */

typedef struct obj_parser {
    const char *name;
    prt_error *err;
    int line;
    float *pos;             /* 3 floats per 'v' */
    size_t nv, cap_pos;     /* vertices read, capacity in vertices */
    int32_t *idx;           /* 3 per triangle, 0-based; may be >= nv for forward references */
    size_t nidx, cap_idx;
    int64_t fwd_max;        /* largest index referring past the vertices read so far (-1: none) */
    int fwd_line;
    int faces;
    int mtllib_line;        /* first `mtllib` line (0: none) */
} obj_parser;

static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f' || c == '\r'; }

/* Copies a token for an error message, replacing unprintable bytes. */
static void token_for_msg(const char *p, const char *e, char out[40]) {
    int n = 0;
    while (p < e && !is_blank(*p) && n < 32) {
        unsigned char c = (unsigned char)*p++;
        out[n++] = (c >= 32 && c < 127) ? (char)c : '?';
    }
    if (p < e && !is_blank(*p)) { out[n++] = '.'; out[n++] = '.'; out[n++] = '.'; }
    out[n] = 0;
}

/* Statements that are valid OBJ but carry nothing prt uses. */
static bool obj_ignored_keyword(const char *k, size_t n) {
    static const char *const kw[] = {
        "vt", "vn", "vp", "o", "g", "s", "usemtl", "mtllib", "l", "p", "cstype", "deg", "bmat",
        "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp", "end", "con", "mg",
        "bevel", "c_interp", "d_interp", "lod", "maplib", "usemap", "shadow_obj", "trace_obj",
        "ctech", "stech", "call", "csh",
    };
    for (size_t i = 0; i < sizeof kw / sizeof kw[0]; i++)
        if (strlen(kw[i]) == n && memcmp(kw[i], k, n) == 0) return true;
    return false;
}

/* Parses a 'v' line's numbers from p (end e, text NUL-terminated beyond). Returns 0 or -1. */
static int obj_vertex(obj_parser *P, const char *p, const char *e) {
    if (grow((void **)&P->pos, &P->cap_pos, P->nv + 1, 3 * sizeof(float)) != 0)
        return prt_fail(P->err, "%s:%d: out of memory", P->name, P->line);
    float *v = P->pos + 3 * P->nv;
    int count = 0;
    for (;;) {
        while (p < e && is_blank(*p)) p++;
        if (p >= e) break;
        char c = *p;
        bool numeric = (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.' ||
                       c == 'n' || c == 'N' || c == 'i' || c == 'I';
        char *q = (char *)p;
        float x = 0.f;
        if (numeric) x = strtof(p, &q);
        if (!numeric || q == p || q > e || (q < e && !is_blank(*q))) {
            char tok[40];
            token_for_msg(p, e, tok);
            return prt_fail(P->err, "%s:%d: bad vertex coordinate '%s'", P->name, P->line, tok);
        }
        if (count < 3) {
            if (!isfinite(x))
                return prt_fail(P->err, "%s:%d: non-finite vertex coordinate", P->name, P->line);
            v[count] = x + 0.f; /* -0 becomes +0, so equal points are bitwise equal */
        }
        count++;
        p = q;
    }
    /* x y z, optionally w or an r g b colour (a common extension): 3 to 7 numbers. */
    if (count < 3)
        return prt_fail(P->err, "%s:%d: vertex needs 3 coordinates, got %d", P->name, P->line, count);
    if (count > 7)
        return prt_fail(P->err, "%s:%d: vertex has %d numbers (at most 7)", P->name, P->line, count);
    P->nv++;
    if (P->nv > MESH_MAX_ELEMS) return prt_fail(P->err, "%s:%d: too many vertices", P->name, P->line);
    return 0;
}

/* Parses an optionally signed decimal integer at *pp (not past e). Returns false if none. */
static bool parse_int(const char **pp, const char *e, int64_t *out) {
    const char *p = *pp;
    bool neg = false;
    if (p < e && (*p == '-' || *p == '+')) { neg = *p == '-'; p++; }
    if (p >= e || *p < '0' || *p > '9') return false;
    int64_t v = 0;
    while (p < e && *p >= '0' && *p <= '9') {
        v = v * 10 + (*p - '0');
        if (v > INT32_MAX) v = (int64_t)INT32_MAX + 1; /* saturate: reported as out of range */
        p++;
    }
    *out = neg ? -v : v;
    *pp = p;
    return true;
}

/* Resolves an OBJ index (1-based, or negative relative) to 0-based; -1 on error (err set). */
static int64_t obj_resolve(obj_parser *P, int64_t i) {
    if (i == 0) {
        prt_fail(P->err, "%s:%d: bad face index 0 (OBJ indices start at 1)", P->name, P->line);
        return -1;
    }
    if (i < 0) {
        int64_t r = (int64_t)P->nv + i;
        if (r < 0) {
            prt_fail(P->err, "%s:%d: bad face index %lld (only %zu vertices before this line)",
                     P->name, P->line, (long long)i, P->nv);
            return -1;
        }
        return r;
    }
    if (i > MESH_MAX_ELEMS) {
        prt_fail(P->err, "%s:%d: face index %lld out of range", P->name, P->line, (long long)i);
        return -1;
    }
    if (i - 1 >= (int64_t)P->nv && i - 1 > P->fwd_max) {
        /* A forward reference: valid only if the vertex appears later; checked at the end. */
        P->fwd_max = i - 1;
        P->fwd_line = P->line;
    }
    return i - 1;
}

/* Parses an 'f' line: v, v/vt, v//vn or v/vt/vn references; fan-triangulates. */
static int obj_face(obj_parser *P, const char *p, const char *e) {
    int64_t first = -1, prev = -1;
    int n = 0;
    for (;;) {
        while (p < e && is_blank(*p)) p++;
        if (p >= e) break;
        const char *start = p;
        int64_t vi, t;
        bool ok = parse_int(&p, e, &vi);
        if (ok && p < e && *p == '/') {
            p++;
            if (p < e && *p == '/') { p++; ok = parse_int(&p, e, &t) && t != 0; }      /* v//vn */
            else {
                ok = parse_int(&p, e, &t) && t != 0;                                    /* v/vt */
                if (ok && p < e && *p == '/') { p++; ok = parse_int(&p, e, &t) && t != 0; } /* v/vt/vn */
            }
        }
        if (!ok || (p < e && !is_blank(*p))) {
            char tok[40];
            token_for_msg(start, e, tok);
            return prt_fail(P->err, "%s:%d: bad face vertex '%s'", P->name, P->line, tok);
        }
        int64_t r = obj_resolve(P, vi);
        if (r < 0) return -1;
        if (n == 0) first = r;
        else if (n >= 2) {
            if (grow((void **)&P->idx, &P->cap_idx, P->nidx + 3, sizeof(int32_t)) != 0)
                return prt_fail(P->err, "%s:%d: out of memory", P->name, P->line);
            P->idx[P->nidx++] = (int32_t)first;
            P->idx[P->nidx++] = (int32_t)prev;
            P->idx[P->nidx++] = (int32_t)r;
            if (P->nidx / 3 > MESH_MAX_ELEMS)
                return prt_fail(P->err, "%s:%d: too many triangles", P->name, P->line);
        }
        prev = r;
        n++;
    }
    if (n < 3) return prt_fail(P->err, "%s:%d: face with %d vertices (needs at least 3)", P->name, P->line, n);
    P->faces++;
    return 0;
}

static int mesh_build(const char *name, float *pos, size_t nv, const int32_t *idx, size_t ntris,
                      mesh_load_stats *st, prt_mesh *out, prt_error *err);

/* The encoding a byte-order mark at the start names when it is one the parser cannot read
 * (UTF-32 checked first: its little-endian mark begins with UTF-16's), else NULL. */
static const char *obj_wide_encoding(const unsigned char *t, size_t len) {
    if (len >= 4 && t[0] == 0xFF && t[1] == 0xFE && t[2] == 0 && t[3] == 0) return "UTF-32LE";
    if (len >= 4 && t[0] == 0 && t[1] == 0 && t[2] == 0xFE && t[3] == 0xFF) return "UTF-32BE";
    if (len >= 2 && t[0] == 0xFF && t[1] == 0xFE) return "UTF-16LE";
    if (len >= 2 && t[0] == 0xFE && t[1] == 0xFF) return "UTF-16BE";
    return NULL;
}

/* Parses NUL-terminated text of length len (text[len] == 0). */
static int parse_obj_text(const char *name, const char *text, size_t len, mesh_load_stats *stats,
                          prt_mesh *out, prt_error *err) {
    const char *enc = obj_wide_encoding((const unsigned char *)text, len);
    if (enc) return prt_fail(err, "%s: the file is %s text (byte-order mark); save it as UTF-8 or ASCII", name, enc);
    if (len >= 3 && !memcmp(text, "\xEF\xBB\xBF", 3)) { text += 3; len -= 3; }   /* a UTF-8 BOM is only a marker */
    obj_parser P = { .name = name, .err = err, .fwd_max = -1 };
    const char *p = text, *end = text + len;
    int rc = 0;
    while (p < end && rc == 0) {
        P.line++;
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        const char *e = nl ? nl : end;
        const char *next = nl ? nl + 1 : end;
        const char *hash = memchr(p, '#', (size_t)(e - p));
        if (hash) e = hash;                               /* a comment runs to the end of the line */
        while (e > p && is_blank(e[-1])) e--;             /* CR and trailing blanks */
        while (p < e && is_blank(*p)) p++;
        if (p < e) {
            const char *k = p;
            while (p < e && !is_blank(*p)) p++;
            size_t kn = (size_t)(p - k);
            if (kn == 1 && k[0] == 'v') rc = obj_vertex(&P, p, e);
            else if (kn == 1 && k[0] == 'f') rc = obj_face(&P, p, e);
            else if (kn == 6 && !memcmp(k, "mtllib", 6) && !P.mtllib_line) P.mtllib_line = P.line;
            else if (!obj_ignored_keyword(k, kn)) {
                char tok[40];
                token_for_msg(k, e, tok);
                rc = prt_fail(err, "%s:%d: unknown statement '%s'", name, P.line, tok);
            }
        }
        p = next;
    }
    if (rc == 0 && P.fwd_max >= (int64_t)P.nv)
        rc = prt_fail(err, "%s:%d: face index %lld out of range (the file has %zu vertices)", name,
                      P.fwd_line, (long long)P.fwd_max + 1, P.nv);
    if (rc == 0 && P.nidx == 0) rc = prt_fail(err, "%s: no triangles (%zu vertices, no faces)", name, P.nv);
    mesh_load_stats st = { .obj_vertices = (int)P.nv, .faces = P.faces, .mtllib_line = P.mtllib_line };
    if (rc == 0) rc = mesh_build(name, P.pos, P.nv, P.idx, P.nidx / 3, &st, out, err);
    free(P.pos);
    free(P.idx);
    if (stats) *stats = st;
    return rc;
}

int mesh_parse_obj(const char *name, const char *text, size_t len, mesh_load_stats *stats, prt_mesh *out,
                   prt_error *err) {
    memset(out, 0, sizeof *out);
    if (stats) memset(stats, 0, sizeof *stats);
    if (!name) name = "<obj>";
    /* strtof needs a terminator after the last number: work on a NUL-terminated copy. */
    char *buf = malloc(len + 1);
    if (!buf) return prt_fail(err, "%s: out of memory", name);
    if (len) memcpy(buf, text, len);
    buf[len] = 0;
    int rc = parse_obj_text(name, buf, len, stats, out, err);
    free(buf);
    return rc;
}

int mesh_load_obj(const char *path, mesh_load_stats *stats, prt_mesh *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (stats) memset(stats, 0, sizeof *stats);
    struct stat sb;
    if (stat(path, &sb) != 0) return prt_fail(err, "%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(sb.st_mode)) return prt_fail(err, "%s: not a regular file", path);
    FILE *f = fopen(path, "rb");
    if (!f) return prt_fail(err, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = (size_t)sb.st_size, len = 0;
    char *buf = malloc(cap + 1);
    if (!buf) { fclose(f); return prt_fail(err, "%s: out of memory (%zu bytes)", path, cap); }
    /* Read to EOF (the size may change under us; grow if it does). */
    for (;;) {
        len += fread(buf + len, 1, cap - len, f);
        if (len < cap || feof(f)) break;
        int c = fgetc(f);
        if (c == EOF) break;
        char *nb = realloc(buf, 2 * cap + 2);
        if (!nb) { free(buf); fclose(f); return prt_fail(err, "%s: out of memory", path); }
        buf = nb;
        buf[len++] = (char)c;
        cap = 2 * cap + 1;
    }
    bool bad = ferror(f);
    fclose(f);
    if (bad) { free(buf); return prt_fail(err, "%s: read error", path); }
    buf[len] = 0;
    int rc = parse_obj_text(path, buf, len, stats, out, err);
    free(buf);
    return rc;
}

/* ---------------------------------------------------------------- welding and cleanup */

static uint32_t float_key(float f) {
    uint32_t u;
    if (f == 0.f) f = 0.f; /* -0 and +0 are equal, so they weld */
    memcpy(&u, &f, 4);
    return u;
}

static uint32_t hash3(const float *p) {
    uint64_t h = float_key(p[0]) * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) + float_key(p[1]) * 0xBF58476D1CE4E5B9ull;
    h ^= (h >> 31) + float_key(p[2]) * 0x94D049BB133111EBull;
    h ^= h >> 32;
    return (uint32_t)h;
}

/* Welds exactly equal positions: remap[i] receives the unique index of vertex i;
 * the unique positions are packed at the front of pos (first-appearance order).
 * Returns the number of unique vertices, or -1 on OOM. */
static int64_t weld(float *pos, size_t nv, uint32_t *remap) {
    size_t size = 16;
    while (size < 2 * nv) size *= 2;
    uint32_t *table = malloc(size * sizeof *table);
    if (!table) return -1;
    memset(table, 0xff, size * sizeof *table);
    size_t nu = 0;
    for (size_t i = 0; i < nv; i++) {
        const float *p = pos + 3 * i;
        size_t h = hash3(p) & (size - 1);
        for (;;) {
            uint32_t u = table[h];
            if (u == UINT32_MAX) {
                table[h] = (uint32_t)nu;
                if (nu != i) memmove(pos + 3 * nu, p, 3 * sizeof(float));
                remap[i] = (uint32_t)nu++;
                break;
            }
            const float *q = pos + 3 * (size_t)u;
            if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) { remap[i] = u; break; }
            h = (h + 1) & (size - 1);
        }
    }
    free(table);
    return (int64_t)nu;
}

/* Twice the area of triangle (a,b,c), in double (exact enough to see collinearity). */
static double tri_area2(const float *a, const float *b, const float *c, double n[3]) {
    double e1[3] = { (double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2] };
    double e2[3] = { (double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2] };
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    return sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/* Builds a clean mesh from raw positions (modified in place) and triangles:
 * weld, drop degenerate triangles, drop unused vertices, compute normals. */
static int mesh_build(const char *name, float *pos, size_t nv, const int32_t *idx, size_t ntris,
                      mesh_load_stats *st, prt_mesh *out, prt_error *err) {
    uint32_t *remap = malloc((nv ? nv : 1) * sizeof *remap);
    uint32_t *tris = malloc(3 * ntris * sizeof *tris);
    uint32_t *used = NULL;
    if (!remap || !tris) goto oom;
    int64_t nu = weld(pos, nv, remap);
    if (nu < 0) goto oom;
    st->welded = (int)(nv - (size_t)nu);

    /* Bounds of the referenced vertices give the model size for the area test. */
    float bmin[3] = { INFINITY, INFINITY, INFINITY }, bmax[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t t = 0; t < 3 * ntris; t++) {
        const float *p = pos + 3 * (size_t)remap[idx[t]];
        for (int k = 0; k < 3; k++) {
            if (p[k] < bmin[k]) bmin[k] = p[k];
            if (p[k] > bmax[k]) bmax[k] = p[k];
        }
    }
    double diag2 = 0;
    for (int k = 0; k < 3; k++) diag2 += ((double)bmax[k] - bmin[k]) * ((double)bmax[k] - bmin[k]);
    double min_area2 = MESH_DEGENERATE_REL * diag2;

    size_t nt = 0;
    for (size_t t = 0; t < ntris; t++) {
        uint32_t a = remap[idx[3 * t]], b = remap[idx[3 * t + 1]], c = remap[idx[3 * t + 2]];
        double n[3];
        if (a == b || b == c || a == c ||
            tri_area2(pos + 3 * (size_t)a, pos + 3 * (size_t)b, pos + 3 * (size_t)c, n) <= min_area2) {
            st->degenerate++;
            continue;
        }
        tris[3 * nt] = a; tris[3 * nt + 1] = b; tris[3 * nt + 2] = c;
        nt++;
    }
    if (nt == 0) {
        free(remap); free(tris);
        return prt_fail(err, "%s: no triangles left (all %zu are degenerate)", name, ntris);
    }

    /* Drop unused vertices, keeping the order of the rest. */
    used = calloc((size_t)nu, sizeof *used);
    if (!used) goto oom;
    for (size_t t = 0; t < 3 * nt; t++) used[tris[t]] = 1;
    uint32_t nk = 0;
    for (uint32_t v = 0; v < (uint32_t)nu; v++) {
        if (!used[v]) { used[v] = UINT32_MAX; continue; }
        if (nk != v) memmove(pos + 3 * (size_t)nk, pos + 3 * (size_t)v, 3 * sizeof(float));
        used[v] = nk++;
    }
    for (size_t t = 0; t < 3 * nt; t++) tris[t] = used[tris[t]];
    st->unused = (int)((uint32_t)nu - nk);

    out->nverts = (int)nk;
    out->ntris = (int)nt;
    out->pos = malloc(3 * (size_t)nk * sizeof(float));
    out->nrm = malloc(3 * (size_t)nk * sizeof(float));
    out->mat = calloc(nk, sizeof(uint16_t));
    out->tris = realloc(tris, 3 * nt * sizeof *tris);
    if (!out->tris) out->tris = tris;
    tris = NULL;
    if (!out->pos || !out->nrm || !out->mat) { mesh_free(out); goto oom; }
    memcpy(out->pos, pos, 3 * (size_t)nk * sizeof(float));
    mesh_compute_normals(out);
    free(remap);
    free(used);
    return 0;
oom:
    free(remap); free(tris); free(used);
    return prt_fail(err, "%s: out of memory", name);
}

/* ---------------------------------------------------------------- normals */

/* Angle-weighted smooth normals (each triangle's unit normal weighted by its
 * corner angle at the vertex), written into m->nrm (allocated if NULL). */
void mesh_compute_normals(prt_mesh *m) {
    if (m->nverts <= 0) return;
    if (!m->nrm && !(m->nrm = malloc(3 * (size_t)m->nverts * sizeof(float)))) return;
    float *acc = m->nrm;
    memset(acc, 0, 3 * (size_t)m->nverts * sizeof(float));
    float *wsum = calloc((size_t)m->nverts, sizeof(float)); /* sum of weights, for the cancel test */
    for (int t = 0; t < m->ntris; t++) {
        const uint32_t *tv = m->tris + 3 * (size_t)t;
        const float *p[3] = { m->pos + 3 * (size_t)tv[0], m->pos + 3 * (size_t)tv[1], m->pos + 3 * (size_t)tv[2] };
        double n[3];
        double a2 = tri_area2(p[0], p[1], p[2], n);
        if (!(a2 > 0) || !isfinite(a2)) continue; /* no normal: contributes nothing */
        for (int k = 0; k < 3; k++) n[k] /= a2;
        for (int c = 0; c < 3; c++) {
            const float *o = p[c], *u = p[(c + 1) % 3], *w = p[(c + 2) % 3];
            double e1[3] = { (double)u[0] - o[0], (double)u[1] - o[1], (double)u[2] - o[2] };
            double e2[3] = { (double)w[0] - o[0], (double)w[1] - o[1], (double)w[2] - o[2] };
            double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                   cz = e1[0] * e2[1] - e1[1] * e2[0];
            /* atan2(|e1 x e2|, e1.e2) is accurate for tiny and near-pi angles alike. */
            double ang = atan2(sqrt(cx * cx + cy * cy + cz * cz), e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]);
            float *a = acc + 3 * (size_t)tv[c];
            a[0] += (float)(ang * n[0]); a[1] += (float)(ang * n[1]); a[2] += (float)(ang * n[2]);
            if (wsum) wsum[tv[c]] += (float)ang;
        }
    }
    /* Normalize; a vertex whose weighted normals (nearly) cancel, e.g. the edge
     * of a two-sided fin, gets the normal of its largest triangle instead. */
    int ncancel = 0;
    for (int v = 0; v < m->nverts; v++) {
        float *a = acc + 3 * (size_t)v;
        float l = v3_len(a);
        float w = wsum ? wsum[v] : 1.f;
        if (w > 0.f && isfinite(l) && l > 1e-4f * w) v3_scale(a, a, 1.f / l);
        else { v3_set(a, 0.f, 0.f, 0.f); ncancel++; }
    }
    double *best = ncancel ? calloc((size_t)m->nverts, sizeof(double)) : NULL;
    if (best) {
        for (int t = 0; t < m->ntris; t++) {
            const uint32_t *tv = m->tris + 3 * (size_t)t;
            double n[3];
            double a2 = tri_area2(m->pos + 3 * (size_t)tv[0], m->pos + 3 * (size_t)tv[1], m->pos + 3 * (size_t)tv[2], n);
            if (!(a2 > 0) || !isfinite(a2)) continue;
            for (int c = 0; c < 3; c++) {
                uint32_t v = tv[c];
                float *a = acc + 3 * (size_t)v;
                bool pending = a[0] == 0.f && a[1] == 0.f && a[2] == 0.f;
                if ((pending || best[v] > 0) && a2 > best[v]) {
                    best[v] = a2;
                    v3_set(a, (float)(n[0] / a2), (float)(n[1] / a2), (float)(n[2] / a2));
                }
            }
        }
    }
    /* Whatever is still not a unit vector (no valid triangle at all) becomes +y. */
    for (int v = 0; v < m->nverts; v++) {
        float *a = acc + 3 * (size_t)v;
        float l = v3_normalize(a);
        if (!(l > 0.5f) || !isfinite(a[0] + a[1] + a[2])) v3_set(a, 0.f, 1.f, 0.f);
    }
    free(best);
    free(wsum);
}

/* ---------------------------------------------------------------- whole-mesh operations */

void mesh_transform(prt_mesh *m, const float R[9], float s, const float t[3]) {
    /* A reflection (det(sR) < 0) would turn the counter-clockwise winding
     * inside out: swap two corners of every triangle and flip normals to match. */
    double det = R[0] * ((double)R[4] * R[8] - (double)R[5] * R[7]) - R[1] * ((double)R[3] * R[8] - (double)R[5] * R[6]) +
                 R[2] * ((double)R[3] * R[7] - (double)R[4] * R[6]);
    bool flip = det * s < 0;
    float nsign = s < 0 ? -1.f : 1.f;
    for (int v = 0; v < m->nverts; v++) {
        float *p = m->pos + 3 * (size_t)v;
        float q[3];
        for (int i = 0; i < 3; i++) q[i] = s * (R[3 * i] * p[0] + R[3 * i + 1] * p[1] + R[3 * i + 2] * p[2]) + t[i];
        v3_copy(p, q);
        if (m->nrm) {
            float *n = m->nrm + 3 * (size_t)v;
            for (int i = 0; i < 3; i++) q[i] = nsign * (R[3 * i] * n[0] + R[3 * i + 1] * n[1] + R[3 * i + 2] * n[2]);
            if (!(v3_normalize(q) > 0.f)) v3_set(q, 0.f, 1.f, 0.f);
            v3_copy(n, q);
        }
    }
    if (flip)
        for (int k = 0; k < m->ntris; k++) {
            uint32_t *tv = m->tris + 3 * (size_t)k, x = tv[1];
            tv[1] = tv[2];
            tv[2] = x;
        }
}

int mesh_append(prt_mesh *a, const prt_mesh *b, prt_error *err) {
    if (b->nverts <= 0 && b->ntris <= 0) return 0;
    if ((int64_t)a->nverts + b->nverts > MESH_MAX_ELEMS || (int64_t)a->ntris + b->ntris > MESH_MAX_ELEMS)
        return prt_fail(err, "mesh too large (%d + %d vertices)", a->nverts, b->nverts);
    size_t nv = (size_t)a->nverts + (size_t)b->nverts, nt = (size_t)a->ntris + (size_t)b->ntris;
    float *pos = realloc(a->pos, 3 * nv * sizeof(float));
    if (pos) a->pos = pos;
    float *nrm = realloc(a->nrm, 3 * nv * sizeof(float));
    if (nrm) a->nrm = nrm;
    uint16_t *mat = realloc(a->mat, nv * sizeof(uint16_t));
    if (mat) a->mat = mat;
    uint32_t *tris = realloc(a->tris, 3 * (nt ? nt : 1) * sizeof(uint32_t));
    if (tris) a->tris = tris;
    if (!pos || !nrm || !mat || !tris) return prt_fail(err, "out of memory appending a mesh");
    size_t v0 = (size_t)a->nverts;
    if (a->uv || b->uv) {   /* coordinates for all when either has them (0 for the other's vertices) */
        float *uv = realloc(a->uv, 2 * nv * sizeof(float));
        if (!uv) return prt_fail(err, "out of memory appending a mesh");
        if (!a->uv) memset(uv, 0, 2 * v0 * sizeof(float));
        a->uv = uv;
        if (b->uv) memcpy(uv + 2 * v0, b->uv, 2 * (size_t)b->nverts * sizeof(float));
        else memset(uv + 2 * v0, 0, 2 * (size_t)b->nverts * sizeof(float));
    }
    memcpy(a->pos + 3 * v0, b->pos, 3 * (size_t)b->nverts * sizeof(float));
    for (size_t v = 0; v < (size_t)b->nverts; v++) {
        float *n = a->nrm + 3 * (v0 + v);
        if (b->nrm) v3_copy(n, b->nrm + 3 * v);
        else v3_set(n, 0.f, 1.f, 0.f);
        a->mat[v0 + v] = b->mat ? b->mat[v] : 0;
    }
    for (size_t k = 0; k < 3 * (size_t)b->ntris; k++) a->tris[3 * (size_t)a->ntris + k] = b->tris[k] + (uint32_t)v0;
    a->nverts = (int)nv;
    a->ntris = (int)nt;
    return 0;
}

void mesh_vertex_areas(const prt_mesh *m, double *area) {
    for (int v = 0; v < m->nverts; v++) area[v] = 0;
    for (int t = 0; t < m->ntris; t++) {
        const uint32_t *tri = m->tris + 3 * (size_t)t;
        const float *a = m->pos + 3 * (size_t)tri[0], *b = m->pos + 3 * (size_t)tri[1], *c = m->pos + 3 * (size_t)tri[2];
        double u[3], w[3];
        for (int k = 0; k < 3; k++) u[k] = (double)b[k] - a[k], w[k] = (double)c[k] - a[k];
        double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2], z = u[0] * w[1] - u[1] * w[0];
        double third = sqrt(x * x + y * y + z * z) / 6;
        for (int k = 0; k < 3; k++) area[tri[k]] += third;
    }
}

void mesh_bounds(const prt_mesh *m, float bmin[3], float bmax[3]) {
    if (m->nverts <= 0) {
        v3_set(bmin, 0.f, 0.f, 0.f);
        v3_set(bmax, 0.f, 0.f, 0.f);
        return;
    }
    v3_copy(bmin, m->pos);
    v3_copy(bmax, m->pos);
    for (int v = 1; v < m->nverts; v++)
        for (int k = 0; k < 3; k++) {
            float x = m->pos[3 * (size_t)v + k];
            if (x < bmin[k]) bmin[k] = x;
            if (x > bmax[k]) bmax[k] = x;
        }
}

int mesh_copy(prt_mesh *dst, const prt_mesh *src, prt_error *err) {
    memset(dst, 0, sizeof *dst);
    return mesh_append(dst, src, err);
}

void mesh_free(prt_mesh *m) {
    free(m->pos);
    free(m->nrm);
    free(m->tris);
    free(m->mat);
    free(m->uv);
    memset(m, 0, sizeof *m);
}

/* ---------------------------------------------------------------- procedural shapes */

/* Allocates a mesh with nv vertices and nt triangles (material 0). Returns 0 or -1. */
static int mesh_alloc(prt_mesh *m, int64_t nv, int64_t nt, const char *what, prt_error *err) {
    memset(m, 0, sizeof *m);
    if (nv > MESH_MAX_ELEMS || nt > MESH_MAX_ELEMS)
        return prt_fail(err, "%s: too many vertices (%lld)", what, (long long)nv);
    m->pos = malloc(3 * (size_t)nv * sizeof(float));
    m->nrm = malloc(3 * (size_t)nv * sizeof(float));
    m->mat = calloc((size_t)nv, sizeof(uint16_t));
    m->tris = malloc(3 * (size_t)nt * sizeof(uint32_t));
    if (!m->pos || !m->nrm || !m->mat || !m->tris) {
        mesh_free(m);
        return prt_fail(err, "%s: out of memory", what);
    }
    m->nverts = (int)nv;
    m->ntris = (int)nt;
    return 0;
}

static void put_tri(uint32_t *t, uint32_t a, uint32_t b, uint32_t c) { t[0] = a; t[1] = b; t[2] = c; }

static bool finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

int mesh_make_sphere(prt_mesh *out, const float center[3], float radius, int rings, int segments, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (!finite3(center) || !(radius > 0.f) || !isfinite(radius))
        return prt_fail(err, "sphere: bad centre or radius %g", (double)radius);
    if (rings < 2 || segments < 3 || rings > 16384 || segments > 16384)
        return prt_fail(err, "sphere: needs 2..16384 rings and 3..16384 segments (got %d, %d)", rings, segments);
    int64_t nv = 2 + (int64_t)(rings - 1) * segments, nt = 2 * (int64_t)segments * (rings - 1);
    if (mesh_alloc(out, nv, nt, "sphere", err)) return -1;
    /* Vertex 0 is the north pole (+y), then rings-1 latitude rows of `segments`
     * vertices (the seam is shared, not duplicated), then the south pole. */
    int south = (int)nv - 1;
    for (int i = 0; i <= rings; i++) {
        double th = M_PI * i / rings, st = sin(th), ct = cos(th);
        int jn = (i == 0 || i == rings) ? 1 : segments;
        for (int j = 0; j < jn; j++) {
            double ph = 2.0 * M_PI * j / segments;
            double d[3] = { st * cos(ph), ct, st * sin(ph) };
            if (i == 0 || i == rings) { d[0] = 0; d[2] = 0; d[1] = i == 0 ? 1 : -1; }
            int v = i == 0 ? 0 : i == rings ? south : 1 + (i - 1) * segments + j;
            for (int k = 0; k < 3; k++) {
                out->nrm[3 * v + k] = (float)d[k];
                out->pos[3 * v + k] = (float)(center[k] + radius * d[k]);
            }
        }
    }
    /* (a, a+phi, a+theta) winds counter-clockwise seen from outside: d_phi x d_theta points out. */
    uint32_t *t = out->tris;
    for (int i = 0; i < rings; i++)
        for (int j = 0; j < segments; j++) {
            int j1 = (j + 1) % segments;
            uint32_t a = i == 0 ? 0 : (uint32_t)(1 + (i - 1) * segments + j);
            uint32_t b = i == 0 ? 0 : (uint32_t)(1 + (i - 1) * segments + j1);
            uint32_t c = i == rings - 1 ? (uint32_t)south : (uint32_t)(1 + i * segments + j);
            uint32_t d = i == rings - 1 ? (uint32_t)south : (uint32_t)(1 + i * segments + j1);
            if (i != 0) { put_tri(t, a, b, c); t += 3; }
            if (i != rings - 1) { put_tri(t, b, d, c); t += 3; }
        }
    return 0;
}

int mesh_make_plane(prt_mesh *out, float x0, float x1, float z0, float z1, float height, int nx, int nz, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (!(x1 > x0) || !(z1 > z0) || !isfinite(x0) || !isfinite(x1) || !isfinite(z0) || !isfinite(z1) || !isfinite(height))
        return prt_fail(err, "plane: bad extent [%g,%g]x[%g,%g] at height %g", (double)x0, (double)x1, (double)z0,
                        (double)z1, (double)height);
    if (nx < 2 || nz < 2 || nx > 65536 || nz > 65536)
        return prt_fail(err, "plane: needs 2..65536 vertices per side (got %d x %d)", nx, nz);
    if (mesh_alloc(out, (int64_t)nx * nz, 2 * (int64_t)(nx - 1) * (nz - 1), "plane", err)) return -1;
    for (int k = 0; k < nz; k++)
        for (int i = 0; i < nx; i++) {
            size_t v = (size_t)k * nx + i;
            /* Exact end points, so tiles of adjacent planes meet. */
            float x = i == nx - 1 ? x1 : (float)(x0 + ((double)x1 - x0) * i / (nx - 1));
            float z = k == nz - 1 ? z1 : (float)(z0 + ((double)z1 - z0) * k / (nz - 1));
            v3_set(out->pos + 3 * v, x, height, z);
            v3_set(out->nrm + 3 * v, 0.f, 1.f, 0.f);
        }
    /* dz x dx = +y: (a, a+z, a+x) is counter-clockwise seen from +y. */
    uint32_t *t = out->tris;
    for (int k = 0; k + 1 < nz; k++)
        for (int i = 0; i + 1 < nx; i++) {
            uint32_t a = (uint32_t)(k * nx + i), b = a + 1, c = a + (uint32_t)nx, d = c + 1;
            put_tri(t, a, c, b); t += 3;
            put_tri(t, b, c, d); t += 3;
        }
    return 0;
}

int mesh_make_box(prt_mesh *out, const float bmin[3], const float bmax[3], int n, bool open_top, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (!finite3(bmin) || !finite3(bmax) || !(bmax[0] > bmin[0]) || !(bmax[1] > bmin[1]) || !(bmax[2] > bmin[2]))
        return prt_fail(err, "box: max (%g,%g,%g) must exceed min (%g,%g,%g)", (double)bmax[0], (double)bmax[1],
                        (double)bmax[2], (double)bmin[0], (double)bmin[1], (double)bmin[2]);
    if (n < 1 || n > 4096) return prt_fail(err, "box: needs 1..4096 quads per face side (got %d)", n);
    /* Each face: normal axis, sign, and (u, v) axes with u x v = the outward normal. */
    static const int faces[6][4] = { { 0, +1, 1, 2 }, { 0, -1, 2, 1 }, { 1, +1, 2, 0 },
                                     { 1, -1, 0, 2 }, { 2, +1, 0, 1 }, { 2, -1, 1, 0 } };
    int nf = open_top ? 5 : 6, side = n + 1;
    if (mesh_alloc(out, (int64_t)nf * side * side, (int64_t)nf * 2 * n * n, "box", err)) return -1;
    int f = 0;
    uint32_t *t = out->tris;
    for (int fi = 0; fi < 6; fi++) {
        int ax = faces[fi][0], sg = faces[fi][1], ua = faces[fi][2], va = faces[fi][3];
        if (open_top && ax == 1 && sg > 0) continue;
        uint32_t base = (uint32_t)(f * side * side);
        for (int j = 0; j < side; j++)
            for (int i = 0; i < side; i++) {
                float *p = out->pos + 3 * (base + (size_t)j * side + i);
                float *nn = out->nrm + 3 * (base + (size_t)j * side + i);
                p[ax] = sg > 0 ? bmax[ax] : bmin[ax];
                p[ua] = i == n ? bmax[ua] : (float)(bmin[ua] + ((double)bmax[ua] - bmin[ua]) * i / n);
                p[va] = j == n ? bmax[va] : (float)(bmin[va] + ((double)bmax[va] - bmin[va]) * j / n);
                v3_set(nn, 0.f, 0.f, 0.f);
                nn[ax] = (float)sg;
            }
        /* u x v is outward: (a, a+u, a+v) is counter-clockwise seen from outside. */
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                uint32_t a = base + (uint32_t)(j * side + i), b = a + 1, c = a + (uint32_t)side, d = c + 1;
                put_tri(t, a, b, c); t += 3;
                put_tri(t, b, d, c); t += 3;
            }
        f++;
    }
    return 0;
}

int mesh_make_torus(prt_mesh *out, const float center[3], float major, float minor, int nu, int nv, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (!finite3(center) || !(major > 0.f) || !(minor > 0.f) || !isfinite(major) || !isfinite(minor))
        return prt_fail(err, "torus: bad centre or radii (major %g, minor %g)", (double)major, (double)minor);
    if (nu < 3 || nv < 3 || nu > 16384 || nv > 16384)
        return prt_fail(err, "torus: needs 3..16384 segments each way (got %d, %d)", nu, nv);
    if (mesh_alloc(out, (int64_t)nu * nv, 2 * (int64_t)nu * nv, "torus", err)) return -1;
    for (int i = 0; i < nu; i++) {
        double u = 2.0 * M_PI * i / nu, cu = cos(u), su = sin(u);
        for (int j = 0; j < nv; j++) {
            double w = 2.0 * M_PI * j / nv, cw = cos(w), sw = sin(w);
            double d[3] = { cw * cu, sw, cw * su }; /* exact outward normal */
            size_t v = (size_t)i * nv + j;
            out->pos[3 * v + 0] = (float)(center[0] + major * cu + minor * d[0]);
            out->pos[3 * v + 1] = (float)(center[1] + minor * d[1]);
            out->pos[3 * v + 2] = (float)(center[2] + major * su + minor * d[2]);
            for (int k = 0; k < 3; k++) out->nrm[3 * v + k] = (float)d[k];
        }
    }
    /* d_u x d_v points inward here, so (a, a+v, a+u) is the outward winding. */
    uint32_t *t = out->tris;
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j);
            uint32_t c = (uint32_t)(i * nv + (j + 1) % nv), d = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv);
            put_tri(t, a, c, b); t += 3;
            put_tri(t, b, c, d); t += 3;
        }
    return 0;
}
