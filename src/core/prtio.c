/* prtio.c - the .prt byte-level serializer (prtio.h). Arrays go out in one
 * fwrite on a little-endian host and element by element otherwise; on the way in
 * they are copied, or on a little-endian host left in the file's pages
 * (prtio_map_window). */
#include "prtio.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>
#include <zlib.h>

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HOST_LE 1
#else
#define HOST_LE 0
#endif

unsigned long prtio_crc_init(void) { return crc32(0L, Z_NULL, 0); }

/* crc32 takes 32-bit lengths: fold in chunks of 1 GB. */
unsigned long prtio_crc(unsigned long crc, const void *p, size_t len) {
    const Bytef *b = p;
    for (size_t off = 0; off < len;) {
        size_t chunk = len - off > (1u << 30) ? (1u << 30) : len - off;
        crc = crc32(crc, b + off, (uInt)chunk);
        off += chunk;
    }
    return crc;
}

/* prtio_crc_threads: chunks of 16 MB, each folded from zero on its own and joined in order. */
#define CRC_CHUNK ((size_t)16 << 20)
typedef struct crc_job { const uint8_t *p; size_t len; bool drop; unsigned long *part; } crc_job;

static void crc_chunk(void *ctx, int begin, int end, int thread) {
    (void)thread;
    crc_job *j = ctx;
    for (int c = begin; c < end; c++) {
        size_t off = (size_t)c * CRC_CHUNK, n = j->len - off < CRC_CHUNK ? j->len - off : CRC_CHUNK;
        j->part[c] = prtio_crc(prtio_crc_init(), j->p + off, n);
        if (j->drop) {   /* whole pages only: a page shared with the next chunk stays for it */
            uintptr_t a = ((uintptr_t)(j->p + off) + 4095) & ~(uintptr_t)4095, b = (uintptr_t)(j->p + off + n) & ~(uintptr_t)4095;
            if (b > a) madvise((void *)a, b - a, MADV_DONTNEED);
        }
    }
}

/* See prtio.h. A CRC is a polynomial remainder, so the chunks' CRCs join exactly (zlib's
 * crc32_combine). A file of one chunk (or a failed allocation) is folded in one go, its pages kept. */
unsigned long prtio_crc_threads(const void *p, size_t len, int nthreads, bool drop) {
    size_t nchunks = (len + CRC_CHUNK - 1) / CRC_CHUNK;
    unsigned long *part = nchunks > 1 && nchunks < INT32_MAX ? malloc(nchunks * sizeof *part) : NULL;
    if (!part) return prtio_crc(prtio_crc_init(), p, len);
    crc_job j = { p, len, drop, part };
    prt_parallel_for((int)nchunks, 1, nthreads, crc_chunk, &j);
    unsigned long crc = part[0];
    for (size_t c = 1; c < nchunks; c++) {
        size_t n = len - c * CRC_CHUNK < CRC_CHUNK ? len - c * CRC_CHUNK : CRC_CHUNK;
        crc = crc32_combine(crc, part[c], (z_off_t)n);
    }
    free(part);
    return crc;
}

/* Writes (or only counts) len bytes and folds them into the CRC. */
void prtio_put_bytes(prt_writer *w, const void *p, size_t len) {
    if (w->f && len) {
        if (fwrite(p, 1, len, w->f) != len) w->bad = true;
        w->crc = prtio_crc(w->crc, p, len);
    }
    w->n += len;
}
void prtio_put_u8(prt_writer *w, uint8_t v) { prtio_put_bytes(w, &v, 1); }
static void put_u16(prt_writer *w, uint16_t v) {
    uint8_t b[2] = { (uint8_t)v, (uint8_t)(v >> 8) };
    prtio_put_bytes(w, b, 2);
}
void prtio_put_u32(prt_writer *w, uint32_t v) {
    uint8_t b[4] = { (uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24) };
    prtio_put_bytes(w, b, 4);
}
void prtio_put_u64(prt_writer *w, uint64_t v) {
    prtio_put_u32(w, (uint32_t)v);
    prtio_put_u32(w, (uint32_t)(v >> 32));
}
void prtio_put_i32(prt_writer *w, int32_t v) { prtio_put_u32(w, (uint32_t)v); }
void prtio_put_f32(prt_writer *w, float v) {
    uint32_t u;
    memcpy(&u, &v, 4);
    prtio_put_u32(w, u);
}
void prtio_put_f64(prt_writer *w, double v) {
    uint64_t u;
    memcpy(&u, &v, 8);
    prtio_put_u64(w, u);
}
void prtio_put_arr(prt_writer *w, const void *p, size_t count, size_t es) {
    if (HOST_LE || es == 1 || !w->f) {
        prtio_put_bytes(w, p, count * es);
        return;
    }
    const uint8_t *b = p;
    for (size_t i = 0; i < count; i++) {
        if (es == 2) { uint16_t v; memcpy(&v, b + 2 * i, 2); put_u16(w, v); }
        else { uint32_t v; memcpy(&v, b + 4 * i, 4); prtio_put_u32(w, v); }
    }
}
void prtio_put_str(prt_writer *w, const char *s, size_t cap) {
    size_t n = strnlen(s, cap);
    prtio_put_u32(w, (uint32_t)n);
    prtio_put_bytes(w, s, n);
}

void prtio_put_pad(prt_writer *w, size_t after, size_t align) {
    static const uint8_t zero[256];
    size_t k = (align - (size_t)((w->n + 1 + after) % align)) % align;
    prtio_put_u8(w, (uint8_t)k);
    prtio_put_bytes(w, zero, k);
}

bool prtio_need(prt_reader *r, size_t count, size_t es) {
    if (r->bad) return false;
    if (es && count > (r->n - r->pos) / es) {
        r->bad = true;
        return false;
    }
    return true;
}
uint32_t prtio_get_u32(prt_reader *r) {
    if (!prtio_need(r, 1, 4)) return 0;
    const uint8_t *b = r->p + r->pos;
    r->pos += 4;
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}
uint64_t prtio_get_u64(prt_reader *r) {
    uint64_t lo = prtio_get_u32(r);
    return lo | (uint64_t)prtio_get_u32(r) << 32;
}
uint8_t prtio_get_u8(prt_reader *r) {
    if (!prtio_need(r, 1, 1)) return 0;
    return r->p[r->pos++];
}
int32_t prtio_get_i32(prt_reader *r) { return (int32_t)prtio_get_u32(r); }
float prtio_get_f32(prt_reader *r) {
    uint32_t u = prtio_get_u32(r);
    float v;
    memcpy(&v, &u, 4);
    return v;
}
double prtio_get_f64(prt_reader *r) {
    uint64_t u = prtio_get_u64(r);
    double v;
    memcpy(&v, &u, 8);
    return v;
}
void *prtio_copy_arr(prt_reader *r, const void *p, size_t count, size_t es) {
    void *dst = malloc(count * es > 0 ? count * es : 1);
    if (!dst) {
        r->oom = true;
        r->bad = true;
        return NULL;
    }
    const uint8_t *b = p;
    if (HOST_LE || es == 1) {
        if (count) memcpy(dst, b, count * es);
    } else {
        for (size_t i = 0; i < count; i++) {
            const uint8_t *e = b + i * es;
            if (es == 2) { uint16_t v = (uint16_t)(e[0] | e[1] << 8); memcpy((uint8_t *)dst + 2 * i, &v, 2); }
            else { uint32_t v = (uint32_t)e[0] | (uint32_t)e[1] << 8 | (uint32_t)e[2] << 16 | (uint32_t)e[3] << 24; memcpy((uint8_t *)dst + 4 * i, &v, 4); }
        }
    }
    return dst;
}
const void *prtio_peek_arr(prt_reader *r, size_t count, size_t es) {
    if (!prtio_need(r, count, es)) return NULL;
    const uint8_t *b = r->p + r->pos;
    r->pos += count * es;
    return b;
}
void *prtio_get_arr(prt_reader *r, size_t count, size_t es) {
    const void *b = prtio_peek_arr(r, count, es);
    return b ? prtio_copy_arr(r, b, count, es) : NULL;
}
bool prtio_skip_pad(prt_reader *r, size_t align) {
    uint8_t k = prtio_get_u8(r);
    const uint8_t *z = prtio_peek_arr(r, k, 1);
    if (k >= align) r->bad = true;
    for (size_t i = 0; z && i < k; i++)
        if (z[i]) r->bad = true;
    return !r->bad;
}
/* See prtio.h: the window starts at the page holding p (mmap's offsets are whole pages), so p keeps
 * its alignment; the pages are the page cache's, shared with the reader's mapping, never copied. */
const void *prtio_map_window(const prt_reader *r, const void *p, size_t len, void **map, size_t *mapped) {
    *map = NULL;
    *mapped = 0;
    const prtio_file *f = r->file;
    if (!f || !HOST_LE || len == 0) return NULL;
    size_t off = (size_t)((const uint8_t *)p - f->base), pg = (size_t)sysconf(_SC_PAGESIZE), start = off / pg * pg;
    PRT_CHECK(off <= f->size && len <= f->size - off);
    void *m = mmap(NULL, off + len - start, PROT_READ, MAP_PRIVATE, f->fd, (off_t)start);
    if (m == MAP_FAILED) return NULL;
    *map = m;
    *mapped = off + len - start;
    return (const uint8_t *)m + (off - start);
}
bool prtio_get_str(prt_reader *r, char *buf, size_t cap) {
    uint32_t n = prtio_get_u32(r);
    if (n >= cap || !prtio_need(r, n, 1)) {
        r->bad = true;
        buf[0] = 0;
        return false;
    }
    memcpy(buf, r->p + r->pos, n);
    buf[n] = 0;
    r->pos += n;
    return true;
}

bool prtio_all_finite(const float *v, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) return false;
    return true;
}
