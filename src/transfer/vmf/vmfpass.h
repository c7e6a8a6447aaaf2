/* vmfpass.h - the passes that fill a vMF lobe transfer (vmf.h): the direct pass from rays
 * sampled from the BRDF lobe (laurijssen-2011 Eq. 8-9) and the gathering passes (section
 * 5.2, Eq. 7, 10-11). It is transfer_vmf's ops->view->precompute; its checkpoint passes are
 * in->ckpt_pass (the direct pass) and in->ckpt_pass + p (gathering pass p).
 *
 * Usage:
 *     transfer_precompute_in in = { .scene = &sc, .vis = vs, .passes = 3, .bounce_threshold = 0.01f };
 *     prt_transfer *tr = prt_data_add_transfer(d, &transfer_vmf, &cfg, glossy_mask);   // cfg: its configure
 *     if (vmfpass_run(&in, tr, &err)) puts(err.msg);      // fills tr->priv (a vmft_data)
 *
 * Direct pass (pass 0), per vertex v of tr's materials and active grid view j (vmf.h): the
 * BRDF's own lobe (lobefit, vmft_brdf_lobe) of colour A; `samples` rays drawn from it (Eq. 8,
 * vmf_sample, on a rank-1 lattice (i + 1/2)/S, i/phi rotated by a hash of (v, j): deterministic
 * and independent of the thread count); rays below v's shading horizon are not traced (they
 * are the lobe fit's own error, which the unstored BRDF lobe keeps too). No ray blocked: the
 * slice is the BRDF's own lobe and is not stored. Else Eq. 9: the unblocked rays are
 * clustered into at most I lobes (below), each refitted by its mean direction (Eq. 2) and the
 * exact inverse of Eq. 3, colour A * (its rays / S). With one cluster the mean uses the
 * exact mean of the whole lobe minus the blocked rays (r = (S A3(kappa) mu - sum blocked s) /
 * (S - blocked), a control variate): one blocked ray of 64 then moves the lobe by 1/64 of
 * that ray, not by the noise of 63 fresh samples, so stored and unstored neighbours agree.
 * A fitted lobe's kappa is capped at twice the BRDF lobe's (VP_KAPPA_CAP: a straight edge's strip
 * is at most that sharp), so a cluster of one or two rays does not fit a needle.
 *
 * Gathering pass p >= 1, per stored slice (the same rays, so the same hits): at each hit
 * (triangle a, b, c, barycentrics) the radiance toward the slice's vertex along -s is pass
 * p-1's transfer at the hit, interpolated over the hit triangle's glossy corners and the 3
 * grid views of -s (vmft_interp, Eq. 7: 9 pairs), plus in pass 1 the hit's diffuse lobe
 * (below). A hit seen from behind (-s below the interpolated normal's horizon) gives nothing.
 * Each hit lobe i of colour alpha_i becomes a lobe of colour A alpha_i / S and weight its
 * luminance (Eq. 10-11: A / S is the Monte Carlo estimate's factor, since the rays are
 * distributed as the BRDF lobe), and they are merged into I lobes: broad ones (kappa < 8,
 * diffuse light) into the last lobe when I >= 2 (the paper's "second lobe stores diffuse
 * components"), sharp ones clustered into the others. Passes stop after one whose energy
 * (sum of lobe luminances over slices) is below bounce_threshold of the direct pass's (the
 * direct pass's counts every active slice, stored or not).
 *
 * Clustering (laurijssen-2010 section 5, Alg. 4.1 as hard 2-means): start with one cluster;
 * while fewer than I, split the cluster of largest dispersion (sum w - |sum w r|) by 2-means
 * seeded at its heaviest item and the item farthest from it, and keep the split only when it
 * halves that dispersion (a lobe cut by an occluder edge is still one lobe: halving a vMF
 * sample only takes its dispersion to ~0.7). A merged cluster is r = sum w r / sum w (Eq. 4,
 * 10), colour sum of colours (Eq. 11), kappa the exact inverse of Eq. 3.
 *
 * Diffuse hits (the decision the issue asks for): a vertex whose material has kd > 0 (the
 * Lambert floor, and the red diffuse part of paper-phong) reflects, in pass 1, the lobe of
 * its direct diffuse radiance: 64 cosine-distributed rays, the unblocked ones' mean direction
 * (a vMF of kappa ~2.4 about the normal when nothing blocks it) and colour kd * unblocked
 * share, so the floor's reflection appears in a glossy teapot's lower half. Later passes
 * leave the diffuse surfaces' own interreflections out (the Haar transfer has them).
 *
 * Errors: a material of tr's mask without a lobe fit (vmf needs phong, blinn, ggx or
 * beckmann), out of memory, or cancelled through in->progress: -1 with one line; tr->priv is
 * then NULL. Threads: in->nthreads (0: all cores), dynamic chunks (prt_parallel_for). */
#ifndef PRT_VMFPASS_H
#define PRT_VMFPASS_H
#include "transfer.h"

/* Fills tr->priv for tr->materials (tr->cfg configured by transfer_vmf.configure). 0 or -1 with err. */
int vmfpass_run(const transfer_precompute_in *in, prt_transfer *tr, prt_error *err);

/* What vmfpass_estimate measured: CPU seconds of one thread per unit of each stage's work. */
typedef struct vmfpass_cost {
    int nverts, ngverts;        /* the mesh's vertices (the diffuse stage), the transfer's (the direct stage) */
    double diffuse_cpu;         /* per vertex of the diffuse-lobe stage */
    double direct_cpu;          /* per vertex of the transfer's, the direct stage (all its views) */
    double stored;              /* stored slices per vertex of the transfer's: the gathering passes' items */
    double gather_cpu;          /* per stored slice of gathering pass 1 */
    double fit_share;           /* share of stored slices whose rays hit a fitted triangle: the ones passes
                                 * >= 2 gather again (the others are skipped) */
    double gather2_cpu;         /* per such slice of a gathering pass >= 2 */
    int probed_verts, probed_slices;
} vmfpass_cost;

/* A timed probe of the passes vmfpass_run would make of tr (one thread): the direct stage on
 * VMFPASS_PROBE_VERTS of the transfer's vertices spread over them, the diffuse stage on
 * VMFPASS_PROBE_DIFFUSE vertices spread over the mesh, and gathering passes 1 and 2 on up to
 * VMFPASS_PROBE_SLICES of the slices those store (against the BRDFs' own lobes, as a pass sees
 * unstored slices; the hit corners' diffuse lobes made first). Its cost is a few hundredths of a
 * second. 0 or -1 with err (no lobe fit, out of memory). */
#define VMFPASS_PROBE_VERTS 32
#define VMFPASS_PROBE_SLICES 512
#define VMFPASS_PROBE_DIFFUSE 64
int vmfpass_estimate(const transfer_precompute_in *in, const prt_transfer *tr, vmfpass_cost *out, prt_error *err);
#endif
