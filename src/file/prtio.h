/* prtio.h - the .prt file's byte-level serializer: little-endian scalars and
 * arrays out through a CRC-folding writer, in through a bounds-checked reader.
 * prtfile.c frames the file with it; each transfer representation writes and
 * reads its own section with it (transfer.h), so the format of a section lives
 * in the module that owns the data.
 *
 * Usage:
 *     prt_writer w = { .f = f, .crc = prtio_crc_init() };   // .f NULL: only counts bytes
 *     prtio_put_u32(&w, 7); prtio_put_arr(&w, pos, 3 * n, 4);
 *     prt_reader r = { .p = bytes, .n = len };
 *     uint32_t x = prtio_get_u32(&r);        // 0 once past the end; r.bad says so
 *     float *a = prtio_get_arr(&r, n, 4);     // malloc'd (free()); NULL and bad if short
 *
 * Errors: the writer sets bad when fwrite fails; the reader sets bad (sticky) on any
 * overrun and oom too when an allocation fails, and yields zeros from then on, so a
 * section parser checks once at the end. Scalars are written field by field and floats
 * as their IEEE bits, so C struct layout never leaks into the format. */
#ifndef PRT_PRTIO_H
#define PRT_PRTIO_H
#include "common.h"
#include <stdio.h>

typedef struct prt_writer {
    FILE *f;                /* NULL: count bytes only (the pass that sizes a section) */
    uint64_t n;             /* bytes written (or counted) */
    unsigned long crc;      /* CRC-32 (zlib) of everything written */
    bool bad;               /* a write failed */
} prt_writer;

typedef struct prt_reader {
    const uint8_t *p;
    size_t n, pos;
    bool bad;               /* overrun (sticky) */
    bool oom;               /* an allocation failed (bad is set too) */
} prt_reader;

/* The CRC-32 of nothing, to start a writer with. */
unsigned long prtio_crc_init(void);
/* CRC-32 of len bytes continuing crc (any length). */
unsigned long prtio_crc(unsigned long crc, const void *p, size_t len);

/* Writes (or counts) len bytes and folds them into the CRC. */
void prtio_put_bytes(prt_writer *w, const void *p, size_t len);
void prtio_put_u8(prt_writer *w, uint8_t v);
void prtio_put_u32(prt_writer *w, uint32_t v);
void prtio_put_u64(prt_writer *w, uint64_t v);
void prtio_put_i32(prt_writer *w, int32_t v);
void prtio_put_f32(prt_writer *w, float v);
void prtio_put_f64(prt_writer *w, double v);
/* count elements of es bytes (1, 2 or 4; floats as their bits), little-endian. */
void prtio_put_arr(prt_writer *w, const void *p, size_t count, size_t es);
/* u32 length (at most cap) and the bytes, no terminator. */
void prtio_put_str(prt_writer *w, const char *s, size_t cap);

/* True if count elements of es bytes are left; sets bad otherwise (overflow-safe). */
bool prtio_need(prt_reader *r, size_t count, size_t es);
uint8_t prtio_get_u8(prt_reader *r);
uint32_t prtio_get_u32(prt_reader *r);
uint64_t prtio_get_u64(prt_reader *r);
int32_t prtio_get_i32(prt_reader *r);
float prtio_get_f32(prt_reader *r);
double prtio_get_f64(prt_reader *r);
/* Allocates and reads count elements of es bytes (free()); NULL with bad (and oom) set on failure.
 * A zero count gives a valid one-byte allocation so owners can always free it. */
void *prtio_get_arr(prt_reader *r, size_t count, size_t es);
/* Reads a length-prefixed string into buf[cap] (NUL-terminated); false (bad) if too long. */
bool prtio_get_str(prt_reader *r, char *buf, size_t cap);

/* True if none of v[0..n) is NaN or infinite (the readers' validation of float data). */
bool prtio_all_finite(const float *v, size_t n);
#endif
