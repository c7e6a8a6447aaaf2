/* refit.h - a vector's kept Haar coefficients refit to the light a prior expects.
 *
 * Usage:
 *     refit_tables *rt = refit_create(&prior_texels, &err);    // once per set of probes; refit_destroy
 *     float *scratch = malloc(refit_scratch_size(N));          // per thread
 *     refit_face(rt, f, r, g, b, kept, n, out, scratch);       // a vector's face f: new values, or false
 *
 * Why (the shimmer; docs/design/shadows.md has the measurements). Truncation keeps the values c_k of the kept coefficients, the
 * L2-best approximation of T. What the runtime sees is T.L, and under a sun on a ring of elevation
 * (a probe turned about +y) its error is the truncated transport's error at the sun's texels: an
 * unoccluded floor's piecewise-constant blocks miss the cosine lobe there by up to 8% where the ring
 * crosses coarse blocks, so its ratio to the exact product dipped 0.6% at two of 91 one-degree steps.
 * The values that minimise the expected squared error of T.L instead, under a light whose texels
 * l_j (L_j w_j) have E[l_j l_k] = v_j delta_jk + sum_p m_pj m_pk (prior.h: the yaw orbit's variance
 * per texel and each probe's mean), solve the normal equations
 *     (Psi' V Psi + sum_p (Psi' m_p)(Psi' m_p)') x = Psi' V T + sum_p (Psi' m_p)(m_p . T)
 * with Psi the kept Haar functions of the face (texel values), T the face's T/w texels: a weighted
 * least-squares fit that is exact for each probe's mean light (the sky) and tracks T where the sun
 * can be. With v uniform and no means it returns the c_k themselves. Measured on that floor under city
 * (float): the worst step between one-degree turns is 0.20% refit, 0.60% not.
 *
 * Cost: Psi' V Psi is built from the tables (refit_create: the Haar functions' supports and quadrant
 * values, the quadrant sums of v, the Haar coefficients of v and of each m_p), an entry in O(1); then
 * a Cholesky of n x n (LAPACKE) and 3 right-hand sides. n is limited to REFIT_MAX_N per face.
 *
 * Ownership: the tables belong to the caller (refit_destroy); they are read-only, so any number of
 * threads may refit with them at once, each with its own scratch. Errors: refit_create fails only
 * for memory or an invalid prior (a negative or non-finite weight), with one line in err. */
#ifndef PRT_REFIT_H
#define PRT_REFIT_H
#include "common.h"
#include "prior.h"

/* The most kept coefficients of one face refit (the scratch holds an n x n matrix of doubles). */
#define REFIT_MAX_N 256

typedef struct refit_tables refit_tables;

/* Tables for the prior's texels pt (read, not kept). Returns NULL with err on OOM or a bad prior. */
refit_tables *refit_create(const prior_texels *pt, prt_error *err);
void refit_destroy(refit_tables *rt);
/* Bytes of scratch refit_face needs for up to n kept coefficients on a face. */
size_t refit_scratch_size(int n);
/* Face f (0..5) of a vector whose channels r, g, b are its dense Haar coefficients of T/w in wavelet
 * index order (CUBE_TEXELS each; read at f's FACE): the values of its n kept coefficients kept[0..n-1]
 * (wavelet indices on face f, increasing) that minimise the expected error above, into out[3 * k + c].
 * Returns false, out untouched, when n is 0 or over REFIT_MAX_N, a channel of the face is not finite,
 * or the system is not positive definite (a caller keeps its own values then). */
bool refit_face(const refit_tables *rt, int f, const float *r, const float *g, const float *b, const uint32_t *kept,
                int n, float *out, void *scratch);
/* Rounds face f's refit values val[3 k + c] (refit_face's, n kept as there) to multiples q step[c] with
 * |q| <= qmax, in place: first to the nearest, then coordinate by coordinate to the neighbouring multiple
 * wherever that lowers the expected error of T.L (the normal equations' quadratic form), so the coarse
 * coefficients' rounding is made up by the others (at 8 bits rounding each to the nearest leaves an
 * open floor's ratio to the exact product biased by -0.35%). scratch as refit_face's. */
void refit_quantize(const refit_tables *rt, int f, const uint32_t *kept, int n, const float step[3], int qmax, float *val,
                    void *scratch);
#endif
