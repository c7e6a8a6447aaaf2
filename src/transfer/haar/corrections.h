/* corrections.h - what Haar's policy puts back of what truncation drops (haar/policy.h), with the
 * solid-angle measure (the set's solid_angle): the block integrals and the smooth faces.
 *
 * Contract: for a vector's kept coefficients, haar_block_corrections gives adj[TRANSPORT_BLK], the
 * amounts to add to each face's 16 coarsest coefficients (transport.h) so that what was dropped is
 * put back: per block of the set's block_level, each block's integral under the solid angle w made
 * exact; or, on a smooth face (no occluder edge, TRANSPORT_SMOOTH_JUMP) with smooth_faces, the
 * dropped part weighted by the transport put on the face's scaling coefficient. A shared budget
 * splits the same sums: haar_block_stage stages what the non-candidates drop when a vector is
 * stored, haar_budget_corrections adds the dropped candidates at finish. The file and the runtimes
 * never see the corrections: they change only the kept values (docs/design/shadows.md).
 *
 * Why: Wang et al. 2006 (section 4.1.1) keep the N largest coefficients, the L2-best T; what the
 * runtime sees is T.L, and the dropped details of T/w correlate with those of w (both smooth bowls
 * over a face), so truncation loses a same-signed share of each block's integral (corrections.c). */
#ifndef PRT_HAAR_CORRECTIONS_H
#define PRT_HAAR_CORRECTIONS_H
#include "transport.h"

/* A face is smooth (smooth_faces) when no two neighbouring texels of its T/w, the channels summed, differ
 * by more than this share of its largest value and none is negative: an unoccluded cosine lobe changes
 * by at most about 4.5% of its face's largest value between texels (1.8 degrees at a face's centre; the
 * plane's side faces measured 3-5%), an occluder's edge by its cosine there (docs/design/shadows.md). */
#define TRANSPORT_SMOOTH_JUMP 0.1f

/* What every vector's corrections read, made once per set (haar_tables_create; per vector they would
 * cost as much as the corrections themselves). */
typedef struct haar_tables {
    float w[CUBE_RES * CUBE_RES];                          /* the solid angle per texel (haar_face_solid_angle) */
    float W[CUBE_RES * CUBE_RES];                          /* its Haar coefficients, morton order */
    double wsum[TRANSPORT_BLOCK_LEVEL_MAX + 1][16];       /* w summed over each block of level b (row-major) */
    float sigma[CUBE_TEXELS];                              /* the selection's prior per index (transport_sigma) */
} haar_tables;

/* The tables of a set. Returns NULL with err on OOM. */
haar_tables *haar_tables_create(prt_error *err);

/* Which faces of vector ch are smooth (bit f), and with want_H each smooth face's transport coefficients
 * H into Hc + f * CUBE_RES^2 (w: the solid angle per texel). Neither depends on the selection, so the
 * prior's selection and the smooth faces' correction read one result. scratch: 2 x CUBE_RES^2 floats. */
unsigned haar_face_shapes(const float *const ch[3], const float *w, bool want_H, float *scratch, float *Hc);
/* Per-vector budget: with t->solid_angle the block correction of every channel and face, and with
 * smooth_faces the smooth one on the smooth faces (shape, Hc: haar_face_shapes'), into adj[TRANSPORT_BLK];
 * zeros without. scratch: CUBE_RES^2 floats, then CUBE_TEXELS bytes. */
void haar_block_corrections(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n,
                            unsigned shape, const float *Hc, float *scratch, float *adj);
/* Shared budget, when vector ch is staged with its n candidates idx: what the coefficients outside them
 * drop (per channel, face and block, and the smooth faces' S and H_0) into blk (TRANSPORT_STAGE, all but
 * [TRANSPORT_BLK]). shape, Hc and scratch as haar_block_corrections'. */
void haar_block_stage(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, unsigned shape,
                      const float *Hc, float *scratch, float *blk);
/* Shared budget at finish: vector i's corrections adj[TRANSPORT_BLK] from its staging and the dropped
 * candidates (keep[k] == 0; stage_idx, stage_val not yet compacted); zeros without t->solid_angle. */
void haar_budget_corrections(const prt_transport *t, int i, const uint8_t *keep, float *adj);
#endif
