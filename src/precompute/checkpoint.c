/* checkpoint.c - the checkpoint file of a resumable precompute (checkpoint.h says what and why).
 *
 * Writing: ckpt_add serializes one vertex's staged vectors into a record under the checkpoint's
 * lock and appends it through stdio; every CKPT_INTERVAL_PERCENT of the vertices the stream is
 * flushed, so a SIGKILL loses at most that much work plus the records in flight (a record cut in
 * half is dropped on reading, by its length and CRC).
 *
 * Reading (resume): the whole file is scanned once at open into an index (pass, vertex, offset,
 * length per record, the CRC checked); the first record that is cut or fails its CRC ends the
 * valid part and the file is truncated there, so new records follow valid ones. ckpt_restore
 * then reads each record of a pass again and stages it into the pass's transport set, checking
 * that it fits the set (vector count, at most N sorted indices in range, finite values): the key
 * already matched, so a record that does not fit is a corrupt file, refused with one line. */
#include "checkpoint.h"
#include "cubemap.h"
#include "scene.h"
#include "sparse.h"
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#define CKPT_MAGIC "PRTCKPT2"
#define CKPT_HEADER 24
#define CKPT_RECORD 0x58545256u     /* "VRTX" little-endian */
/* Payload: u32 pass, u32 vertex, u32 vectors, i64 traced, i64 hits, f64 err, i32 errs, f64 energy, i32 open (52 bytes),
 * then per vector: u32 count, f32 scale[3], u16 index[count], then its values as the set stores
 * them (transport.h): quantized, i8 or i16 [3 * count] (value = q * scale, what transport_finish
 * quantizes again to the same q), or f32 [3 * count] with 32 bits: about the output's size. */
#define CKPT_FIXED 52
/* With a shared budget (transport.h) a vector is staged as candidates: u32 count, u16 index[count],
 * f32 value[3 * count], f32 weight[count], f32 block[TRANSPORT_STAGE]. */

typedef struct ckpt_entry { uint32_t pass, v, len; uint64_t off; } ckpt_entry;

struct prt_checkpoint {
    char path[4096];
    FILE *f;
    pthread_mutex_t lock;
    int nverts, interval, since, flushes, kill_after;
    int failed;                 /* errno of the first failed write, 0 if none */
    ckpt_entry *idx;            /* records read at open (resume) */
    size_t nidx, cap;
    int count[CKPT_MAX_PASSES];
    uint8_t *buf;               /* one record being written */
    size_t bufcap;
};

ckpt_key ckpt_key_init(void) { return (ckpt_key){ crc32(0L, Z_NULL, 0), adler32(0L, Z_NULL, 0) }; }

void ckpt_key_add(ckpt_key *k, const void *p, size_t n) {
    const Bytef *b = p;
    while (n > 0) {   /* zlib takes 32-bit lengths */
        uInt m = n > (1u << 30) ? (1u << 30) : (uInt)n;
        k->crc = crc32(k->crc, b, m);
        k->adler = adler32(k->adler, b, m);
        b += m;
        n -= m;
    }
}

void ckpt_key_str(ckpt_key *k, const char *s) {
    uint32_t n = s ? (uint32_t)strlen(s) : 0;
    ckpt_key_add(k, &n, sizeof n);
    if (n) ckpt_key_add(k, s, n);
}

void ckpt_key_textures(ckpt_key *k, const prt_scene *sc) {
    if (sc->ntextures <= 0) return;
    ckpt_key_add(k, &sc->ntextures, sizeof sc->ntextures);
    for (int t = 0; t < sc->ntextures; t++) {
        const scene_texture *tx = &sc->textures[t];
        int wh[2] = { tx->w, tx->h };
        ckpt_key_add(k, wh, sizeof wh);
        ckpt_key_add(k, tx->srgb, 3 * (size_t)tx->w * tx->h);
    }
    ckpt_key_add(k, sc->material_texture, (size_t)sc->nmaterials);
    if (sc->mesh.uv) ckpt_key_add(k, sc->mesh.uv, 2 * sizeof(float) * (size_t)sc->mesh.nverts);
}

uint64_t ckpt_key_value(const ckpt_key *k) { return ((uint64_t)(k->crc & 0xffffffffu) << 32) | (k->adler & 0xffffffffu); }

static void put32(uint8_t *p, uint32_t x) { for (int i = 0; i < 4; i++) p[i] = (uint8_t)(x >> (8 * i)); }
static void put64(uint8_t *p, uint64_t x) { for (int i = 0; i < 8; i++) p[i] = (uint8_t)(x >> (8 * i)); }
static uint32_t get32(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static uint64_t get64(const uint8_t *p) { return (uint64_t)get32(p) | (uint64_t)get32(p + 4) << 32; }

/* Appends an index entry. Returns 0 or -1 (OOM). */
static int idx_push(prt_checkpoint *c, ckpt_entry e) {
    if (c->nidx == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 1024;
        ckpt_entry *n = realloc(c->idx, cap * sizeof *n);
        if (!n) return -1;
        c->idx = n;
        c->cap = cap;
    }
    c->idx[c->nidx++] = e;
    if (e.pass < CKPT_MAX_PASSES) c->count[e.pass]++;
    return 0;
}

/* Scans the records after the header into the index; returns the end of the valid part, or -1
 * (OOM). A cut or corrupt record ends the scan. */
static long scan(prt_checkpoint *c) {
    long off = CKPT_HEADER;
    uint8_t head[8];
    uint8_t *pay = NULL;
    size_t paycap = 0;
    for (;;) {
        if (fseek(c->f, off, SEEK_SET) || fread(head, 1, 8, c->f) != 8 || get32(head) != CKPT_RECORD) break;
        uint32_t len = get32(head + 4);
        if (len < 8 || len > (1u << 30)) break;
        if (len + 4 > paycap) {
            uint8_t *n = realloc(pay, len + 4);
            if (!n) { free(pay); return -1; }
            pay = n;
            paycap = len + 4;
        }
        if (fread(pay, 1, len + 4, c->f) != len + 4) break;
        if ((uint32_t)crc32(crc32(0L, Z_NULL, 0), pay, len) != get32(pay + len)) break;
        ckpt_entry e = { get32(pay), get32(pay + 4), len, (uint64_t)off + 8 };
        if (e.pass >= CKPT_MAX_PASSES) break;   /* the item's range is checked when it is restored */
        if (idx_push(c, e)) { free(pay); return -1; }
        off += 8 + (long)len + 4;
    }
    free(pay);
    return off;
}

/* Reads an existing checkpoint for resume. Returns 0, 1 (no file: start a new one) or -1 with err. */
static int open_existing(prt_checkpoint *c, uint64_t key, prt_error *err) {
    c->f = fopen(c->path, "r+b");
    if (!c->f) return errno == ENOENT ? 1 : prt_fail(err, "%s: cannot open the checkpoint: %s", c->path, strerror(errno));
    uint8_t h[CKPT_HEADER];
    if (fread(h, 1, CKPT_HEADER, c->f) != CKPT_HEADER || memcmp(h, CKPT_MAGIC, 8) != 0)
        return prt_fail(err, "%s: not a prt checkpoint (remove it, or run without --resume)", c->path);
    if (get64(h + 8) != key || get32(h + 16) != (uint32_t)c->nverts)
        return prt_fail(err, "%s: checkpoint of other inputs or options (key %016llx, this run %016llx); remove it or "
                        "run without --resume", c->path, (unsigned long long)get64(h + 8), (unsigned long long)key);
    long end = scan(c);
    if (end < 0) return prt_fail(err, "%s: out of memory reading the checkpoint", c->path);
    fflush(c->f);
    if (ftruncate(fileno(c->f), end) != 0 || fseek(c->f, end, SEEK_SET) != 0)
        return prt_fail(err, "%s: cannot truncate the checkpoint: %s", c->path, strerror(errno));
    return 0;
}

prt_checkpoint *ckpt_open(const char *path, uint64_t key, bool resume, int nverts, int kill_after, prt_error *err) {
    prt_checkpoint *c = prt_calloc(1, sizeof *c, err);
    if (!c) return NULL;
    snprintf(c->path, sizeof c->path, "%s", path);
    c->nverts = nverts;
    c->kill_after = kill_after;
    c->interval = nverts * CKPT_INTERVAL_PERCENT / 100 > 1 ? nverts * CKPT_INTERVAL_PERCENT / 100 : 1;
    pthread_mutex_init(&c->lock, NULL);
    int rc = resume ? open_existing(c, key, err) : 1;
    if (rc == 1) {   /* a new checkpoint: the header */
        if (c->f) fclose(c->f);
        c->f = fopen(path, "wb");
        uint8_t h[CKPT_HEADER] = { 0 };
        memcpy(h, CKPT_MAGIC, 8);
        put64(h + 8, key);
        put32(h + 16, (uint32_t)nverts);
        if (!c->f || fwrite(h, 1, CKPT_HEADER, c->f) != CKPT_HEADER || fflush(c->f) != 0)
            rc = prt_fail(err, "%s: cannot write the checkpoint: %s", path, strerror(errno));
        else
            rc = 0;
    }
    if (rc) {
        ckpt_close(c, NULL);
        return NULL;
    }
    return c;
}

int ckpt_transfer_pass(int slot) {
    PRT_CHECK(slot >= 1 && slot < PRT_MAX_TRANSFERS);
    return CKPT_TRANSFER_FIRST + (slot - 1) * TRANSFER_CKPT_PASSES;
}

int ckpt_count(const prt_checkpoint *c, int pass) { return c && pass >= 0 && pass < CKPT_MAX_PASSES ? c->count[pass] : 0; }

/* Bytes of one stored value channel: the quantized q of 8 / 16 bits, or the float. */
static size_t value_bytes(int qbits) { return qbits == 8 ? 1 : qbits == 16 ? 2 : 4; }

/* All finite? */
static bool floats_ok(const float *x, size_t n) {
    for (size_t j = 0; j < n; j++)
        if (!isfinite(x[j])) return false;
    return true;
}

/* stage_record for a shared budget's candidates (CKPT_FIXED's comment). Returns v, or -1. */
static int stage_candidates(const uint8_t *p, uint32_t len, prt_transport *t, uint32_t v, uint32_t nvec) {
    size_t q = CKPT_FIXED;
    for (uint32_t k = 0; k < nvec; k++) {
        size_t i = t->vec_first[v] + k;
        if (q + 4 > len) return -1;
        uint32_t n = get32(p + q);
        if (n > (uint32_t)t->N || q + 4 + 18 * (uint64_t)n + 4 * TRANSPORT_STAGE > len) return -1;
        q += 4;
        uint32_t *idx = t->stage_idx + i * t->N;
        for (uint32_t j = 0; j < n; j++, q += 2) {
            idx[j] = (uint32_t)p[q] | (uint32_t)p[q + 1] << 8;
            if (idx[j] >= CUBE_TEXELS || (j > 0 && idx[j] <= idx[j - 1])) return -1;
        }
        float *val = t->stage_val + i * t->N * 3, *key = t->stage_key + i * t->N, *blk = t->stage_blk + i * TRANSPORT_STAGE;
        memcpy(val, p + q, 12 * (size_t)n);
        memcpy(key, p + q + 12 * (size_t)n, 4 * (size_t)n);
        memcpy(blk, p + q + 16 * (size_t)n, 4 * TRANSPORT_STAGE);
        q += 16 * (size_t)n + 4 * TRANSPORT_STAGE;
        if (!floats_ok(val, 3 * (size_t)n) || !floats_ok(key, n) || !floats_ok(blk, TRANSPORT_STAGE)) return -1;
        t->stage_count[i] = n;
    }
    return q == len ? (int)v : -1;
}

/* Stages one record's payload p (len bytes) into t; vs gets the statistics. Returns the vertex,
 * or -1 when the record does not fit t. */
static int stage_record(const uint8_t *p, uint32_t len, prt_transport *t, ckpt_vstats *vs) {
    uint32_t v = get32(p + 4), nvec = get32(p + 8), q = CKPT_FIXED;
    if (v >= (uint32_t)t->nverts || nvec != t->vec_first[v + 1] - t->vec_first[v]) return -1;
    if (vs) {
        uint64_t e = get64(p + 28);
        vs->traced = (int64_t)get64(p + 12);
        vs->hits = (int64_t)get64(p + 20);
        memcpy(&vs->err, &e, 8);
        vs->errs = (int32_t)get32(p + 36);
        uint64_t en = get64(p + 40);
        memcpy(&vs->energy, &en, 8);
        vs->open = (int32_t)get32(p + 48);
    }
    if (t->stage_key) return stage_candidates(p, len, t, v, nvec);
    const size_t vb = value_bytes(t->qbits);
    for (uint32_t k = 0; k < nvec; k++) {
        uint32_t i = t->vec_first[v] + k;
        if (q + 16 > len) return -1;
        uint32_t n = get32(p + q);
        if (n > (uint32_t)t->N || q + 16 + (2 + 3 * vb) * (uint64_t)n > len) return -1;
        float sc[3];
        memcpy(sc, p + q + 4, 12);
        for (int ch = 0; ch < 3; ch++) {
            if (!isfinite(sc[ch])) return -1;
            t->scale[3 * (size_t)i + ch] = sc[ch];
        }
        q += 16;
        uint32_t *idx = t->stage_idx + (size_t)i * t->N;
        float *val = t->stage_val + (size_t)i * t->N * 3;
        for (uint32_t j = 0; j < n; j++) {
            idx[j] = (uint32_t)p[q + 2 * j] | (uint32_t)p[q + 2 * j + 1] << 8;
            if (idx[j] >= CUBE_TEXELS || (j > 0 && idx[j] <= idx[j - 1])) return -1;
        }
        q += 2 * n;
        for (uint32_t j = 0; j < 3 * n; j++, q += (uint32_t)vb) {
            if (vb == 1) val[j] = (float)(int8_t)p[q] * sc[j % 3];
            else if (vb == 2) val[j] = (float)(int16_t)(uint16_t)(p[q] | p[q + 1] << 8) * sc[j % 3];
            else memcpy(&val[j], p + q, 4);
            if (!isfinite(val[j])) return -1;
        }
        t->stage_count[i] = n;
    }
    return q == len ? (int)v : -1;
}

/* Calls fn for every record of pass (its payload after pass and item). Returns how many, or -1
 * with err when one cannot be read or fn refuses it (-1). */
static int each_record(prt_checkpoint *c, int pass, int (*fn)(void *user, const uint8_t *p, uint32_t len), void *user,
                       prt_error *err) {
    uint8_t *p = NULL;
    size_t cap = 0;
    int n = 0;
    long here = ftell(c->f);
    for (size_t e = 0; e < c->nidx; e++) {
        const ckpt_entry *en = &c->idx[e];
        if (en->pass != (uint32_t)pass) continue;
        if (en->len > cap) {
            uint8_t *q = realloc(p, en->len);
            if (!q) { free(p); return prt_fail(err, "%s: out of memory reading the checkpoint", c->path); }
            p = q;
            cap = en->len;
        }
        int ok = fseek(c->f, (long)en->off, SEEK_SET) == 0 && fread(p, 1, en->len, c->f) == en->len &&
                 fn(user, p, en->len) == 0;
        if (!ok) {
            free(p);
            return prt_fail(err, "%s: corrupt checkpoint (pass %d, item %u); remove it", c->path, pass, en->v);
        }
        n++;
    }
    free(p);
    fseek(c->f, here, SEEK_SET);
    return n;
}

typedef struct stage_ctx { prt_transport *t; uint8_t *done; ckpt_vstats *vs; } stage_ctx;

static int stage_one(void *user, const uint8_t *p, uint32_t len) {
    stage_ctx *s = user;
    if (len < CKPT_FIXED) return -1;
    uint32_t v = get32(p + 4);
    if (v >= (uint32_t)s->t->nverts || stage_record(p, len, s->t, s->vs ? &s->vs[v] : NULL) < 0) return -1;
    s->done[v] = 1;
    return 0;
}

int ckpt_restore(prt_checkpoint *c, int pass, prt_transport *t, uint8_t *done, ckpt_vstats *vs, prt_error *err) {
    if (!c || ckpt_count(c, pass) == 0) return 0;
    PRT_CHECK(t->stage_count && t->nverts == c->nverts);
    stage_ctx s = { t, done, vs };
    return each_record(c, pass, stage_one, &s, err);
}

typedef struct blob_ctx { int (*fn)(void *, uint32_t, const uint8_t *, uint32_t); void *user; } blob_ctx;

static int blob_one(void *user, const uint8_t *p, uint32_t len) {
    blob_ctx *b = user;
    return b->fn(b->user, get32(p + 4), p + 8, len - 8);
}

int ckpt_restore_blobs(prt_checkpoint *c, int pass, int (*fn)(void *user, uint32_t item, const uint8_t *data, uint32_t len),
                       void *user, prt_error *err) {
    if (!c || ckpt_count(c, pass) == 0) return 0;
    blob_ctx b = { fn, user };
    return each_record(c, pass, blob_one, &b, err);
}

/* Writes vector i's staged candidates (a shared budget's, CKPT_FIXED's comment) at p + q; returns the end. */
static size_t put_candidates(uint8_t *p, size_t q, const prt_transport *t, size_t i) {
    uint32_t n = t->stage_count[i];
    put32(p + q, n);
    q += 4;
    for (uint32_t j = 0; j < n; j++, q += 2) {
        uint32_t x = t->stage_idx[i * t->N + j];
        p[q] = (uint8_t)x, p[q + 1] = (uint8_t)(x >> 8);
    }
    memcpy(p + q, t->stage_val + i * t->N * 3, 12 * (size_t)n);
    memcpy(p + q + 12 * (size_t)n, t->stage_key + i * t->N, 4 * (size_t)n);
    memcpy(p + q + 16 * (size_t)n, t->stage_blk + i * TRANSPORT_STAGE, 4 * TRANSPORT_STAGE);
    return q + 16 * (size_t)n + 4 * TRANSPORT_STAGE;
}

/* Serializes vertex v of pass into c->buf. Returns the record's bytes, 0 on OOM. */
static size_t put_record(prt_checkpoint *c, int pass, const prt_transport *t, int v, const ckpt_vstats *vs) {
    uint32_t nvec = t->vec_first[v + 1] - t->vec_first[v];
    const size_t vb = value_bytes(t->qbits);
    const int qmax = t->qbits == 8 ? 127 : t->qbits == 16 ? 32767 : 0;
    size_t len = CKPT_FIXED;
    for (uint32_t k = 0; k < nvec; k++)
        len += t->stage_key ? 4 + 18 * (size_t)t->stage_count[t->vec_first[v] + k] + 4 * TRANSPORT_STAGE
                            : 16 + (2 + 3 * vb) * (size_t)t->stage_count[t->vec_first[v] + k];
    if (len + 12 > c->bufcap) {
        uint8_t *b = realloc(c->buf, len + 12);
        if (!b) return 0;
        c->buf = b;
        c->bufcap = len + 12;
    }
    uint8_t *p = c->buf + 8;
    ckpt_vstats z = { 0 };
    if (!vs) vs = &z;
    uint64_t e;
    memcpy(&e, &vs->err, 8);
    put32(p, (uint32_t)pass); put32(p + 4, (uint32_t)v); put32(p + 8, nvec);
    put64(p + 12, (uint64_t)vs->traced); put64(p + 20, (uint64_t)vs->hits); put64(p + 28, e); put32(p + 36, (uint32_t)vs->errs);
    uint64_t en;
    memcpy(&en, &vs->energy, 8);
    put64(p + 40, en);
    put32(p + 48, (uint32_t)vs->open);
    size_t q = CKPT_FIXED;
    for (uint32_t k = 0; k < nvec && t->stage_key; k++) q = put_candidates(p, q, t, t->vec_first[v] + k);
    for (uint32_t k = 0; k < nvec && !t->stage_key; k++) {
        uint32_t i = t->vec_first[v] + k, n = t->stage_count[i];
        const float *sc = &t->scale[3 * (size_t)i], *val = t->stage_val + (size_t)i * t->N * 3;
        put32(p + q, n);
        memcpy(p + q + 4, sc, 12);
        q += 16;
        for (uint32_t j = 0; j < n; j++, q += 2) {
            uint32_t x = t->stage_idx[(size_t)i * t->N + j];
            p[q] = (uint8_t)x, p[q + 1] = (uint8_t)(x >> 8);
        }
        for (uint32_t j = 0; j < 3 * n; j++, q += vb) {
            int qv = qmax ? sparse_quantize(val[j], sc[j % 3], qmax) : 0;   /* as transport_finish does */
            if (vb == 1) p[q] = (uint8_t)(int8_t)qv;
            else if (vb == 2) p[q] = (uint8_t)qv, p[q + 1] = (uint8_t)((uint16_t)(int16_t)qv >> 8);
            else memcpy(p + q, &val[j], 4);
        }
    }
    put32(c->buf, CKPT_RECORD);
    put32(c->buf + 4, (uint32_t)len);
    put32(p + len, (uint32_t)crc32(crc32(0L, Z_NULL, 0), p, (uInt)len));
    return len + 12;
}

/* Appends the record in c->buf (n bytes; 0: it could not be made), flushing every interval.
 * Called with the lock held. */
static void append(prt_checkpoint *c, size_t n) {
    if (n == 0) c->failed = ENOMEM;
    else if (fwrite(c->buf, 1, n, c->f) != n) c->failed = errno ? errno : EIO;
    else if (++c->since >= c->interval) {
        c->since = 0;
        if (fflush(c->f) != 0) c->failed = errno ? errno : EIO;
        else if (c->kill_after > 0 && ++c->flushes == c->kill_after) raise(SIGKILL);
    }
}

void ckpt_add(prt_checkpoint *c, int pass, const prt_transport *t, int v, const ckpt_vstats *vs) {
    if (!c) return;
    pthread_mutex_lock(&c->lock);
    if (!c->failed) append(c, put_record(c, pass, t, v, vs));
    pthread_mutex_unlock(&c->lock);
}

/* Frames len bytes of data as a record of (pass, item) in c->buf. Returns its bytes, 0 on OOM. */
static size_t put_blob(prt_checkpoint *c, int pass, uint32_t item, const void *data, uint32_t len) {
    if ((size_t)len + 20 > c->bufcap) {
        uint8_t *b = realloc(c->buf, (size_t)len + 20);
        if (!b) return 0;
        c->buf = b;
        c->bufcap = (size_t)len + 20;
    }
    uint8_t *p = c->buf + 8;
    put32(c->buf, CKPT_RECORD);
    put32(c->buf + 4, len + 8);
    put32(p, (uint32_t)pass);
    put32(p + 4, item);
    if (len) memcpy(p + 8, data, len);
    put32(p + 8 + len, (uint32_t)crc32(crc32(0L, Z_NULL, 0), p, (uInt)len + 8));
    return (size_t)len + 20;
}

void ckpt_add_blob(prt_checkpoint *c, int pass, uint32_t item, const void *data, uint32_t len) {
    if (!c) return;
    pthread_mutex_lock(&c->lock);
    if (!c->failed) append(c, put_blob(c, pass, item, data, len));
    pthread_mutex_unlock(&c->lock);
}

int ckpt_close(prt_checkpoint *c, prt_error *err) {
    if (!c) return 0;
    int failed = c->failed;
    if (c->f && fclose(c->f) != 0 && !failed) failed = errno ? errno : EIO;
    pthread_mutex_destroy(&c->lock);
    int rc = failed ? prt_fail(err, "%s: writing the checkpoint failed: %s", c->path, strerror(failed)) : 0;
    free(c->idx);
    free(c->buf);
    free(c);
    return rc;
}

