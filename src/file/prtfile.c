/* prtfile.c - the .prt file: everything precomputation produces, written once
 * and read by every later command (see prtfile.h).
 *
 * Layout (all little-endian):
 *     "PRTF"  u32 version  u64 payload            header, 16 bytes
 *     payload: sections, each  u32 tag  u64 length  bytes[length]
 *     u32 CRC-32 (zlib) of every byte before it
 * Sections (each exactly once; unknown tags are skipped, so later minor additions
 * stay readable):
 *     META  resolutions, basis, N, qbits, statistics, effects plan
 *     MESH  positions, normals, triangles, per-vertex material, floor, bounds, load stats
 *     MATL  per material: BRDF parameters, spec string, factorization (K, maps, sigma)
 *     TRAN  transport: offsets, block runs, scales, coefficients for its qbits
 * Scalars are written field by field (never whole structs), so padding and
 * layout of the C structs do not leak into the format; arrays go out in one
 * fwrite on a little-endian host and element by element otherwise.
 *
 * Writing counts each section's length in a first, silent pass of the same
 * serializer, so the file streams out with no copy of the data in memory; it
 * goes to a temporary name and is renamed at the end (prt_atomic_*).
 *
 * Reading loads the file, checks magic, version, the payload length against
 * the file size, the CRC, then parses each section with a bounds-checked
 * cursor and finally validates every index the runtime will follow (triangle
 * indices, materials, per-vertex vector counts against each material's K,
 * coefficient and run offsets, blocks, ascending wavelet indices) and that
 * every float is finite. A CRC only catches accidents; these checks are what
 * make a crafted file fail with one line instead of crashing the renderer. */
#include "prtfile.h"
#include "sparse.h"
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

#define TAG(a, b, c, d) ((uint32_t)(a) | (uint32_t)(b) << 8 | (uint32_t)(c) << 16 | (uint32_t)(d) << 24)
#define TAG_META TAG('M', 'E', 'T', 'A')
#define TAG_MESH TAG('M', 'E', 'S', 'H')
#define TAG_MATL TAG('M', 'A', 'T', 'L')
#define TAG_TRAN TAG('T', 'R', 'A', 'N')
#define TAG_DIRT TAG('D', 'I', 'R', 'T')   /* optional: direct-only transport, same layout as TRAN */
#define HEADER_BYTES 16
#define MAX_RES 4096          /* vis_res, gather_res, BRDF map res: far above anything sane */

static bool data_ok(const prt_data *d, char *why);

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HOST_LE 1
#else
#define HOST_LE 0
#endif

/* ---- writing ---------------------------------------------------------------------------- */

/* Output stream; f == NULL only counts bytes (the first pass that sizes sections). */
typedef struct wr {
    FILE *f;
    uint64_t n;
    uLong crc;
    bool bad;
} wr;

/* Writes (or only counts) len bytes and folds them into the CRC. */
static void w_bytes(wr *w, const void *p, size_t len) {
    if (w->f && len) {
        if (fwrite(p, 1, len, w->f) != len) w->bad = true;
        const Bytef *b = p;
        for (size_t off = 0; off < len;) {   /* crc32 takes 32-bit lengths */
            size_t chunk = len - off > (1u << 30) ? (1u << 30) : len - off;
            w->crc = crc32(w->crc, b + off, (uInt)chunk);
            off += chunk;
        }
    }
    w->n += len;
}
static void w_u8(wr *w, uint8_t v) { w_bytes(w, &v, 1); }
/* Little-endian scalars (floats as their IEEE bits). */
static void w_u16(wr *w, uint16_t v) {
    uint8_t b[2] = { (uint8_t)v, (uint8_t)(v >> 8) };
    w_bytes(w, b, 2);
}
static void w_u32(wr *w, uint32_t v) {
    uint8_t b[4] = { (uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24) };
    w_bytes(w, b, 4);
}
static void w_u64(wr *w, uint64_t v) {
    w_u32(w, (uint32_t)v);
    w_u32(w, (uint32_t)(v >> 32));
}
static void w_i32(wr *w, int32_t v) { w_u32(w, (uint32_t)v); }
static void w_f32(wr *w, float v) {
    uint32_t u;
    memcpy(&u, &v, 4);
    w_u32(w, u);
}
static void w_f64(wr *w, double v) {
    uint64_t u;
    memcpy(&u, &v, 8);
    w_u64(w, u);
}
/* Array of count elements of size es (1, 2 or 4 bytes; floats as their bits). */
static void w_arr(wr *w, const void *p, size_t count, size_t es) {
    if (HOST_LE || es == 1 || !w->f) {
        w_bytes(w, p, count * es);
        return;
    }
    const uint8_t *b = p;
    for (size_t i = 0; i < count; i++) {
        if (es == 2) { uint16_t v; memcpy(&v, b + 2 * i, 2); w_u16(w, v); }
        else { uint32_t v; memcpy(&v, b + 4 * i, 4); w_u32(w, v); }
    }
}
/* u32 length (at most cap) and the bytes, no terminator. */
static void w_str(wr *w, const char *s, size_t cap) {
    size_t n = strnlen(s, cap);
    w_u32(w, (uint32_t)n);
    w_bytes(w, s, n);
}

static size_t ncoefs_of(const prt_transport *t) { return t->coef_first && t->nvecs >= 0 ? t->coef_first[t->nvecs] : 0; }
static size_t nruns_of(const prt_transport *t) { return t->run_first && t->nvecs >= 0 ? t->run_first[t->nvecs] : 0; }

/* Section writers: each emits its fields in the order its reader takes them. */
static void sec_meta(wr *w, const prt_data *d) {
    const prt_stats *s = &d->stats;
    w_i32(w, d->vis_res);
    w_i32(w, d->gather_res);
    w_i32(w, d->sh_order);
    w_i32(w, d->transport.N);
    w_i32(w, d->transport.qbits);
    w_f64(w, s->t_brdf);
    w_f64(w, s->t_visibility);
    w_f64(w, s->t_transport);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) w_f64(w, s->t_bounce[i]);
    w_f64(w, s->t_write);
    w_f64(w, s->t_total);
    w_u64(w, (uint64_t)s->rays_traced);
    w_u64(w, (uint64_t)s->rays_hit);
    w_f64(w, s->hit_fraction);
    w_i32(w, s->bounces);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) w_f64(w, s->bounce_energy[i]);
    w_f64(w, s->trunc_rel_err);
    w_u64(w, (uint64_t)s->peak_rss_bytes);
    w_str(w, d->plan, sizeof d->plan - 1);
}

static void sec_mesh(wr *w, const prt_data *d) {
    const prt_scene *sc = &d->scene;
    const prt_mesh *m = &sc->mesh;
    w_i32(w, m->nverts);
    w_i32(w, m->ntris);
    w_arr(w, m->pos, 3 * (size_t)m->nverts, 4);
    w_arr(w, m->nrm, 3 * (size_t)m->nverts, 4);
    w_arr(w, m->tris, 3 * (size_t)m->ntris, 4);
    w_arr(w, m->mat, (size_t)m->nverts, 2);
    w_i32(w, sc->floor_first_vertex);
    for (int k = 0; k < 3; k++) w_f32(w, sc->bmin[k]);
    for (int k = 0; k < 3; k++) w_f32(w, sc->bmax[k]);
    const mesh_load_stats *ls = &sc->load_stats;
    w_i32(w, ls->obj_vertices);
    w_i32(w, ls->faces);
    w_i32(w, ls->welded);
    w_i32(w, ls->degenerate);
    w_i32(w, ls->unused);
}

static size_t factor_len(const brdf_factor *f) { return f->K > 0 ? (size_t)f->res * f->res * f->K * 3 : 0; }

static void sec_matl(wr *w, const prt_data *d) {
    const prt_scene *sc = &d->scene;
    w_i32(w, sc->nmaterials);
    for (int m = 0; m < sc->nmaterials; m++) {
        const brdf_params *p = &sc->materials[m];
        w_i32(w, (int32_t)p->type);
        for (int k = 0; k < 3; k++) w_f32(w, p->kd[k]);
        for (int k = 0; k < 3; k++) w_f32(w, p->ks[k]);
        w_f32(w, p->n);
        w_f32(w, p->nu);
        w_f32(w, p->nv);
        w_f32(w, p->alpha);
        w_i32(w, p->nlobes);
        for (int l = 0; l < BRDF_MAX_LOBES; l++)
            for (int k = 0; k < 4; k++) w_f32(w, p->lobe[l][k]);
        w_str(w, sc->material_spec[m], sizeof sc->material_spec[m] - 1);
        const brdf_factor *f = &d->factors[m];
        w_i32(w, f->K);
        w_i32(w, f->res);
        w_i32(w, (int32_t)f->param);
        w_i32(w, f->nsigma);
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < BRDF_MAX_SIGMA; k++) w_f32(w, f->sigma[c][k]);
        for (int k = 0; k <= BRDF_MAX_SIGMA; k++) w_f32(w, f->rel_rms[k]);
        w_u8(w, f->lambertian ? 1 : 0);
        w_f64(w, f->seconds);
        w_arr(w, f->light, factor_len(f), 4);
        w_arr(w, f->view, factor_len(f), 4);
    }
}

static void w_transport(wr *w, const prt_transport *t) {
    size_t nc = ncoefs_of(t), nr = nruns_of(t);
    w_i32(w, t->nverts);
    w_i32(w, t->nvecs);
    w_i32(w, t->N);
    w_i32(w, t->qbits);
    w_u64(w, nc);
    w_u64(w, nr);
    w_arr(w, t->vec_first, (size_t)t->nverts + 1, 4);
    w_arr(w, t->coef_first, (size_t)t->nvecs + 1, 4);
    w_arr(w, t->run_first, (size_t)t->nvecs + 1, 4);
    w_arr(w, t->runs, 2 * nr, 1);
    w_arr(w, t->scale, 3 * (size_t)t->nvecs, 4);
    if (t->qbits == 8) {
        w_arr(w, t->packed, nc, 4);
    } else {
        w_arr(w, t->offs, nc, 1);
        if (t->qbits == 16) w_arr(w, t->q16, 3 * nc, 2);
        else w_arr(w, t->f32, 3 * nc, 4);
    }
}

static void sec_tran(wr *w, const prt_data *d) { w_transport(w, &d->transport); }
static void sec_dirt(wr *w, const prt_data *d) { w_transport(w, &d->direct); }

typedef void (*sec_fn)(wr *, const prt_data *);

/* Writes one tagged section: sizes it with a counting pass, then writes it. */
static void w_section(wr *w, uint32_t tag, sec_fn fn, const prt_data *d) {
    wr count = { 0 };
    fn(&count, d);
    w_u32(w, tag);
    w_u64(w, count.n);
    fn(w, d);
}

/* Writes d to path (temporary file, then rename). Returns 0 or -1 (err names the file). */
int prtfile_write(const char *path, const prt_data *d, prt_error *err) {
    /* Never write what the reader would refuse (an index out of range, a NaN). */
    char why[256];
    if (!data_ok(d, why)) return prt_fail(err, "%s: cannot write: %s", path, why);
    char tmp[4200];
    if (strlen(path) > 4000) return prt_fail(err, "%.60s...: output path too long", path);
    FILE *f = prt_atomic_open(path, tmp, sizeof tmp, err);
    if (!f) return -1;
    /* Payload length: the four sections, each with its 12-byte tag and length. */
    static const sec_fn fns[5] = { sec_meta, sec_mesh, sec_matl, sec_tran, sec_dirt };
    static const uint32_t tags[5] = { TAG_META, TAG_MESH, TAG_MATL, TAG_TRAN, TAG_DIRT };
    int nsec = d->direct.nvecs ? 5 : 4;
    uint64_t payload = 0;
    for (int i = 0; i < nsec; i++) {
        wr c = { 0 };
        fns[i](&c, d);
        payload += 12 + c.n;
    }
    wr w = { .f = f, .crc = crc32(0L, Z_NULL, 0) };
    w_bytes(&w, "PRTF", 4);
    w_u32(&w, PRTFILE_VERSION);
    w_u64(&w, payload);
    for (int i = 0; i < nsec; i++) w_section(&w, tags[i], fns[i], d);
    uint32_t crc = (uint32_t)w.crc;
    w_u32(&w, crc);
    if (w.bad) {
        prt_atomic_abort(f, tmp);
        return prt_fail(err, "%s: write failed: %s", path, strerror(errno));
    }
    return prt_atomic_commit(f, tmp, path, err);
}

/* ---- reading ---------------------------------------------------------------------------- */

/* Bounds-checked cursor over one section; any overrun sets bad and yields zeros. */
typedef struct rd {
    const uint8_t *p;
    size_t n, pos;
    bool bad;
} rd;

/* Are count elements of es bytes left? Sets bad (sticky) if not; overflow-safe. */
static bool r_need(rd *r, size_t count, size_t es) {
    if (r->bad) return false;
    if (es && count > (r->n - r->pos) / es) {
        r->bad = true;
        return false;
    }
    return true;
}
/* Little-endian scalars; 0 once the cursor has overrun. */
static uint32_t r_u32(rd *r) {
    if (!r_need(r, 1, 4)) return 0;
    const uint8_t *b = r->p + r->pos;
    r->pos += 4;
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}
static uint64_t r_u64(rd *r) {
    uint64_t lo = r_u32(r);
    return lo | (uint64_t)r_u32(r) << 32;
}
static uint8_t r_u8(rd *r) {
    if (!r_need(r, 1, 1)) return 0;
    return r->p[r->pos++];
}
static int32_t r_i32(rd *r) { return (int32_t)r_u32(r); }
static float r_f32(rd *r) {
    uint32_t u = r_u32(r);
    float v;
    memcpy(&v, &u, 4);
    return v;
}
static double r_f64(rd *r) {
    uint64_t u = r_u64(r);
    double v;
    memcpy(&v, &u, 8);
    return v;
}
/* Allocates and reads count elements of size es; NULL (bad set) if the section is too short.
 * A zero count gives a valid one-byte allocation so owners can always free it. */
static void *r_arr(rd *r, size_t count, size_t es, bool *oom) {
    if (!r_need(r, count, es)) return NULL;
    void *dst = malloc(count * es > 0 ? count * es : 1);
    if (!dst) {
        *oom = true;
        r->bad = true;
        return NULL;
    }
    const uint8_t *b = r->p + r->pos;
    if (HOST_LE || es == 1) {
        memcpy(dst, b, count * es);
    } else {
        for (size_t i = 0; i < count; i++) {
            const uint8_t *e = b + i * es;
            if (es == 2) { uint16_t v = (uint16_t)(e[0] | e[1] << 8); memcpy((uint8_t *)dst + 2 * i, &v, 2); }
            else { uint32_t v = (uint32_t)e[0] | (uint32_t)e[1] << 8 | (uint32_t)e[2] << 16 | (uint32_t)e[3] << 24; memcpy((uint8_t *)dst + 4 * i, &v, 4); }
        }
    }
    r->pos += count * es;
    return dst;
}
/* Reads a length-prefixed string into buf[cap] (NUL-terminated); false if too long. */
static bool r_str(rd *r, char *buf, size_t cap) {
    uint32_t n = r_u32(r);
    if (n >= cap || !r_need(r, n, 1)) {
        r->bad = true;
        buf[0] = 0;
        return false;
    }
    memcpy(buf, r->p + r->pos, n);
    buf[n] = 0;
    r->pos += n;
    return true;
}

/* True if none of v[0..n) is NaN or infinite. */
static bool all_finite(const float *v, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) return false;
    return true;
}

/* ---- consistency (shared by the writer and the reader) ------------------------------------ */

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

/* True when everything the runtime will index or print is in range and finite; else
 * false with the first problem in why[256]. Array lengths are those the counts imply
 * (the reader has already matched them against the file). */
/* Checks one transport set against d's mesh and factors; false with why on the first problem. */
static bool transport_ok(const prt_data *d, const prt_transport *t, char *why) {
    const prt_mesh *m = &d->scene.mesh;
    int nv = m->nverts;
    if (t->qbits != 8 && t->qbits != 16 && t->qbits != 32) return BAD(why, "bad quantization %d bits", t->qbits);
    if (t->N < 1 || t->N > CUBE_TEXELS) return BAD(why, "bad coefficient count N = %d", t->N);
    if (t->nverts != nv) return BAD(why, "transport has %d vertices, the mesh %d", t->nverts, nv);
    if (t->nvecs < 0) return BAD(why, "bad vector count %d", t->nvecs);
    if (t->stage_count || t->stage_idx || t->stage_val) return BAD(why, "transport not finished (transport_finish)");
    if (!t->vec_first || !t->coef_first || !t->run_first || !t->scale) return BAD(why, "transport offsets missing");
    if (t->vec_first[0] != 0) return BAD(why, "vector offsets do not start at 0");
    for (int v = 0; v < nv; v++) {
        uint32_t a = t->vec_first[v], b = t->vec_first[v + 1];
        if (b < a || b > (uint32_t)t->nvecs) return BAD(why, "vector offsets not increasing at vertex %d", v);
        int K = d->factors[m->mat[v]].K;
        if (b - a != (uint32_t)K) return BAD(why, "vertex %d has %u vectors but its material %u has K = %d", v, b - a, m->mat[v], K);
    }
    if (t->vec_first[nv] != (uint32_t)t->nvecs) return BAD(why, "vector offsets end at %u, not %d", t->vec_first[nv], t->nvecs);
    if (t->coef_first[0] != 0 || t->run_first[0] != 0) return BAD(why, "coefficient or run offsets do not start at 0");
    size_t nc = t->coef_first[t->nvecs], nr = t->run_first[t->nvecs];
    if (nc && (t->qbits == 8 ? !t->packed : (!t->offs || (t->qbits == 16 ? !t->q16 : !t->f32))))
        return BAD(why, "transport coefficients missing");
    if (nr && !t->runs) return BAD(why, "transport runs missing");
    for (int i = 0; i < t->nvecs; i++) {
        uint32_t c0 = t->coef_first[i], c1 = t->coef_first[i + 1], q0 = t->run_first[i], q1 = t->run_first[i + 1];
        if (c1 < c0 || c1 - c0 > (uint32_t)t->N || c1 > nc) return BAD(why, "vector %d: bad coefficient offsets", i);
        if (q1 < q0 || q1 > nr) return BAD(why, "vector %d: bad run offsets", i);
        /* The runs cover exactly this vector's coefficients, blocks in range, and the full
         * indices block * 256 + offset strictly ascending (section 4.1.2's index split). */
        uint32_t c = c0;
        long prev = -1;
        for (uint32_t q = q0; q < q1; q++) {
            uint32_t block = t->runs[2 * q], count = (uint32_t)t->runs[2 * q + 1] + 1;
            if (block >= SPARSE_NBLOCKS) return BAD(why, "vector %d: block %u out of range", i, block);
            if (count > c1 - c) return BAD(why, "vector %d: runs cover more than its %u coefficients", i, c1 - c0);
            for (uint32_t k = 0; k < count; k++, c++) {
                uint32_t off = t->qbits == 8 ? (t->packed[c] & 255u) : t->offs[c];
                long idx = (long)block * SPARSE_BLOCK + off;
                if (idx <= prev) return BAD(why, "vector %d: coefficient indices not ascending", i);
                prev = idx;
            }
        }
        if (c != c1) return BAD(why, "vector %d: runs cover %u of its %u coefficients", i, c - c0, c1 - c0);
    }
    if (!all_finite(t->scale, 3 * (size_t)t->nvecs)) return BAD(why, "non-finite quantization scales");
    for (size_t i = 0; i < 3 * (size_t)t->nvecs; i++)
        if (t->scale[i] < 0) return BAD(why, "negative quantization scale");
    if (t->qbits == 32 && !all_finite(t->f32, 3 * nc)) return BAD(why, "non-finite coefficients");
    return true;
}

static bool data_ok(const prt_data *d, char *why) {
    const prt_stats *s = &d->stats;
    if (d->vis_res < 1 || d->vis_res > MAX_RES || d->gather_res < 1 || d->gather_res > MAX_RES)
        return BAD(why, "bad cube resolutions %d, %d", d->vis_res, d->gather_res);
    if (d->sh_order < 0 || d->sh_order > 64) return BAD(why, "bad spherical-harmonic order %d", d->sh_order);
    if (s->bounces < 0 || s->bounces > PRT_MAX_BOUNCES) return BAD(why, "bad bounce count %d", s->bounces);
    double st[] = { s->t_brdf, s->t_visibility, s->t_transport, s->t_write, s->t_total, s->hit_fraction, s->trunc_rel_err };
    for (size_t i = 0; i < sizeof st / sizeof st[0]; i++)
        if (!isfinite(st[i])) return BAD(why, "non-finite statistics");
    for (int i = 0; i < PRT_MAX_BOUNCES; i++)
        if (!isfinite(s->t_bounce[i]) || !isfinite(s->bounce_energy[i])) return BAD(why, "non-finite statistics");

    const prt_scene *sc = &d->scene;
    const prt_mesh *m = &sc->mesh;
    int nv = m->nverts, nt = m->ntris, nm = sc->nmaterials;
    if (nv < 1 || nt < 1) return BAD(why, "empty mesh (%d vertices, %d triangles)", nv, nt);
    if (!m->pos || !m->nrm || !m->mat || !m->tris) return BAD(why, "mesh arrays missing");
    if (!all_finite(m->pos, 3 * (size_t)nv) || !all_finite(m->nrm, 3 * (size_t)nv)) return BAD(why, "non-finite vertex data");
    if (!all_finite(sc->bmin, 3) || !all_finite(sc->bmax, 3)) return BAD(why, "non-finite bounds");
    for (size_t i = 0; i < 3 * (size_t)nt; i++)
        if (m->tris[i] >= (uint32_t)nv) return BAD(why, "triangle %zu uses vertex %u of %d", i / 3, m->tris[i], nv);
    if (sc->floor_first_vertex < -1 || sc->floor_first_vertex >= nv) return BAD(why, "bad floor start %d", sc->floor_first_vertex);
    if (nm < 1 || nm > PRT_MAX_MATERIALS) return BAD(why, "bad material count %d", nm);
    for (int v = 0; v < nv; v++)
        if (m->mat[v] >= nm) return BAD(why, "vertex %d uses material %u of %d", v, m->mat[v], nm);

    for (int i = 0; i < nm; i++) {
        const brdf_params *p = &sc->materials[i];
        const brdf_factor *f = &d->factors[i];
        if ((int)p->type < 0 || p->type > BRDF_BECKMANN) return BAD(why, "material %d: unknown BRDF type %d", i, (int)p->type);
        if (p->nlobes < 0 || p->nlobes > BRDF_MAX_LOBES) return BAD(why, "material %d: bad lobe count %d", i, p->nlobes);
        float pv[] = { p->kd[0], p->kd[1], p->kd[2], p->ks[0], p->ks[1], p->ks[2], p->n, p->nu, p->nv, p->alpha };
        if (!all_finite(pv, 10) || !all_finite(&p->lobe[0][0], 4 * BRDF_MAX_LOBES))
            return BAD(why, "material %d: non-finite BRDF parameters", i);
        if (f->K < 0 || f->K > BRDF_MAX_SIGMA) return BAD(why, "material %d: bad term count K = %d", i, f->K);
        if (f->res < 0 || f->res > MAX_RES || (f->K > 0 && f->res < 1))
            return BAD(why, "material %d: bad BRDF map resolution %d", i, f->res);
        if (f->param != BRDF_PARAM_GRID && f->param != BRDF_PARAM_POLAR)
            return BAD(why, "material %d: bad parameterization %d", i, (int)f->param);
        if (f->nsigma < 0 || f->nsigma > BRDF_MAX_SIGMA) return BAD(why, "material %d: bad singular value count %d", i, f->nsigma);
        if (!isfinite(f->seconds) || !all_finite(&f->sigma[0][0], 3 * BRDF_MAX_SIGMA) || !all_finite(f->rel_rms, BRDF_MAX_SIGMA + 1))
            return BAD(why, "material %d: non-finite factor statistics", i);
        if (f->K > 0 && (!f->light || !f->view)) return BAD(why, "material %d: BRDF maps missing", i);
        if (f->K > 0 && (!all_finite(f->light, factor_len(f)) || !all_finite(f->view, factor_len(f))))
            return BAD(why, "material %d: non-finite BRDF maps", i);
    }

    if (!transport_ok(d, &d->transport, why)) return false;
    /* The optional direct-only set (kept for the viewer's direct/bounces toggle) has the
     * same layout as the total transport. */
    if (d->direct.nvecs || d->direct.vec_first) {
        if (!transport_ok(d, &d->direct, why)) return false;
        if (d->direct.nvecs != d->transport.nvecs) return BAD(why, "direct transport has %d vectors, the total %d", d->direct.nvecs, d->transport.nvecs);
    }
    return true;
}

/* ---- section readers: sizes and allocation only; data_ok() checks the contents ------------- */

typedef struct parse {
    prt_data *d;
    bool oom;
    char why[256];
    int meta_N, meta_qbits;
} parse;

/* Section readers: parse one section into P->d; false with P->why on a short or oversized section. */
static bool rd_meta(parse *P, rd *r) {
    prt_data *d = P->d;
    prt_stats *s = &d->stats;
    d->vis_res = r_i32(r);
    d->gather_res = r_i32(r);
    d->sh_order = r_i32(r);
    P->meta_N = r_i32(r);
    P->meta_qbits = r_i32(r);
    s->t_brdf = r_f64(r);
    s->t_visibility = r_f64(r);
    s->t_transport = r_f64(r);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) s->t_bounce[i] = r_f64(r);
    s->t_write = r_f64(r);
    s->t_total = r_f64(r);
    s->rays_traced = (long)r_u64(r);
    s->rays_hit = (long)r_u64(r);
    s->hit_fraction = r_f64(r);
    s->bounces = r_i32(r);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) s->bounce_energy[i] = r_f64(r);
    s->trunc_rel_err = r_f64(r);
    s->peak_rss_bytes = (size_t)r_u64(r);
    r_str(r, d->plan, sizeof d->plan);
    return r->bad ? BAD(P->why, "META section too short") : true;
}

static bool rd_mesh(parse *P, rd *r) {
    prt_scene *sc = &P->d->scene;
    prt_mesh *m = &sc->mesh;
    int nv = r_i32(r), nt = r_i32(r);
    if (r->bad) return BAD(P->why, "MESH section too short");
    if (nv < 1 || nt < 1 || nv > INT32_MAX / 3 || nt > INT32_MAX / 3)
        return BAD(P->why, "bad mesh size (%d vertices, %d triangles)", nv, nt);
    m->pos = r_arr(r, 3 * (size_t)nv, 4, &P->oom);
    m->nrm = r_arr(r, 3 * (size_t)nv, 4, &P->oom);
    m->tris = r_arr(r, 3 * (size_t)nt, 4, &P->oom);
    m->mat = r_arr(r, (size_t)nv, 2, &P->oom);
    if (r->bad) return BAD(P->why, "MESH section too short for %d vertices, %d triangles", nv, nt);
    m->nverts = nv;
    m->ntris = nt;
    sc->floor_first_vertex = r_i32(r);
    for (int k = 0; k < 3; k++) sc->bmin[k] = r_f32(r);
    for (int k = 0; k < 3; k++) sc->bmax[k] = r_f32(r);
    mesh_load_stats *ls = &sc->load_stats;
    ls->obj_vertices = r_i32(r);
    ls->faces = r_i32(r);
    ls->welded = r_i32(r);
    ls->degenerate = r_i32(r);
    ls->unused = r_i32(r);
    return r->bad ? BAD(P->why, "MESH section too short") : true;
}

static bool rd_matl(parse *P, rd *r) {
    prt_data *d = P->d;
    prt_scene *sc = &d->scene;
    int nm = r_i32(r);
    if (r->bad) return BAD(P->why, "MATL section too short");
    if (nm < 1 || nm > PRT_MAX_MATERIALS) return BAD(P->why, "bad material count %d", nm);
    sc->nmaterials = nm;
    for (int m = 0; m < nm; m++) {
        brdf_params *p = &sc->materials[m];
        p->type = (brdf_type)r_i32(r);
        for (int k = 0; k < 3; k++) p->kd[k] = r_f32(r);
        for (int k = 0; k < 3; k++) p->ks[k] = r_f32(r);
        p->n = r_f32(r);
        p->nu = r_f32(r);
        p->nv = r_f32(r);
        p->alpha = r_f32(r);
        p->nlobes = r_i32(r);
        for (int l = 0; l < BRDF_MAX_LOBES; l++)
            for (int k = 0; k < 4; k++) p->lobe[l][k] = r_f32(r);
        r_str(r, sc->material_spec[m], sizeof sc->material_spec[m]);
        brdf_factor *f = &d->factors[m];
        f->K = r_i32(r);
        f->res = r_i32(r);
        f->param = (brdf_param)r_i32(r);
        f->nsigma = r_i32(r);
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < BRDF_MAX_SIGMA; k++) f->sigma[c][k] = r_f32(r);
        for (int k = 0; k <= BRDF_MAX_SIGMA; k++) f->rel_rms[k] = r_f32(r);
        uint8_t lam = r_u8(r);
        f->lambertian = lam != 0;
        f->seconds = r_f64(r);
        if (r->bad) return BAD(P->why, "MATL section too short (material %d)", m);
        if (lam > 1) return BAD(P->why, "material %d: bad Lambertian flag", m);
        /* K and res size the maps: check them before allocating. */
        if (f->K < 0 || f->K > BRDF_MAX_SIGMA) return BAD(P->why, "material %d: bad term count K = %d", m, f->K);
        if (f->res < 0 || f->res > MAX_RES || (f->K > 0 && f->res < 1))
            return BAD(P->why, "material %d: bad BRDF map resolution %d", m, f->res);
        if (f->K > 0) {
            f->light = r_arr(r, factor_len(f), 4, &P->oom);
            f->view = r_arr(r, factor_len(f), 4, &P->oom);
            if (r->bad) return BAD(P->why, "MATL section too short for material %d's %dx%d maps", m, f->res, f->res);
        }
    }
    return true;
}

static bool rd_transport(parse *P, rd *r, prt_transport *t) {
    int nverts = r_i32(r), nvecs = r_i32(r), N = r_i32(r), qbits = r_i32(r);
    uint64_t nc = r_u64(r), nr = r_u64(r);
    if (r->bad) return BAD(P->why, "TRAN section too short");
    if (qbits != 8 && qbits != 16 && qbits != 32) return BAD(P->why, "bad quantization %d bits", qbits);
    if (N < 1 || N > CUBE_TEXELS) return BAD(P->why, "bad coefficient count N = %d", N);
    if (nverts < 0 || nverts > INT32_MAX - 1 || nvecs < 0 || nvecs > INT32_MAX / 3 - 1) return BAD(P->why, "bad transport size");
    if (nc > (uint64_t)nvecs * (uint64_t)N || nr > nc) return BAD(P->why, "bad coefficient or run totals");
    t->nverts = nverts;
    t->nvecs = nvecs;
    t->N = N;
    t->qbits = qbits;
    t->vec_first = r_arr(r, (size_t)nverts + 1, 4, &P->oom);
    t->coef_first = r_arr(r, (size_t)nvecs + 1, 4, &P->oom);
    t->run_first = r_arr(r, (size_t)nvecs + 1, 4, &P->oom);
    t->runs = r_arr(r, 2 * (size_t)nr, 1, &P->oom);
    t->scale = r_arr(r, 3 * (size_t)nvecs, 4, &P->oom);
    if (qbits == 8) {
        t->packed = r_arr(r, (size_t)nc, 4, &P->oom);
    } else {
        t->offs = r_arr(r, (size_t)nc, 1, &P->oom);
        if (qbits == 16) t->q16 = r_arr(r, 3 * (size_t)nc, 2, &P->oom);
        else t->f32 = r_arr(r, 3 * (size_t)nc, 4, &P->oom);
    }
    if (r->bad) return BAD(P->why, "TRAN section too short for %d vectors, %llu coefficients", nvecs, (unsigned long long)nc);
    /* The arrays were sized by nc and nr: the offsets must end exactly there. */
    if (t->coef_first[nvecs] != nc || t->run_first[nvecs] != nr) return BAD(P->why, "coefficient or run offsets do not match their totals");
    return true;
}

static bool rd_tran(parse *P, rd *r) { return rd_transport(P, r, &P->d->transport); }
static bool rd_dirt(parse *P, rd *r) { return rd_transport(P, r, &P->d->direct); }

/* Reads path into out. Returns 0, or -1 with one line naming the file (out is then empty). */
int prtfile_read(const char *path, prt_data *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->scene.floor_first_vertex = -1;
    FILE *f = fopen(path, "rb");
    if (!f) return prt_fail(err, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(f);
        return prt_fail(err, "%s: not a regular file", path);
    }
    size_t size = (size_t)st.st_size;
    if (size == 0) {
        fclose(f);
        return prt_fail(err, "%s: empty file (not a prt file)", path);
    }
    uint8_t *buf = malloc(size);
    if (!buf) {
        fclose(f);
        return prt_fail(err, "%s: out of memory reading %zu bytes", path, size);
    }
    size_t got = fread(buf, 1, size, f);
    fclose(f);
    int rc = -1;
    parse P = { .d = out };
    if (got != size) {
        prt_fail(err, "%s: read error: %s", path, strerror(errno));
        goto done;
    }
    if (size < 4 || memcmp(buf, "PRTF", 4) != 0) {
        prt_fail(err, "%s: not a prt file (bad magic)", path);
        goto done;
    }
    if (size < HEADER_BYTES + 4) {
        prt_fail(err, "%s: truncated (%zu bytes, less than a header)", path, size);
        goto done;
    }
    rd h = { buf, size, 4, false };
    uint32_t version = r_u32(&h);
    uint64_t payload = r_u64(&h);
    if (version != PRTFILE_VERSION) {
        prt_fail(err, "%s: version %u not supported (expected %d)", path, version, PRTFILE_VERSION);
        goto done;
    }
    if (payload > size - HEADER_BYTES - 4) {
        prt_fail(err, "%s: truncated (%zu bytes, expected %llu)", path, size, (unsigned long long)(payload + HEADER_BYTES + 4));
        goto done;
    }
    if (payload < size - HEADER_BYTES - 4) {
        prt_fail(err, "%s: corrupt (%zu bytes, but the header says %llu)", path, size, (unsigned long long)(payload + HEADER_BYTES + 4));
        goto done;
    }
    uLong crc = crc32(0L, Z_NULL, 0);
    for (size_t off = 0; off < size - 4;) {
        size_t chunk = size - 4 - off > (1u << 30) ? (1u << 30) : size - 4 - off;
        crc = crc32(crc, buf + off, (uInt)chunk);
        off += chunk;
    }
    rd tail = { buf, size, size - 4, false };
    if ((uint32_t)crc != r_u32(&tail)) {
        prt_fail(err, "%s: corrupt (checksum mismatch)", path);
        goto done;
    }
    /* Sections. */
    rd s = { buf, size - 4, HEADER_BYTES, false };
    bool seen[5] = { false, false, false, false, false };
    static const uint32_t order[5] = { TAG_META, TAG_MESH, TAG_MATL, TAG_TRAN, TAG_DIRT };
    static const char *names[5] = { "META", "MESH", "MATL", "TRAN", "DIRT" };
    while (s.pos < s.n) {
        uint32_t tag = r_u32(&s);
        uint64_t len = r_u64(&s);
        if (s.bad || len > s.n - s.pos) {
            prt_fail(err, "%s: corrupt (section runs past the end)", path);
            goto done;
        }
        rd sec = { buf + s.pos, (size_t)len, 0, false };
        s.pos += (size_t)len;
        int which = -1;
        for (int i = 0; i < 5; i++)
            if (tag == order[i]) which = i;
        if (which < 0) continue;   /* unknown section: skip */
        if (seen[which]) {
            prt_fail(err, "%s: corrupt (two %s sections)", path, names[which]);
            goto done;
        }
        /* Sections only read here; the cross-section checks follow in data_ok(). */
        bool ok = which == 0 ? rd_meta(&P, &sec) : which == 1 ? rd_mesh(&P, &sec) : which == 2 ? rd_matl(&P, &sec) : which == 3 ? rd_tran(&P, &sec) : rd_dirt(&P, &sec);
        if (P.oom) {
            prt_fail(err, "%s: out of memory", path);
            goto done;
        }
        if (!ok) {
            prt_fail(err, "%s: corrupt (%s)", path, P.why);
            goto done;
        }
        seen[which] = true;
    }
    for (int i = 0; i < 4; i++)   /* DIRT is optional */
        if (!seen[i]) {
            prt_fail(err, "%s: corrupt (no %s section)", path, names[i]);
            goto done;
        }
    if (P.meta_N != out->transport.N || P.meta_qbits != out->transport.qbits) {
        prt_fail(err, "%s: corrupt (META and TRAN disagree on N or qbits)", path);
        goto done;
    }
    if (!data_ok(out, P.why)) {
        prt_fail(err, "%s: corrupt (%s)", path, P.why);
        goto done;
    }
    rc = 0;
done:
    free(buf);
    if (rc) prt_data_free(out);
    return rc;
}

/* Frees everything in d (scene, factors, transport) and zeroes it. */
void prt_data_free(prt_data *d) {
    if (!d) return;
    scene_free(&d->scene);
    for (int m = 0; m < PRT_MAX_MATERIALS; m++) brdf_factor_free(&d->factors[m]);
    transport_free(&d->transport);
    transport_free(&d->direct);
    memset(d, 0, sizeof *d);
    d->scene.floor_first_vertex = -1;
}
