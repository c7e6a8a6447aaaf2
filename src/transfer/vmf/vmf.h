/* vmf.h - the vMF lobe transfer (laurijssen-2011 sections 4-6): its data layout, the one
 * shading rule both runtimes follow, and the helpers the precompute (vmfpass.h), the file
 * section and the CPU runtime share. Short prefix: vmft_ (vMF transfer; vmf_ is a lobe,
 * lobe.h). The ops table is transfer_vmf (transfer_vmf.c, listed in transfer.c).
 *
 * Usage (runtime; the ops do this, a GPU backend mirrors it):
 *     const vmft_data *t = vmft_get(tr);                  // tr->priv of a "vmf" transfer
 *     vmft_radiance(t, &d->scene.mesh, v, wo, env, rgb);  // one vertex toward unit wo (world), added to rgb
 *     tr->ops->view->shade_vertices(d, tr, env, eye, rgb, 0);   // every vertex of tr's materials, both cores
 *
 * What is represented (Eq. 5-6): the outgoing radiance of vertex v toward view w_o is
 *     L_o(v, w_o) = sum over passes p < passes, lobes i < lobes of alpha_{p,i} E(mu_{p,i}, kappa_{p,i})
 * with E(mu, kappa) = int L(s) gamma(s; mu, kappa) ds the probe prefiltered by the vMF
 * (prefilter.h) and alpha an RGB colour (the slice's integral, Eq. 9 and 11). Pass 0 is the
 * direct pass (the BRDF lobe minus what the scene blocks, Eq. 9), pass p >= 1 the light
 * gathered after p reflections (section 5.2). Only the specular slice f_s cos is here: the
 * material's kd/pi stays in the linear K = 1 transfer beside this one.
 *
 * Sampling: w_o is sampled on the geodesic grid of `level` (geogrid.h: 10 * 4^level + 2
 * views, global frame). A (vertex, view) slice is one pass's I lobes for each pass. Only
 * active views are computed: g_j . n_v > -sin(spacing) (`horizon`), so that the three grid
 * views around any w_o above the horizon are active.
 *
 * Storage (section 6.2): a slice equal to the BRDF's own lobe (no sampled ray blocked, hence
 * nothing gathered either) is NOT stored; the BRDF's own lobe comes from the material's
 * one-lobe fit (lobefit.h, fit[material]) at the view in v's frame: vmft_brdf_lobe. The
 * stored slices go in a perfect hash by row displacement (phash.h), row = vertex, column =
 * view: slot s = hash.offset[v] + j holds (v, j) when hash.owner[s] == v + 1, and its lobes
 * are entry entry[s] of a compact lobe array (the hash's fill is ~50% on a small scene, so
 * lobes per slot would double the bytes; the map costs 4 bytes a slot). An absent
 * slice means: pass 0 = the BRDF's own lobe as lobe 0 (lobes 1.. zero), passes >= 1 zero.
 *
 * Data layout (what a GPU backend uploads; all little-endian 32-bit words):
 *     hash.offset [nverts]            u32 O[v]
 *     hash.owner  [hash.size]         u32 v + 1 of the slice in slot s, 0 when free
 *     entry       [hash.size]         u32 e: the slice's index in lobe (0xffffffff when free);
 *                                     entries are in (vertex, view) order
 *     lobe        [hash.n][passes][lobes][VMFT_WORDS] u32: entry e, pass p, lobe i at
 *                                     ((e * passes + p) * lobes + i) * 3
 * and one packed lobe is 12 bytes (VMFT_WORDS = 3):
 *     word 0: mu, octahedral (Cigolle et al. 2014): u = x / (|x|+|y|+|z|), v likewise, folded
 *             for z < 0 (u, v) <- ((1 - |v|) sign u, (1 - |u|) sign v); snorm16 each,
 *             u in bits 0-15, v in bits 16-31 (round(u * 32767) as int16)
 *     word 1: kappa as IEEE half in bits 0-15, alpha red as half in bits 16-31
 *     word 2: alpha green (bits 0-15), alpha blue (bits 16-31), halves
 * A lobe with alpha 0 is empty (skipped). Measured round trip (tests/test_vmf.c, vmf/pack):
 * axis within 7e-5 rad (6.3e-5 seen), kappa and alpha within 0.05% (half's 11 bits); kappa above 65,504
 * (half's largest; a lobe 0.004 rad wide, 40 times sharper than the prefilter's finest level)
 * is stored as 65,504.
 *
 * Interpolation (Eq. 7), vmft_interp: a lobe of pass p and index i at n (vertex, view) pairs
 * with weights w_k (the 3 grid views of one vertex at runtime; 3 views x 3 hit-triangle
 * vertices when gathering) is alpha = sum w_k alpha_k, mu = normalize(sum w_k a_k mu_k),
 * kappa = sum w_k a_k kappa_k / sum w_k a_k, a_k the luminance of alpha_k: Eq. 7 with the
 * axis and width of an empty lobe (alpha 0) left out. Lobes correspond by index (each slice
 * keeps its lobes sorted by decreasing luminance). Where none of the pairs is stored, pass 0
 * is the BRDF's own lobe at the exact w_o instead (so an unoccluded vertex is exactly the
 * lobe fit); where some are, absent pairs give the BRDF lobe at their grid view, which keeps
 * Eq. 7 exact for mirror lobes (the mirror direction is linear in w_o, geogrid.h).
 * Measured against interpolating radiance instead (sum w_k alpha_k E(mu_k, kappa_k) over the three
 * views, an absent view's lobe at the exact w_o; teapot + floor under city, 3 passes, against
 * the path tracer at 1,024 spp, 3.6% noise): 20.4% per vertex (27.8% where a view is stored)
 * against Eq. 7's 18.2% (24.6%), and 3 lookups instead of 1: Eq. 7 stays.
 * Views below the horizon: w_o (and any view) with n.w_o < VMFT_MIN_COS is shaded at the
 * grazing direction of the same azimuth (as the SVD runtime does, relight.c).
 *
 * Per pixel (vmft_radiance_point; gl's per-pixel program is the same rule in GLSL,
 * transfer_vmf_glsl.c): a point at barycentrics b of triangle (v_0, v_1, v_2) seen along w_o has
 * the normal normalize(sum b_k n_k) and the view w_o (moved to the grazing view as above for that
 * normal), located once on the grid (views g_q, weights w_q); Eq. 7 then runs over the 9 pairs
 * (v_k, g_q) of the corners of the transfer's materials with weights b_k w_q, exactly as the
 * gathering passes interpolate at a hit point (vmfpass.c). At a vertex (b = e_k) it is the
 * per-vertex rule (within 3e-6, the renormalized normal: runtime/vmf_point_vertex). So the lobes,
 * not their radiance, are interpolated across a triangle: a Phong n = 1000 highlight or a
 * reflected edge keeps its width instead of being spread over the vertex spacing.
 *
 * Grid level (the default, 2 = 162 views, by measurement; tools/vmf_measure.sh on
 * data/teapot-floor.json under city.exr, specular part only against `prt reference` at 2,048
 * samples per vertex, 2.5% noise, this 2-core machine shared with other jobs): vertices whose
 * three views are unstored are within 4.4% (the lobe fit's own error); those near a stored
 * slice are 22.5% off at level 2 and 19.7% at level 3 (direct pass), 16.2% / 13.7% overall
 * with 3 passes, while the precompute costs 38 s at level 2 and 92 s at level 3 (Haar's
 * direct pass of the same scene: 15 s). With the eye far along a grid view the stored slices
 * are within 5.0%: the error is the grid's angular interpolation of occlusion boundaries (a
 * floor edge that a lobe crosses between two views is blended over 2 x 17 degrees of
 * reflected direction at level 2), so level 3 or 4 sharpens it at 4x, 16x the cost.
 * Measured (same set-up): teapot + floor, level 2, 3 passes (the third carried 0.25% of the
 * direct energy): 65.8% of 347,243 active slices stored (the floor blocks every low view;
 * 28% of stored slices are fully blocked, only 8% have 1-2 blocked rays of 64), hash fill
 * 46.5% (phash.c), 20.4 MB (the Haar file of the scene: 9.0 MB). CPU shading (tools/vmf_measure.sh
 * --save/--load): 0.63 us a glossy vertex of teapot + floor; the bunny in paper-phong alone (34,834
 * glossy vertices, 39% of 3.7 M slices stored, 72 MB) 0.30-0.33 us a vertex on one thread, 86-88
 * frames a second on both cores; 0.28 us on the unoccluded sphere, where every vertex takes the
 * one-lookup path. shade_range prefetches a block's entries and lobes, since a frame otherwise
 * waits on their cache misses, and vmft_brdf_lobe builds its tangent frame in float. Precompute
 * of teapot + floor, 3 passes: 16.6 s (direct 6.2, pass 1 6.7, pass 2 3.2 s: pass 2 skips the
 * slices that hit no fitted triangle in pass 1), about the linear transfer's direct pass (16.5 s);
 * the paper-phong sphere 0.66 s (vmfpass.c vp_open: nothing above the tangent plane is traced).
 * docs/design/representations.md keeps how these figures came about.
 * Diffuse hits (vmfpass.h): without pass 1 the stored teapot vertices have 59% of the
 * reference's 1-bounce energy (25.9% error); with the floor's diffuse lobes gathered, 100.6%
 * (16.2%), so they are kept.
 *
 * Errors: vmft_init fails (-1, one line) on a bad level or out of memory. Everything else is
 * pure reads of a validated vmft_data (any thread).
 * Ownership: a vmft_data owns its hash, lobes and grid (vmft_free); tr->priv owns one. */
#ifndef PRT_VMF_H
#define PRT_VMF_H
#include "common.h"
#include "geogrid.h"
#include "lobe.h"
#include "lobefit.h"
#include "phash.h"
#include "scene.h"
#include "transfer.h"

struct prt_transfer;
struct prt_data;
struct prefilter_env;

#define VMFT_WORDS 3             /* u32 words per packed lobe */
#define VMFT_MAX_LOBES 4         /* I */
#define VMFT_MAX_PASSES 4        /* R: the direct pass and up to 3 gathering passes */
#define VMFT_MIN_COS 0.02f       /* views closer to the horizon are shaded at this elevation */
#define VMFT_KAPPA_MAX 65504.0f  /* half's largest */
#define VMFT_DEFAULT_LOBES 2
#define VMFT_DEFAULT_LEVEL 2     /* 162 views: measured against level 3 in vmf.h ("Grid level") */
#define VMFT_DEFAULT_SAMPLES 64  /* rays per slice and pass (the paper traced 144) */
/* The view grid's level when the options leave it (settle): the finest of VMFT_DEFAULT_LEVEL..
 * VMFT_PLAN_MAX_LEVEL whose bytes stay within VMFT_PLAN_BYTES (the bench file's size). A finer grid
 * interpolates a lobe's occlusion edge over fewer degrees of view (docs/design/glossy.md: teapot over
 * a floor under studio, per-vertex specular error 18% at level 2, 15% at 3, 13% at 4). Bytes per
 * (vertex, view) pair: VMFT_PLAN_SLOT_BYTES of hash slots, and VMFT_PLAN_STORED stored slices of
 * passes x lobes x 12 bytes: teapot-floor's at level 2 (491,244 slots and 228,570 stored slices of
 * its 525,042 pairs), a scene whose floor blocks every low view, the dear case. */
#define VMFT_PLAN_BYTES 96e6
#define VMFT_PLAN_SLOT_BYTES 7.5
#define VMFT_PLAN_STORED 0.44
#define VMFT_PLAN_MAX_LEVEL 4

/* The transfer's configuration (its options: lobes=1..4, level=0..6, samples=4..4096; transfer_vmf.c),
 * the private struct inside its transfer_config. */
typedef struct vmf_config {
    int lobes;      /* I: lobes per set and reflection pass */
    int level;      /* geodesic view grid: icosahedron subdivided `level` times (10 * 4^level + 2 views) */
    int samples;    /* rays per (vertex, view) set in the direct and gathering passes */
    bool level_set; /* level fixed: given in the options, settled, or read; else settle picks it */
} vmf_config;
vmf_config vmft_config(const transfer_config *cfg);
/* Its table (transfer_vmf.c; listed in transfer.c) and the per-pixel shading it points at
 * (transfer_vmf_glsl.c), for this folder and the tests and tools that measure vMF itself. */
extern const transfer_ops transfer_vmf;
extern const transfer_glsl_view transfer_vmf_glsl_view;

typedef struct vmft_data {
    int level, nviews;          /* geodesic grid (grid is rebuilt from level when read) */
    int lobes;                  /* I */
    int passes;                 /* R stored: 1 = the direct pass alone */
    int samples;                /* rays per slice and pass */
    int nverts;                 /* mesh vertices = hash rows */
    uint64_t materials;         /* bit m: fit[m] is filled (the transfer's materials) */
    float horizon;              /* view j is active at v when g_j . n_v > -horizon */
    phash_table hash;           /* rows vertices, columns views */
    uint32_t *entry;            /* [hash.size] slot -> entry (layout above) */
    uint32_t *lobe;             /* [hash.n * passes * lobes * VMFT_WORDS] */
    lobefit_table fit[PRT_MAX_MATERIALS];   /* the BRDF's own lobe per view elevation */
    geogrid *grid;
    uint64_t *stored;           /* [nverts * words] derived, not in the file (vmft_index): bit j of row v
                                 * = slice (v, j) is stored, so an absent view costs no hash probe */
    int words;                  /* (nviews + 63) / 64 */
    /* statistics (stored in the file, shown by `prt info`) */
    uint64_t slices;            /* active (vertex, view) slices computed */
    double t_pass[VMFT_MAX_PASSES];   /* seconds per pass */
    double energy[VMFT_MAX_PASSES];   /* each pass's sum of alpha luminance over slices / the direct pass's */
} vmft_data;

/* The vmft_data of a vmf transfer (tr->priv). */
const vmft_data *vmft_get(const struct prt_transfer *tr);
/* Sets up an empty transfer: the grid of `level`, I = lobes, nverts rows; -1 and err on a bad level/OOM. */
int vmft_init(vmft_data *t, int level, int lobes, int nverts, prt_error *err);
/* Frees the hash, lobes and grid and zeroes t. */
void vmft_free(vmft_data *t);
/* Builds t->stored from the hash (after it is filled or read; owners outside their row are skipped,
 * the validator names them). -1 and err when out of memory. */
int vmft_index(vmft_data *t, prt_error *err);
/* Bytes of the layout above (offsets, owners, entries, lobes). */
size_t vmft_bytes(const vmft_data *t);

/* Packs a lobe and colour into 3 words (layout above); unpacks them (alpha 0: an empty lobe). */
void vmft_pack(const vmf_lobe *l, const float alpha[3], uint32_t w[VMFT_WORDS]);
void vmft_unpack(const uint32_t w[VMFT_WORDS], vmf_lobe *l, float alpha[3]);
/* The packed lobes of slice (v, j), pass p (lobes words each VMFT_WORDS), or NULL when absent. */
const uint32_t *vmft_slice(const vmft_data *t, int v, int j, int p);

/* The BRDF's own lobe (fit) toward world view wo at a vertex of unit normal n: lobefit_lookup in a
 * frame of n (wo below VMFT_MIN_COS moved to that elevation), mu back in the world frame. */
void vmft_brdf_lobe(const lobefit_table *fit, const float n[3], const float wo[3], vmf_lobe *l, float alpha[3]);
/* Eq. 7 (header): the `lobes` lobes of pass p interpolated over n pairs (vert[k], view[k]) with weights
 * w[k]; exact_wo (may be NULL) is the view for the all-absent case of pass 0, at normal exact_n, with
 * vert[0]'s material and its colour scaled by sum w[k]. Every vert[k]'s material must be fitted. */
void vmft_interp(const vmft_data *t, const prt_mesh *m, int n, const int *vert, const int *view, const float *w,
                 int p, const float *exact_wo, const float *exact_n, vmf_lobe *out, float (*alpha)[3]);
/* Adds to rgb the radiance of vertex v (of a fitted material) toward unit world wo (every pass), lit by env. */
void vmft_radiance(const vmft_data *t, const prt_mesh *m, int v, const float wo[3], const struct prefilter_env *env,
                   float rgb[3]);
/* Adds to rgb the radiance of the point of triangle tri (vertex ids) at barycentrics bary, toward unit world wo,
 * lobes per pixel (header, "Per pixel"; negatives clamped to 0, the weights renormalized); the corners of
 * other materials take no part. What gl's per-pixel view program evaluates (transfer_vmf_glsl.c). */
void vmft_radiance_point(const vmft_data *t, const prt_mesh *m, const int tri[3], const float bary[3], const float wo[3],
                         const struct prefilter_env *env, float rgb[3]);
/* The per-pixel program's data (transfer_vmf_glsl.c's file comment gives the layout): u as R32UI
 * words, f as RGBA32F texels, both malloc'd (vmft_glsl_free). -1 with err when out of memory. */
#define VMFT_GLSL_HEADER 16
#define VMFT_GLSL_MAGIC 0x564d4631u   /* "VMF1" */
typedef struct vmft_glsl_arrays { uint32_t *u; size_t nu; float (*f)[4]; size_t nf; } vmft_glsl_arrays;
int vmft_glsl_data(const struct prt_data *d, const struct prt_transfer *tr, vmft_glsl_arrays *out, prt_error *err);
void vmft_glsl_free(vmft_glsl_arrays *a);
#endif
