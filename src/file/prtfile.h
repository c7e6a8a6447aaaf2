/* prtfile.h - prt_data, everything precomputation produces, and the .prt file.
 *
 * File layout (little-endian), version PRTFILE_VERSION:
 *   "PRTF" magic, u32 version, u64 payload bytes, then tagged sections
 *   (u32 tag, u64 length, bytes): META (N, qbits, resolutions, timings, plan text),
 *   MESH, MATL (params, spec strings, factor maps and singular values), TRAN
 *   (transport arrays), optionally DIRT (the direct-only transport, same layout), and finally a CRC-32 (zlib) of everything before it.
 * prtfile_read checks magic, version, every length against the file size, the
 * CRC and every index (vertex, material, block, run and coefficient counts),
 * so a corrupt, truncated or wrong-version file fails with one line, never a crash.
 * prtfile_write writes to a temporary file and renames it.
 *
 * Ownership: prt_data owns everything in it; prt_data_free frees it. */
#ifndef PRT_PRTFILE_H
#define PRT_PRTFILE_H
#include "common.h"
#include "scene.h"
#include "factor.h"
#include "transport.h"

#define PRTFILE_VERSION 1
#define PRT_MAX_BOUNCES 8

typedef struct prt_stats {
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
} prt_stats;

typedef struct prt_data {
    prt_scene scene;
    brdf_factor factors[PRT_MAX_MATERIALS];   /* one per scene material */
    prt_transport transport;  /* direct + every interreflection pass (what the runtime uses) */
    prt_transport direct;     /* optional (nvecs 0 when absent): the direct pass alone, kept by
                               * `precompute --keep-direct` for the viewer's direct/bounces toggle */
    int vis_res;        /* visibility cube resolution (128) */
    int gather_res;     /* gathering cube resolution (32) */
    int sh_order;       /* 0: Haar wavelet basis; else spherical harmonics of this order */
    prt_stats stats;
    char plan[4096];    /* the effects plan, as printed */
} prt_data;

int prtfile_write(const char *path, const prt_data *d, prt_error *err);
int prtfile_read(const char *path, prt_data *out, prt_error *err);
void prt_data_free(prt_data *d);
#endif
