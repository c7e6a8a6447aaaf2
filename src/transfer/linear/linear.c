/* linear.c - what the linear representations stored as sparse coefficient sets share (linear.h
 * states the section layout and the checks): the leading config fields and their defaults, the
 * file section, the validation of every index, the default set setup, and the GLSL light
 * kernels. */
#include "linear.h"
#include "prtfile.h"
#include "sparse.h"
#include "check.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)
#define SPARSE_FILE_ALIGN 64   /* the coefficient arrays' alignment in the file (a cache line) */

linear_config linear_config_of(const transfer_config *cfg) {
    linear_config lc;
    memcpy(&lc, cfg->bytes, sizeof lc);
    return lc;
}

void linear_store(transfer_config *cfg, const void *priv, size_t size) {
    PRT_CHECK(size >= sizeof(linear_config) && size <= sizeof cfg->bytes);
    memset(cfg, 0, sizeof *cfg);
    memcpy(cfg->bytes, priv, size);
}

int linear_configure(const transfer_setup *s, linear_config *lc, prt_error *err) {
    memset(lc, 0, sizeof *lc);
    lc->N = s->N ? s->N : LINEAR_DEFAULT_N;
    lc->qbits = s->qbits ? s->qbits : 8;
    if (lc->N < 1 || lc->N > CUBE_TEXELS) return prt_fail(err, "N = %d is out of range 1..%d", lc->N, CUBE_TEXELS);
    if (lc->qbits != 8 && lc->qbits != 16 && lc->qbits != 32)
        return prt_fail(err, "qbits = %d (must be 8, 16 or 32)", lc->qbits);
    return 0;
}

int linear_init_set(const transfer_config *cfg, const transfer_linear_run *run, prt_transport *t, int nverts,
                    const int *nvec, prt_error *err) {
    linear_config lc = linear_config_of(cfg);
    if (transport_init(t, nverts, nvec, lc.N, lc.qbits, err)) return -1;
    t->block_level = TRANSPORT_BLOCK_LEVEL;   /* read only with the solid-angle measure; set as Haar sets it */
    return 0;
}

double linear_vector_bytes(const transfer_config *cfg) {
    linear_config lc = linear_config_of(cfg);
    return lc.N * (3.0 * lc.qbits / 8 + 1.5);
}

double linear_compress(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch) {
    return transport_store(t, i, r, g, b, scratch);
}

static size_t ncoefs_of(const prt_transport *t) { return t->coef_first && t->nvecs >= 0 ? t->coef_first[t->nvecs] : 0; }
static size_t nruns_of(const prt_transport *t) { return t->run_first && t->nvecs >= 0 ? t->run_first[t->nvecs] : 0; }

/* ---- writing ---------------------------------------------------------------------------- */

static void put_transport(prt_writer *w, const prt_transport *t) {
    size_t nc = ncoefs_of(t), nr = nruns_of(t);
    prtio_put_i32(w, t->nverts);
    prtio_put_i32(w, t->nvecs);
    prtio_put_i32(w, t->N);
    prtio_put_i32(w, t->qbits);
    prtio_put_u64(w, nc);
    prtio_put_u64(w, nr);
    prtio_put_arr(w, t->vec_first, (size_t)t->nverts + 1, 4);
    prtio_put_arr(w, t->coef_first, (size_t)t->nvecs + 1, 4);
    prtio_put_arr(w, t->run_first, (size_t)t->nvecs + 1, 4);
    prtio_put_arr(w, t->runs, 2 * nr, 1);
    prtio_put_arr(w, t->scale, 3 * (size_t)t->nvecs, 4);
    prtio_put_pad(w, t->qbits == 8 ? 0 : nc, SPARSE_FILE_ALIGN);
    if (t->qbits == 8) {
        prtio_put_arr(w, t->packed, nc, 4);
    } else {
        prtio_put_arr(w, t->offs, nc, 1);
        if (t->qbits == 16) prtio_put_arr(w, t->q16, 3 * nc, 2);
        else prtio_put_arr(w, t->f32, 3 * nc, 4);
    }
}

void linear_write(prt_writer *w, const prt_transfer *tr) {
    linear_config lc = linear_config_of(&tr->cfg);
    prtio_put_i32(w, lc.N);
    prtio_put_i32(w, lc.qbits);
    prtio_put_i32(w, lc.order);
    prtio_put_u64(w, tr->materials);
    bool direct = tr->direct.nvecs > 0;
    prtio_put_u8(w, (uint8_t)((direct ? 1 : 0) | (lc.measure == LINEAR_MEASURE_SOLID_ANGLE ? 2 : 0) | 4 | (tr->open_sky ? 8 : 0)));
    put_transport(w, &tr->transport);
    if (direct) put_transport(w, &tr->direct);
    linear_put_open(w, tr);
}

/* See linear.h: u8 open_vert[nverts] after the sets when the split is on. */
void linear_put_open(prt_writer *w, const prt_transfer *tr) {
    if (tr->open_sky) prtio_put_bytes(w, tr->open_vert, (size_t)tr->transport.nverts);
}

/* See linear.h. */
bool linear_get_open(prt_reader *r, prt_transfer *tr, char *why) {
    if (!tr->open_sky) return true;
    size_t n = (size_t)tr->transport.nverts;
    if (!(tr->open_vert = prtio_get_arr(r, n, 1))) return BAD(why, "transfer section too short (open sky)");
    for (size_t v = 0; v < n; v++)
        if (tr->open_vert[v] > OPENSKY_FOLDED) return BAD(why, "open sky: vertex %zu has flag %u", v, tr->open_vert[v]);
    return true;
}

/* ---- reading ---------------------------------------------------------------------------- */

/* Points t's runs and coefficients (runs at p, nr of them; offs at offs (16/32 bits); the values at
 * vals; nc coefficients) at a window of r's file when r has one and the values are aligned for
 * their type, else copies them. False only when a copy's allocation fails (r->oom). */
static bool place_arrays(prt_reader *r, prt_transport *t, const uint8_t *p, const uint8_t *offs, const uint8_t *vals, size_t nr, size_t nc) {
    size_t es = t->qbits == 16 ? 2 : 4, nval = t->qbits == 8 ? nc : 3 * nc;
    const uint8_t *m = NULL;
    if (nc > 0 && (uintptr_t)vals % es == 0) m = prtio_map_window(r, p, (size_t)(vals + nval * es - p), &t->data_map, &t->data_mapped);
    if (m) {   /* every array lies inside the window (nc > 0 ends it with values), as transport_free expects */
        t->runs = (uint8_t *)m;
        if (offs) t->offs = (uint8_t *)(m + (offs - p));
        void *v = (void *)(m + (vals - p));
        if (t->qbits == 8) t->packed = v;
        else if (t->qbits == 16) t->q16 = v;
        else t->f32 = v;
        return true;
    }
    t->runs = prtio_copy_arr(r, p, 2 * nr, 1);
    if (offs) t->offs = prtio_copy_arr(r, offs, nc, 1);
    if (t->qbits == 8) t->packed = prtio_copy_arr(r, vals, nc, 4);
    else if (t->qbits == 16) t->q16 = prtio_copy_arr(r, vals, 3 * nc, 2);
    else t->f32 = prtio_copy_arr(r, vals, 3 * nc, 4);
    return !r->bad;
}

static bool get_transport(prt_reader *r, prt_transport *t, bool padded, char *why) {
    int nverts = prtio_get_i32(r), nvecs = prtio_get_i32(r), N = prtio_get_i32(r), qbits = prtio_get_i32(r);
    uint64_t nc = prtio_get_u64(r), nr = prtio_get_u64(r);
    if (r->bad) return BAD(why, "transfer section too short");
    if (qbits != 8 && qbits != 16 && qbits != 32) return BAD(why, "bad quantization %d bits", qbits);
    if (N < 1 || N > CUBE_TEXELS) return BAD(why, "bad coefficient count N = %d", N);
    if (nverts < 0 || nverts > INT32_MAX - 1 || nvecs < 0 || nvecs > INT32_MAX / 3 - 1) return BAD(why, "bad transport size");
    if (nc > (uint64_t)nvecs * (uint64_t)N || nr > nc) return BAD(why, "bad coefficient or run totals");
    t->nverts = nverts;
    t->nvecs = nvecs;
    t->N = N;
    t->qbits = qbits;
    t->vec_first = prtio_get_arr(r, (size_t)nverts + 1, 4);
    t->coef_first = prtio_get_arr(r, (size_t)nvecs + 1, 4);
    t->run_first = prtio_get_arr(r, (size_t)nvecs + 1, 4);
    const uint8_t *runs = prtio_peek_arr(r, 2 * (size_t)nr, 1);
    t->scale = prtio_get_arr(r, 3 * (size_t)nvecs, 4);
    if (padded && !r->bad && !prtio_skip_pad(r, SPARSE_FILE_ALIGN)) return BAD(why, "bad padding before the coefficients");
    const uint8_t *offs = qbits == 8 ? NULL : prtio_peek_arr(r, (size_t)nc, 1);
    const uint8_t *vals = prtio_peek_arr(r, qbits == 8 ? (size_t)nc : 3 * (size_t)nc, qbits == 16 ? 2 : 4);
    if (r->bad) return BAD(why, "transfer section too short for %d vectors, %llu coefficients", nvecs, (unsigned long long)nc);
    if (!place_arrays(r, t, runs, offs, vals, (size_t)nr, (size_t)nc)) return BAD(why, "out of memory");
    /* The arrays were sized by nc and nr: the offsets must end exactly there. */
    if (t->coef_first[nvecs] != nc || t->run_first[nvecs] != nr) return BAD(why, "coefficient or run offsets do not match their totals");
    return true;
}

/* Reads the leading config fields into tr->cfg (the rest zero: what only a precompute uses). */
bool linear_read(prt_reader *r, prt_transfer *tr, char *why) {
    linear_config lc = { 0 };
    lc.N = prtio_get_i32(r);
    lc.qbits = prtio_get_i32(r);
    lc.order = prtio_get_i32(r);
    tr->materials = prtio_get_u64(r);
    uint8_t flags = prtio_get_u8(r), direct = flags & 1;
    if (r->bad) return BAD(why, "transfer section too short");
    if (flags > 15) return BAD(why, "bad transfer flags %u", flags);
    tr->open_sky = flags & 8;
    lc.measure = flags & 2 ? LINEAR_MEASURE_SOLID_ANGLE : 0;   /* 0: the texels */
    linear_store(&tr->cfg, &lc, sizeof lc);
    if (!get_transport(r, &tr->transport, flags & 4, why)) return false;
    if (direct && !get_transport(r, &tr->direct, flags & 4, why)) return false;
    if (!linear_get_open(r, tr, why)) return false;
    prt_transport *sets[2] = { &tr->transport, &tr->direct };
    for (int k = 0; k < 2; k++)   /* a shared budget (budget_ok): its kind is not recorded */
        if (sets[k]->N > lc.N && lc.N > 0) { sets[k]->budget = lc.N; sets[k]->budget_kind = TRANSPORT_BUDGET_SHARED; }
    if (r->pos != r->n) return BAD(why, "transfer section longer than its data");
    return true;
}

/* ---- validation ------------------------------------------------------------------------- */

/* The runs of vector i cover exactly its coefficients, blocks in range, and the full indices
 * block * 256 + offset strictly ascending (section 4.1.2's index split) and below max_index. */
static bool runs_ok(const prt_transport *t, int i, size_t nr, uint32_t max_index, char *why) {
    uint32_t c0 = t->coef_first[i], c1 = t->coef_first[i + 1], q0 = t->run_first[i], q1 = t->run_first[i + 1];
    if (q1 < q0 || q1 > nr) return BAD(why, "vector %d: bad run offsets", i);
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
            if (idx >= (long)max_index) return BAD(why, "vector %d: coefficient index %ld beyond the basis (%u)", i, idx, max_index);
            prev = idx;
        }
    }
    if (c != c1) return BAD(why, "vector %d: runs cover %u of its %u coefficients", i, c - c0, c1 - c0);
    return true;
}

/* Vertex offsets: vertex v has K vectors of its material when the mask holds it, else none. */
static bool vectors_ok(const struct prt_data *d, const prt_transfer *tr, const prt_transport *t, char *why) {
    const prt_mesh *m = &d->scene.mesh;
    int nv = m->nverts;
    if (t->vec_first[0] != 0) return BAD(why, "vector offsets do not start at 0");
    for (int v = 0; v < nv; v++) {
        uint32_t a = t->vec_first[v], b = t->vec_first[v + 1];
        if (b < a || b > (uint32_t)t->nvecs) return BAD(why, "vector offsets not increasing at vertex %d", v);
        int mat = m->mat[v];
        int K = (tr->materials >> mat) & 1 ? d->factors[mat].K : 0;
        if (b - a != (uint32_t)K) return BAD(why, "vertex %d has %u vectors but its material %u has K = %d", v, b - a, m->mat[v], K);
    }
    if (t->vec_first[nv] != (uint32_t)t->nvecs) return BAD(why, "vector offsets end at %u, not %d", t->vec_first[nv], t->nvecs);
    return true;
}

/* Checks one transport set against d's mesh and factors; false with why on the first problem. */
static bool set_ok(const struct prt_data *d, const prt_transfer *tr, const prt_transport *t, uint32_t max_index, char *why) {
    if (t->qbits != 8 && t->qbits != 16 && t->qbits != 32) return BAD(why, "bad quantization %d bits", t->qbits);
    if (t->N < 1 || t->N > CUBE_TEXELS) return BAD(why, "bad coefficient count N = %d", t->N);
    if (t->nverts != d->scene.mesh.nverts) return BAD(why, "transport has %d vertices, the mesh %d", t->nverts, d->scene.mesh.nverts);
    if (t->nvecs < 0) return BAD(why, "bad vector count %d", t->nvecs);
    if (t->stage_count || t->stage_idx || t->stage_val) return BAD(why, "transport not finished (transport_finish)");
    if (!t->vec_first || !t->coef_first || !t->run_first || !t->scale) return BAD(why, "transport offsets missing");
    if (!vectors_ok(d, tr, t, why)) return false;
    if (t->coef_first[0] != 0 || t->run_first[0] != 0) return BAD(why, "coefficient or run offsets do not start at 0");
    size_t nc = t->coef_first[t->nvecs], nr = t->run_first[t->nvecs];
    if (nc && (t->qbits == 8 ? !t->packed : (!t->offs || (t->qbits == 16 ? !t->q16 : !t->f32))))
        return BAD(why, "transport coefficients missing");
    if (nr && !t->runs) return BAD(why, "transport runs missing");
    for (int i = 0; i < t->nvecs; i++) {
        uint32_t c0 = t->coef_first[i], c1 = t->coef_first[i + 1];
        if (c1 < c0 || c1 - c0 > (uint32_t)t->N || c1 > nc) return BAD(why, "vector %d: bad coefficient offsets", i);
        if (!runs_ok(t, i, nr, max_index, why)) return false;
    }
    if (!prtio_all_finite(t->scale, 3 * (size_t)t->nvecs)) return BAD(why, "non-finite quantization scales");
    for (size_t i = 0; i < 3 * (size_t)t->nvecs; i++)
        if (t->scale[i] < 0) return BAD(why, "negative quantization scale");
    if (t->qbits == 32 && !prtio_all_finite(t->f32, 3 * nc)) return BAD(why, "non-finite coefficients");
    return true;
}

/* A set's N against the config's: equal (every vector its own N), or a shared budget (transport.h): the
 * set's N is the most one vector holds, the config's the mean, and the total at most config N x vectors. */
static bool budget_ok(const prt_transfer *tr, const prt_transport *t, char *why) {
    linear_config lc = linear_config_of(&tr->cfg);
    if (lc.qbits != t->qbits) return BAD(why, "%s config and transport disagree on qbits", tr->ops->name);
    if (t->N == lc.N) return true;
    if (t->N < lc.N) return BAD(why, "%s config and transport disagree on N", tr->ops->name);
    if ((uint64_t)t->coef_first[t->nvecs] > (uint64_t)lc.N * (uint64_t)t->nvecs)
        return BAD(why, "%u coefficients exceed the shared budget of %d x %d vectors", t->coef_first[t->nvecs], lc.N, t->nvecs);
    return true;
}

bool linear_validate(const struct prt_data *d, const prt_transfer *tr, uint32_t max_index, char *why) {
    if (!set_ok(d, tr, &tr->transport, max_index, why) || !budget_ok(tr, &tr->transport, why)) return false;
    /* The optional direct-only set (the direct/bounces toggle) has the same layout as the total. */
    if (tr->direct.nvecs || tr->direct.vec_first) {
        if (!set_ok(d, tr, &tr->direct, max_index, why) || !budget_ok(tr, &tr->direct, why)) return false;
        if (tr->direct.nvecs != tr->transport.nvecs)
            return BAD(why, "direct transport has %d vectors, the total %d", tr->direct.nvecs, tr->transport.nvecs);
    }
    return true;
}

void linear_release(prt_transfer *tr) {
    transport_free(&tr->transport);
    transport_free(&tr->direct);
    free(tr->open_vert);
    tr->open_vert = NULL;
}

size_t linear_bytes(const prt_transfer *tr) { return transport_bytes(&tr->transport) + transport_bytes(&tr->direct); }

/* ---- GLSL light kernels (compiled by gpu/glrt.c; buffer layout in its header comment) ---- */

/* Coefficient decoding, shared by every light kernel. WORD(c) and BLOCK(c) are defined per kernel.
 * Every kernel writes g = acc * scale * u_unshift clamped to the float range: a light near FLT_MAX
 * (a finite 1e37 sun) is uploaded scaled down by 2^-e so that the sums of codes x L stay
 * finite, and u_unshift = 2^e undoes it exactly, as transfer_light does on the CPU. */
static const char k_decode[] =
    "#if QBITS == 8\n"
    "vec3 coef(uint c, out uint idx) {\n"
    "    uint w = WORD(c);\n"
    "    idx = BLOCK(c) * 256u + (w & 255u);\n"
    "    return vec3(float(int(w << 16) >> 24), float(int(w << 8) >> 24), float(int(w) >> 24));\n"
    "}\n"
    "#elif QBITS == 16\n"
    "vec3 coef(uint c, out uint idx) {\n"
    "    uint w0 = WORD(2u * c), w1 = WORD(2u * c + 1u);\n"
    "    idx = w0 & 65535u;\n"
    "    return vec3(float(int(w0) >> 16), float(int(w1 << 16) >> 16), float(int(w1) >> 16));\n"
    "}\n"
    "#else\n"
    "vec3 coef(uint c, out uint idx) {\n"
    "    idx = WORD(4u * c);\n"
    "    return vec3(uintBitsToFloat(WORD(4u * c + 1u)), uintBitsToFloat(WORD(4u * c + 2u)),\n"
    "                uintBitsToFloat(WORD(4u * c + 3u)));\n"
    "}\n"
    "#endif\n"
    "uniform float u_unshift;\n"
    "vec3 unshift(vec3 v) { float m = uintBitsToFloat(0x7f7fffffu); return clamp(v * u_unshift, vec3(-m), vec3(m)); }\n";

/* Fragment kernel: one fragment per vector (GL 3.3, buffer textures). */
static const char k_light_frag[] =
    "uniform usamplerBuffer t_first, t_words, t_blocks;\n"
    "uniform samplerBuffer t_scale, t_L, t_open;\n"
    "uniform int u_width, u_nvecs;\n"
    "out vec4 o_g;\n"
    "#define WORD(c) texelFetch(t_words, int(c)).r\n"
    "#define BLOCK(c) texelFetch(t_blocks, int(c)).r\n"
    "DECODE\n"
    "void main() {\n"
    "    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);\n"
    "    if (i >= u_nvecs) { o_g = vec4(0.0); return; }\n"
    "    uint c0 = texelFetch(t_first, i).r, c1 = texelFetch(t_first, i + 1).r;\n"
    "    vec3 acc = vec3(0.0);\n"
    "    for (uint c = c0; c < c1; c++) { uint idx; vec3 q = coef(c, idx); acc += q * texelFetch(t_L, int(idx)).rgb; }\n"
    "    vec3 s = vec3(texelFetch(t_scale, 3 * i).r, texelFetch(t_scale, 3 * i + 1).r, texelFetch(t_scale, 3 * i + 2).r);\n"
    "    o_g = vec4(unshift(acc * s) + texelFetch(t_open, i).rgb, 0.0);\n"
    "}\n";

static const char k_light_buffers[] =
    "layout(std430, binding = 0) readonly buffer B0 { uint first[]; };\n"
    "layout(std430, binding = 1) readonly buffer B1 { uint words[]; };\n"
    "layout(std430, binding = 2) readonly buffer B2 { uint blocks[]; };\n"
    "layout(std430, binding = 3) readonly buffer B3 { float scale[]; };\n"
    "layout(std430, binding = 4) readonly buffer B4 { vec4 L[]; };\n"
    "layout(std430, binding = 5) writeonly buffer B5 { vec4 g[]; };\n"
    "layout(std430, binding = 6) readonly buffer B6 { vec4 open_g[]; };\n"
    "uniform uint u_nvecs;\n"
    "#define WORD(c) words[c]\n"
    "#define BLOCK(c) ((blocks[(c) >> 2] >> (((c) & 3u) * 8u)) & 255u)\n";

/* Compute kernel, one invocation per vector. */
static const char k_light_thread[] =
    "layout(local_size_x = 64) in;\n"
    "BUFFERS\n"
    "DECODE\n"
    "void main() {\n"
    "    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationID.x;\n"
    "    if (i >= u_nvecs) return;\n"
    "    uint c0 = first[i], c1 = first[i + 1u];\n"
    "    vec3 acc = vec3(0.0);\n"
    "    for (uint c = c0; c < c1; c++) { uint idx; vec3 q = coef(c, idx); acc += q * L[idx].rgb; }\n"
    "    g[i] = vec4(unshift(acc * vec3(scale[3u * i], scale[3u * i + 1u], scale[3u * i + 2u])) + open_g[i].rgb, 0.0);\n"
    "}\n";

/* Compute kernel, 32 invocations per vector (8 vectors per group of 256) and a tree sum in shared memory. */
static const char k_light_warp[] =
    "layout(local_size_x = 256) in;\n"
    "BUFFERS\n"
    "DECODE\n"
    "shared vec3 part[256];\n"
    "void main() {\n"
    "    uint lid = gl_LocalInvocationID.x, lane = lid & 31u;\n"
    "    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 8u + (lid >> 5);\n"
    "    vec3 acc = vec3(0.0);\n"
    "    if (i < u_nvecs) {\n"
    "        uint c1 = first[i + 1u];\n"
    "        for (uint c = first[i] + lane; c < c1; c += 32u) { uint idx; vec3 q = coef(c, idx); acc += q * L[idx].rgb; }\n"
    "    }\n"
    "    part[lid] = acc;\n"
    "    memoryBarrierShared(); barrier();\n"
    "    for (uint s = 16u; s > 0u; s >>= 1) {\n"
    "        if (lane < s) part[lid] += part[lid + s];\n"
    "        memoryBarrierShared(); barrier();\n"
    "    }\n"
    "    if (lane == 0u && i < u_nvecs)\n"
    "        g[i] = vec4(unshift(part[lid] * vec3(scale[3u * i], scale[3u * i + 1u], scale[3u * i + 2u])) + open_g[i].rgb, 0.0);\n"
    "}\n";

const transfer_glsl linear_glsl = {
    .decode = k_decode, .fragment = k_light_frag, .buffers = k_light_buffers,
    .thread = k_light_thread, .warp = k_light_warp,
};
