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
 * Mapped reading: prtfile_read maps the whole file read-only and gives its readers
 * .file; a section reader may then leave a large array in the file (prtio_peek_arr, then
 * prtio_map_window: a private read-only mapping of just those pages, which outlives the reader)
 * instead of copying it. A reader without .file (bytes in memory) always copies.
 * Alignment: prtio_put_pad pads so that the next array starts at a multiple of its alignment from
 * the file's start; its count pass must then start at the real pass's offset (prt_writer.n).
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

/* A file read through a read-only mapping of all of it (prtfile_read). */
typedef struct prtio_file {
    int fd;                 /* open for reading while the readers run */
    const uint8_t *base;    /* the mapping of the whole file (byte 0 of the file) */
    size_t size;
} prtio_file;

typedef struct prt_reader {
    const uint8_t *p;
    size_t n, pos;
    bool bad;               /* overrun (sticky) */
    bool oom;               /* an allocation failed (bad is set too) */
    const prtio_file *file; /* non-NULL: p lies in file->base's mapping, so arrays may be mapped */
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
/* A u8 k and k zero bytes (k < align <= 256), k chosen so that the byte `after` bytes past them
 * lies at a multiple of align from the start of the file (w->n counts from there). */
void prtio_put_pad(prt_writer *w, size_t after, size_t align);

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
/* The count elements of es bytes at the reader's position, in place (no copy, the reader's bytes:
 * file order, little-endian), and advances past them; NULL with bad set if short. */
const void *prtio_peek_arr(prt_reader *r, size_t count, size_t es);
/* A malloc'd host-order copy of count elements of es bytes at p (e.g. from prtio_peek_arr); NULL
 * with bad and oom set when the allocation fails. A zero count gives a one-byte allocation. */
void *prtio_copy_arr(prt_reader *r, const void *p, size_t count, size_t es);
/* Skips prtio_put_pad's padding (k < align, zero bytes); false (bad) when it is longer or not zero. */
bool prtio_skip_pad(prt_reader *r, size_t align);
/* Maps the len bytes at p (inside r's file mapping, e.g. from prtio_peek_arr) on their own,
 * read-only and private, so they outlive the reader's mapping. Returns p's address in the new
 * mapping, with the mapping itself in *map, *mapped (for munmap), or NULL (nothing mapped) when r
 * has no file, the host is big-endian, len is 0 or mmap fails: the caller copies instead. */
const void *prtio_map_window(const prt_reader *r, const void *p, size_t len, void **map, size_t *mapped);
/* CRC-32 of len bytes from the start (prtio_crc_init), folded on up to nthreads threads in chunks
 * and joined (crc32_combine): the same value as prtio_crc. With drop, p is a read-only file
 * mapping and each chunk's pages leave this process's memory once folded (the page cache keeps
 * them). */
unsigned long prtio_crc_threads(const void *p, size_t len, int nthreads, bool drop);

/* Reads a length-prefixed string into buf[cap] (NUL-terminated); false (bad) if too long. */
bool prtio_get_str(prt_reader *r, char *buf, size_t cap);

/* True if none of v[0..n) is NaN or infinite (the readers' validation of float data). */
bool prtio_all_finite(const float *v, size_t n);
#endif
