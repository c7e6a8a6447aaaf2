/* prtfile.h - prt_data, everything precomputation produces, and the .prt file.
 *
 * File layout (little-endian), version PRTFILE_VERSION:
 *   "PRTF" magic, u32 version, u64 payload bytes, then tagged sections
 *   (u32 tag, u64 length, bytes): META (resolutions, timings, plan text),
 *   MESH, MATL (params, spec strings, factor maps and singular values), then one
 *   section per transfer representation used, under that representation's own tag
 *   and written, read and validated by its module (transfer.h: config, material
 *   mask, transport, the direct-only set inside it when kept), the optional LITE
 *   (local lights), CAMS (named cameras) and TXTR (textures and UVs) sections,
 *   and finally a CRC-32 (zlib) of everything before it.
 * prtfile_read checks magic, version, every length against the file size, the
 * CRC and every index (vertex, material, block, run and coefficient counts),
 * so a corrupt, truncated or wrong-version file fails with one line, never a crash;
 * a file of an older version says to precompute it again. prtfile_read_memory does
 * the same on bytes already in memory (a name stands for the path in its errors).
 * prtfile_write writes to a temporary file and renames it.
 *
 * Mapped loading: prtfile_read maps the file instead of reading it, folds the CRC on every
 * core, and a linear transfer's runs and coefficients (nearly all of a large file) stay in
 * the file's pages as a read-only window per transport set (its data_map) rather than being
 * copied; the writer pads them to 64-byte offsets so that they can.
 * The checks are the same. The windows' pages are the page cache's: shared by every process
 * that loads the file, never copied, dropped by the kernel under memory pressure and read
 * back; the CRC's pass over the whole file leaves none resident. prtfile_read_memory, an
 * file whose arrays fall on odd offsets (unpadded, version 2), or a file mmap refuses, are
 * copied: the same data.
 * A loaded file may be replaced (prt writes by rename) but must not be truncated in place.
 *
 * Ownership: prt_data owns everything in it, mappings included; prt_data_free frees it
 * (each transfer through its ops->release). Nothing here names a representation: each
 * transfer's section is its ops' (transfer.h). */
#ifndef PRT_PRTFILE_H
#define PRT_PRTFILE_H
#include "common.h"
#include "scene.h"
#include "factor.h"
#include "transfer.h"

/* 3: a Haar set's coefficient arrays padded to 64-byte file offsets (transfer flag bit 2, for the
 *    mapped load) and, with a shared coefficient budget, a set's N the most any vector holds;
 * 2: one section per transfer representation, read still (the same sections, unpadded, N per vector);
 * 1: META basis + TRAN/DIRT, refused. A prt older than version 3 refuses version 3 files with one line
 * naming the version, rather than as corrupt. */
#define PRTFILE_VERSION 3
#define PRTFILE_VERSION_OLDEST 2
#define PRT_MAX_BOUNCES 8
#define PRT_MAX_PASSES 16   /* direct + bounces + a view-dependent transfer's stages, with room */

/* One pass of a precompute, as the effects plan estimated it and as it ran (not stored). */
typedef struct prt_pass_time {
    char name[24];      /* "direct", "bounce 1", then a view-dependent transfer's stages as it names them */
    double est_cpu;     /* the plan's estimate: CPU seconds over every thread */
    double est;         /* the same in wall seconds at the sample's threads and share of a core */
    double cpu, wall;   /* measured (0 and ran false while it has not run) */
    bool planned, ran;
} prt_pass_time;

typedef struct prt_stats {
    double t_refine;            /* adaptive refinement (refine.h; 0 when off; not stored: the plan line has it) */
    double t_transfer[PRT_MAX_TRANSFERS];  /* transfer i's own work beyond the linear passes (a view-dependent
                                 * transfer's passes, a linear one's begin); 0: none (not stored) */
    const char *t_transfer_name[PRT_MAX_TRANSFERS];  /* what that time is, as its representation names it
                                 * ("light prior"; NULL for a view-dependent transfer's passes) */
    double t_brdf;              /* BRDF tabulation + SVD */
    double t_visibility;        /* ray casting */
    double t_transport;         /* transport evaluation, Haar, selection, quantization */
    double t_bounce[PRT_MAX_BOUNCES]; /* each interreflection pass */
    double t_write;             /* writing the file (filled by the writer's caller) */
    double t_total;
    long rays_traced, rays_hit; /* visibility pass */
    double hit_fraction;        /* rays_hit / rays_traced */
    int bounces;                /* interreflection passes done */
    double bounce_energy[PRT_MAX_BOUNCES]; /* energy of pass i relative to the direct pass */
    double trunc_rel_err;       /* RMS relative L2 error of truncation + quantization over all vectors */
    size_t peak_rss_bytes;
    int npasses;                /* passes the plan estimated or that ran (not stored) */
    prt_pass_time pass[PRT_MAX_PASSES];
} prt_stats;

typedef struct prt_data {
    prt_scene scene;
    brdf_factor factors[PRT_MAX_MATERIALS];   /* one per scene material */
    prt_transfer transfers[PRT_MAX_TRANSFERS]; /* one per representation used (transfer.h); a vertex's
                                                * radiance is the sum over those whose mask holds its material */
    int ntransfers;
    int vis_res;        /* visibility cube resolution (128) */
    int gather_res;     /* gathering cube resolution (32) */
    prt_stats stats;
    char plan[4096];    /* the effects plan, as printed */
} prt_data;

int prtfile_write(const char *path, const prt_data *d, prt_error *err);
int prtfile_read(const char *path, prt_data *out, prt_error *err);
/* prtfile_read on the bytes buf[size] (the caller's; only read), naming them name in errors. */
int prtfile_read_memory(const char *name, const uint8_t *buf, size_t size, prt_data *out, prt_error *err);
void prt_data_free(prt_data *d);
/* Bytes of d that prtfile_read left in the file's pages (the transport sets' windows, data_map)
 * instead of copying: 0 for data read from memory or built by a precompute. */
size_t prt_data_mapped_bytes(const prt_data *d);
/* The linear transfer: the first of kind TRANSFER_LINEAR, or NULL when there is none (a file
 * holding only a view-dependent transfer, as its tests write: valid, but the runtimes refuse it
 * with one line). Precompute makes exactly one, covering every material (a material on a
 * view-dependent path keeps only its kd/pi factor there). Code that shades iterates d->transfers. */
const prt_transfer *prt_data_transfer(const prt_data *d);
/* Appends a transfer of ops with cfg (NULL: defaults unfilled, zero) for materials (bit i:
 * material i) and returns it, its transport sets empty; the caller fills them. PRT_CHECKs room. */
prt_transfer *prt_data_add_transfer(prt_data *d, const transfer_ops *ops, const transfer_config *cfg, uint64_t materials);
#endif
