/* checkpoint.h - resumable precompute: the per-vertex results of the long passes logged to a
 * checkpoint file (`prt precompute -o OUT.prt` keeps OUT.prt.ckpt), so that a run killed at any
 * point continues where it was (`--resume`) and writes the file an uninterrupted run writes.
 *
 * Usage (precompute.c and gather.c; the `ckpt_` prefix):
 *     ckpt_key k = ckpt_key_init();  ckpt_key_add(&k, bytes, n); ...   // everything results depend on
 *     prt_checkpoint *ck = ckpt_open(path, ckpt_key_value(&k), resume, nverts, NULL, &err);
 *     n = ckpt_restore(ck, pass, &t, done, vstats, &err);  // vertices of `pass` already done: staged
 *                                                          // into t, done[v] = 1, their statistics
 *     ... compute every vertex with !done[v]; after each: ckpt_add(ck, pass, &t, v, &vstats[v]);
 *     if (ckpt_close(ck, &err)) ...                         // a failed write is reported here
 *     remove(path) once the output file is written           // (the CLI does)
 *
 * Passes: 0 is the linear transfer's direct pass (visibility + transport, Eq. 3), b =
 * 1..PRT_MAX_BOUNCES its gathering pass b (Eq. 8); a view-dependent transfer in slot s >= 1 of
 * prt_data.transfers numbers its own passes from ckpt_transfer_pass(s) (transfer.h:
 * transfer_precompute_in.ckpt_pass, TRANSFER_CKPT_PASSES of them), recording opaque blobs (the vMF
 * passes: per vertex its stored slices, per slice its gathered lobes). A linear pass's records are
 * the staged vectors of its vertices (transport.h:
 * the kept indices, values and scales, exactly what transport_store staged), so restoring them
 * and finishing the set gives the same bytes as computing them. Every pass is deterministic per
 * vertex (a vertex's result depends on the scene, the options and the previous pass only, never
 * on the thread or the order), and the statistics the file keeps are summed per vertex in vertex
 * order, so threads and a resume change nothing in the output.
 *
 * File: "PRTCKPT1", u64 key, u32 vertices, u32 0; then records appended as vertices finish:
 * u32 magic, u32 length, payload, u32 CRC-32 of the payload. The file is flushed every
 * CKPT_INTERVAL_PERCENT of the vertices (the work a kill loses at most), and written in place
 * rather than renamed, since it only grows: each record is whole or ignored (a record cut by a
 * kill fails its length or CRC and is dropped, with everything after it), which makes every
 * flush atomic at record granularity without rewriting the file.
 *
 * Key: a 64-bit hash (zlib's CRC-32 and Adler-32 of one stream) of the mesh as precomputed, the
 * materials, their BRDF factors, a textured scene's textures and every option that changes the
 * output (not the threads). A
 * checkpoint of another key is refused with one line naming it; so is a corrupt record in the
 * valid part.
 *
 * Errors: ckpt_open and ckpt_restore return NULL / -1 with one line naming the file. ckpt_add is
 * called from the worker threads and cannot fail the pass: a failed write (a full disk) is kept
 * and returned by ckpt_close, and later records are not written.
 *
 * Test hook: ckpt_open's kill_after > 0 raises SIGKILL right after that many flushes
 * (`PRT_CHECKPOINT_KILL=N prt precompute ...`; tests/test_resume.c kills runs at chosen points).
 *
 * Ownership: the checkpoint owns its FILE and index; ckpt_close frees it (NULL is fine). */
#ifndef PRT_CHECKPOINT_H
#define PRT_CHECKPOINT_H
#include "common.h"
#include "transfer.h"
#include "transport.h"

#define CKPT_INTERVAL_PERCENT 2     /* flush every 2% of the vertices of a pass */
#define CKPT_TRANSFER_FIRST 10      /* the first id after the linear passes 0..PRT_MAX_BOUNCES */
#define CKPT_MAX_PASSES (CKPT_TRANSFER_FIRST + (PRT_MAX_TRANSFERS - 1) * TRANSFER_CKPT_PASSES)
/* The first pass id of the view-dependent transfer in slot s (1 <= s < PRT_MAX_TRANSFERS). */
int ckpt_transfer_pass(int slot);

typedef struct prt_checkpoint prt_checkpoint;

/* What the direct pass keeps per vertex for the file's statistics (zero for gathering passes). */
typedef struct ckpt_vstats {
    int64_t traced, hits;   /* visibility rays cast and hitting geometry */
    double err;             /* sum over its vectors of (relative L2 error)^2 */
    int32_t errs;           /* vectors counted in err */
    double energy;          /* sum over its vectors of the whole vector's |coefficients|^2 */
    int32_t open;           /* 1: its vectors hold the open sky split's blocked part (opensky.h) */
} ckpt_vstats;

/* A running 64-bit hash of the inputs. */
typedef struct ckpt_key { unsigned long crc, adler; } ckpt_key;
ckpt_key ckpt_key_init(void);
/* Adds n bytes at p to the hash. */
void ckpt_key_add(ckpt_key *k, const void *p, size_t n);
/* Adds a string (with its length, so "ab","c" and "a","bc" differ; NULL as empty). */
void ckpt_key_str(ckpt_key *k, const char *s);
uint64_t ckpt_key_value(const ckpt_key *k);
struct prt_scene;
/* Adds a textured scene's textures (texture.h): each one's size and sRGB texels (its linear values
 * follow from them), each material's texture and the mesh's coordinates, which the gathering passes
 * read (each triangle's mean albedo); nothing for an untextured scene. */
void ckpt_key_textures(ckpt_key *k, const struct prt_scene *sc);

/* Opens path: resume and the file exists: reads its index (a torn tail is cut off), refusing
 * another key or vertex count; otherwise starts a new file. kill_after: the test hook above.
 * Returns the checkpoint, or NULL with err. */
prt_checkpoint *ckpt_open(const char *path, uint64_t key, bool resume, int nverts, int kill_after, prt_error *err);
/* Vertices of `pass` in the checkpoint (0 for a new file). */
int ckpt_count(const prt_checkpoint *c, int pass);
/* Stages the recorded vertices of pass into t (initialized, not finished), sets done[v] = 1 and,
 * when vs is not NULL, vs[v]. Returns how many, or -1 with err (a record that does not fit t). */
int ckpt_restore(prt_checkpoint *c, int pass, prt_transport *t, uint8_t *done, ckpt_vstats *vs, prt_error *err);
/* Appends vertex v of pass (its staged vectors in t; vs may be NULL). Thread-safe. */
void ckpt_add(prt_checkpoint *c, int pass, const prt_transport *t, int v, const ckpt_vstats *vs);
/* Passes whose results are not transport sets (a view-dependent transfer's) record opaque blobs:
 * item (a vertex or slice number), len bytes. Thread-safe, like ckpt_add. */
void ckpt_add_blob(prt_checkpoint *c, int pass, uint32_t item, const void *data, uint32_t len);
/* Calls fn for every blob of pass; fn returns 0, or -1 when the blob does not fit (a corrupt file).
 * Returns how many, or -1 with err. */
int ckpt_restore_blobs(prt_checkpoint *c, int pass, int (*fn)(void *user, uint32_t item, const uint8_t *data, uint32_t len),
                       void *user, prt_error *err);
/* Flushes and closes (the file stays). Returns 0, or -1 with err when a write failed. */
int ckpt_close(prt_checkpoint *c, prt_error *err);
#endif
