/* corrections.c - what Haar's policy puts back of what truncation drops (corrections.h).
 *
 * The block integrals (block_integrals says the arithmetic): the transported light of a uniform
 * environment L is L sum_j T_j = L sum_m c_m W_m, and W (the Haar coefficients of the solid-angle
 * bowl w_j) has details that correlate with those of T/w, so dropping the small details removes a
 * same-signed share of the integral (on an unoccluded plane a uniform 1% too little). Putting what
 * was dropped back makes the integral exact again at no storage; done per block of the face, a
 * shadowed block's loss stays in that block.
 *
 * The smooth faces (smooth_faces says the arithmetic): the block integrals make every block exact
 * under a uniform light, but a sun sees a point of a block mean, and the block mean of a concave lobe
 * falls below its value on the ring a sun at a fixed elevation turns along (Jensen), which leaves an
 * unoccluded face a small bias with steps where the sun crosses a face edge. Putting the dropped part
 * back weighted by the transport, sum over dropped m of c_m H_m (H the Haar coefficients of the texels
 * T_j, Eq. 3) on the face's scaling coefficient, makes the product exact under a light shaped like
 * the transport, where a sun matters most. One scalar per face spreads over the whole face, so it is
 * taken only on faces with no occluder edge (face_smooth): on a shadowed face it would light the dark
 * part where the sun may be. H is that of the channels summed (a grey light of the transport's shape;
 * for a material of one colour the same as per channel). docs/design/transport.md has the figures. */
#include "corrections.h"
#include "haar.h"
#include "select.h"
#include <math.h>
#include <string.h>

enum { FACE = CUBE_RES * CUBE_RES };

/* See corrections.h. */
haar_tables *haar_tables_create(prt_error *err) {
    haar_tables *tb = prt_calloc(1, sizeof *tb, err);
    if (!tb) return NULL;
    haar_face_solid_angle(tb->w, CUBE_RES, false);
    for (int b = 0; b <= TRANSPORT_BLOCK_LEVEL_MAX; b++) {
        int s = 1 << b, side = CUBE_RES / s;
        for (int j = 0; j < CUBE_RES; j++)
            for (int i = 0; i < CUBE_RES; i++) tb->wsum[b][(j / side) * s + i / side] += tb->w[j * CUBE_RES + i];
    }
    float tmp[FACE];
    haar_face_solid_angle_coeffs(tb->W, CUBE_RES, tmp);
    for (uint32_t i = 0; i < CUBE_TEXELS; i++) tb->sigma[i] = transport_sigma(i);
    return tb;
}

/* The dropped coarse part coarse[m] (m < 4^b, morton order, zero where kept) into E: its value on each
 * block times w's integral there (block_integrals). */
static void block_coarse(const float *coarse, const double *wsum, int b, double *E) {
    int s = 1 << b, nb = s * s;
    float img[16] = { 0 }, tmp[16];
    for (int m = 0; m < nb; m++) {   /* an s x s image in quadrant layout */
        uint32_t i, j;
        haar_unmorton((uint32_t)m, &i, &j);
        img[j * (uint32_t)s + i] = coarse[m];
    }
    haar_inverse(img, s, tmp);
    for (int B = 0; B < nb; B++) {
        double u = img[B] * (double)s / CUBE_RES;   /* its value on block B (orthonormal at res 64) */
        E[B] += u * wsum[B];
    }
}

/* The integral under w of what was dropped of face x (not kept, finite), per block of level b, into E. */
static void block_dropped(const float *x, const uint8_t *kept, const float *W, const double *wsum, int b, double *E) {
    int s = 1 << b, nb = s * s;
    float coarse[16];
    uint8_t row[16];   /* block (row-major) of each morton position q < 4^b */
    for (uint32_t q = 0, bi, bj; q < (uint32_t)nb; q++) {
        haar_unmorton(q, &bi, &bj);
        row[q] = (uint8_t)(bj * (uint32_t)s + bi);
    }
    for (int B = 0; B < 16; B++) E[B] = 0;
    for (int l = b + 1, lo = 1 << 2 * b; l < TRANSPORT_LEVELS; l++, lo *= 4) {   /* details of level l: [lo, 4 lo) */
        int run = lo >> 2 * b;   /* one block's positions within one of the level's three kinds of detail */
        for (int m0 = lo; m0 < 4 * lo; m0 += run) {
            float acc = 0;   /* at most 64 terms; branch-free for the compiler */
            for (int m = m0; m < m0 + run; m++) {
                float v = x[m] * W[m];
                acc += kept[m] || !isfinite(v) ? 0.f : v;
            }
            E[row[(m0 & (lo - 1)) / run]] += acc;
        }
    }
    for (int m = 0; m < nb; m++) coarse[m] = !kept[m] && isfinite(x[m]) ? x[m] : 0.f;
    block_coarse(coarse, wsum, b, E);
}

/* The piecewise constant E_B / |B|_w in the kept coarse coefficients of the face: adj[4^b]. */
static void block_adjust(const double *E, const uint8_t *kept, const double *wsum, int b, float *adj) {
    int s = 1 << b, nb = s * s;
    float img[16], tmp[16];
    for (int B = 0; B < nb; B++) {
        double d = E[B] / wsum[B];
        img[B] = isfinite(d) ? (float)d : 0.f;
    }
    haar_forward(img, s, tmp);
    for (int m = 0; m < nb; m++) {
        uint32_t i, j;
        haar_unmorton((uint32_t)m, &i, &j);
        adj[m] = kept[m] ? img[j * (uint32_t)s + i] * (float)(CUBE_RES / s) : 0.f;
    }
}

/* Per block B of the 2^b x 2^b grid of a face, what was dropped integrates under w to
 * D_B = sum over dropped m of c_m <psi_m, w 1_B>: a detail finer than B lies inside one block and
 * gives c_m W_m there (its block is the top 2b bits of its position within its level's morton
 * range); the coarse ones (m < 4^b, constant on every block) give their value on B times w's
 * integral over B. Adding the piecewise constant D_B / |B|_w, expressed in the coarse coefficients
 * m < 4^b (the Haar transform of the s x s image, times 64/s), makes each block's integral exact
 * where those coefficients are kept; where some are not, what is added is the correction's
 * projection on the kept ones. b = 0 is the face correction. wsum: w summed over each block
 * (row-major s x s); x: one face's coefficients; kept: the face's kept mask; adj: [4^b] to add. */
static void block_integrals(const float *x, const uint8_t *kept, const float *W, const double *wsum, int b, float *adj) {
    double E[16];
    block_dropped(x, kept, W, wsum, b, E);
    block_adjust(E, kept, wsum, b, adj);
}

/* The mask of the n indices idx into kept[CUBE_TEXELS]. */
static void mark(uint8_t *kept, const uint32_t *idx, int n) {
    memset(kept, 0, CUBE_TEXELS);
    for (int k = 0; k < n; k++) kept[idx[k]] = 1;
}

/* Face f of the channels' sum of T/w as texels (row-major, haar_forward's layout) into img: true when it
 * is smooth (TRANSPORT_SMOOTH_JUMP) and not negative. tmp: FACE floats. */
static bool face_smooth(const float *const ch[3], int f, float *img, float *tmp) {
    const float *x[3] = { ch[0] + (size_t)f * FACE, ch[1] + (size_t)f * FACE, ch[2] + (size_t)f * FACE };
    bool any = false;
    for (int m = 0; m < FACE; m++) {   /* a non-finite channel (never from precompute) voids the texel's sum */
        float v = x[0][m] + x[1][m] + x[2][m];
        v = isfinite(v) ? v : 0.f;
        tmp[m] = v;
        any |= v != 0;
    }
    if (!any) return false;   /* nothing to correct (a face below the horizon) */
    haar_face_from_morton(tmp, CUBE_RES, img);
    haar_inverse(img, CUBE_RES, tmp);
    float mx = 0, lo = 0, jump = 0;
    for (int j = 0; j < CUBE_RES; j++)
        for (int i = 0; i < CUBE_RES; i++) {
            float v = img[j * CUBE_RES + i];
            float dx = i > 0 ? fabsf(v - img[j * CUBE_RES + i - 1]) : 0.f, dy = j > 0 ? fabsf(v - img[(j - 1) * CUBE_RES + i]) : 0.f;
            mx = v > mx ? v : mx;   /* not fmaxf: a libm call per texel without -ffinite-math-only */
            lo = v < lo ? v : lo;
            jump = dx > jump ? dx : jump;
            jump = dy > jump ? dy : jump;
        }
    return mx > 0 && lo >= -1e-4f * mx && jump <= TRANSPORT_SMOOTH_JUMP * mx;   /* lo: the transform's rounding */
}

/* The Haar coefficients of the texels img_j w_j (T_j from T/w) in morton order into H; img is used up. */
static void face_transport(float *img, const float *w, float *tmp, float *H) {
    for (int k = 0; k < FACE; k++) img[k] *= w[k];
    haar_forward(img, CUBE_RES, tmp);
    haar_face_to_morton(img, CUBE_RES, H);
}

/* See corrections.h: face_smooth per face (bit f), and face_transport of each smooth face with want_H. */
unsigned haar_face_shapes(const float *const ch[3], const float *w, bool want_H, float *scratch, float *Hc) {
    float *img = scratch, *tmp = scratch + FACE;
    unsigned smooth = 0;
    for (int f = 0; f < 6; f++) {
        if (!face_smooth(ch, f, img, tmp)) continue;
        smooth |= 1u << f;
        if (want_H) face_transport(img, w, tmp, Hc + (size_t)f * FACE);
    }
    return smooth;
}

/* For each smooth face f (bit f of smooth, H at Hc + f * FACE: face_shapes): S[c * 6 + f] = sum over
 * its m outside `in` of c_m H_m, and H0[f] = H_0, the transport's integral over the face over 64
 * (orthonormal); H0[f] = 0 elsewhere. */
static void smooth_faces(const float *const ch[3], const uint8_t *in, unsigned smooth, const float *Hc, float *S,
                         float *H0) {
    for (int f = 0; f < 6; f++) {
        for (int c = 0; c < 3; c++) S[c * 6 + f] = 0;
        H0[f] = 0;
        if (!(smooth >> f & 1)) continue;
        const float *H = Hc + (size_t)f * FACE;
        H0[f] = H[0];
        const uint8_t *out = in + (size_t)f * FACE;
        for (int c = 0; c < 3; c++) {
            const float *x = ch[c] + (size_t)f * FACE;
            double d = 0;
            for (int m0 = 0; m0 < FACE; m0 += 64) {   /* float runs of 64, branch-free for the compiler */
                float acc = 0;
                for (int m = m0; m < m0 + 64; m++) {
                    float v = x[m] * H[m];
                    acc += out[m] || !isfinite(v) ? 0.f : v;
                }
                d += acc;
            }
            S[c * 6 + f] = (float)d;
        }
    }
}

/* The faces whose correction is the smooth one: smooth (H0 != 0) with their scaling coefficient kept
 * (kept0: bit f when face f's is). The others keep the block correction. */
static unsigned smooth_mask(const float *H0, unsigned kept0) {
    unsigned mask = 0;
    for (int f = 0; f < 6; f++) mask |= (unsigned)(H0[f] != 0 && (kept0 >> f & 1)) << f;
    return mask;
}

/* The smooth faces' correction into adj[3][6][16] on the faces of mask (smooth_mask): S / H_0 on the
 * scaling coefficient, nothing on the face's other coarse coefficients. */
static void smooth_adjust(const float *S, const float *H0, unsigned mask, float *adj) {
    for (int f = 0; f < 6; f++) {
        if (!(mask >> f & 1)) continue;
        for (int c = 0; c < 3; c++) {
            float *a = adj + (c * 6 + f) * 16, d = S[c * 6 + f] / H0[f];
            memset(a, 0, 16 * sizeof *a);
            a[0] = isfinite(d) ? d : 0.f;
        }
    }
}

/* See corrections.h: block_integrals per channel and face, smooth_adjust on the smooth faces. */
void haar_block_corrections(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n,
                            unsigned shape, const float *Hc, float *scratch, float *adj) {
    const haar_tables *tb = t->policy_state;
    memset(adj, 0, 3 * 6 * 16 * sizeof *adj);
    if (!t->solid_angle) return;
    int b = t->block_level;
    PRT_CHECK(b >= 0 && b <= TRANSPORT_BLOCK_LEVEL_MAX);
    uint8_t *kept = (uint8_t *)(void *)(scratch + FACE);
    mark(kept, idx, n);
    float S[18] = { 0 }, H0[6] = { 0 };
    unsigned kept0 = 0, smooth = 0;
    if (t->smooth_faces) {   /* first: the faces it corrects need no block integrals */
        smooth_faces(ch, kept, shape, Hc, S, H0);
        for (int f = 0; f < 6; f++) kept0 |= (unsigned)kept[(size_t)f * FACE] << f;
        smooth = smooth_mask(H0, kept0);
    }
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < 6; f++)
            if (!(smooth >> f & 1))
                block_integrals(ch[c] + (size_t)f * FACE, kept + (size_t)f * FACE, tb->W, tb->wsum[b], b,
                                adj + (c * 6 + f) * 16);
    smooth_adjust(S, H0, smooth, adj);
}

/* See corrections.h. Why: which candidates a vector keeps is known only at transport_finish, so its
 * correction is split: what the coefficients outside its candidates drop is fixed now (blk, per
 * channel, face and block, and the smooth faces' S and H_0 after the norm; finish adds the candidates
 * it drops). */
void haar_block_stage(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, unsigned shape,
                      const float *Hc, float *scratch, float *blk) {
    const haar_tables *tb = t->policy_state;
    int b = t->block_level;
    PRT_CHECK(b >= 0 && b <= TRANSPORT_BLOCK_LEVEL_MAX);
    uint8_t *kept = (uint8_t *)(void *)(scratch + FACE);
    mark(kept, idx, n);
    double E[16];
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < 6; f++) {
            block_dropped(ch[c] + (size_t)f * FACE, kept + (size_t)f * FACE, tb->W, tb->wsum[b], b, E);
            for (int B = 0; B < 16; B++) blk[(c * 6 + f) * 16 + B] = (float)E[B];
        }
    float *S = blk + TRANSPORT_BLK + 1, *H0 = S + 18;
    if (t->smooth_faces) smooth_faces(ch, kept, shape, Hc, S, H0);
    else memset(S, 0, 24 * sizeof *S);
}

/* Why: a smooth face's dropped candidates are weighted by H (smooth_faces), which is not staged; the
 * candidates (a smooth face's 2N largest, by construction its shape) give it: the Haar coefficients of
 * w times their reconstruction, over vector i's candidates [k, n) of face f, into H (morton order).
 * scratch: 2 x FACE floats. */
static void candidates_transport(const prt_transport *t, size_t o, uint32_t k, uint32_t n, uint32_t f, float *scratch,
                                 float *H) {
    const haar_tables *tb = t->policy_state;
    const uint32_t *idx = t->stage_idx + o;
    const float *val = t->stage_val + 3 * o;
    float *img = scratch, *tmp = scratch + FACE;
    memset(H, 0, FACE * sizeof *H);
    for (; k < n && idx[k] / FACE == f; k++) H[idx[k] % FACE] = val[3 * k] + val[3 * k + 1] + val[3 * k + 2];
    haar_face_from_morton(H, CUBE_RES, img);
    haar_inverse(img, CUBE_RES, tmp);
    face_transport(img, tb->w, tmp, H);
}

/* The block of level b that detail m (>= 4^b within its face) lies in (block_integrals' rule). */
static int block_of(uint32_t m, int b) {
    int l = transport_level(m);
    uint32_t lo = 1u << 2 * (l - 1), sh = (uint32_t)(2 * (l - 1 - b)), bi, bj;
    haar_unmorton((m & (lo - 1)) >> sh, &bi, &bj);
    return (int)(bj * (1u << b) + bi);
}

/* See corrections.h. The staged non-candidates' part (block_stage) plus what each dropped candidate
 * adds: a coarse one (m < 4^b) its value on every block, a finer one c_m W_m on its block, and on a
 * smooth face c_m H_m (H from the candidates: candidates_transport). */
void haar_budget_corrections(const prt_transport *t, int i, const uint8_t *keep, float *adj) {
    memset(adj, 0, TRANSPORT_BLK * sizeof *adj);
    if (!t->solid_angle) return;
    const haar_tables *tb = t->policy_state;
    size_t o = (size_t)i * t->N;
    const uint32_t *idx = t->stage_idx + o;
    const float *val = t->stage_val + 3 * o;
    float coarse[TRANSPORT_BLK] = { 0 };
    int b = t->block_level, nb = 1 << 2 * b;
    PRT_CHECK(b >= 0 && b <= TRANSPORT_BLOCK_LEVEL_MAX);
    double E[TRANSPORT_BLK];
    uint8_t kept[6 * 16] = { 0 };
    const float *blk = t->stage_blk + (size_t)i * TRANSPORT_STAGE, *H0 = blk + TRANSPORT_BLK + 1 + 18;
    float S[18], H[FACE], scr[2 * FACE];
    for (int k = 0; k < TRANSPORT_BLK; k++) E[k] = blk[k];
    memcpy(S, blk + TRANSPORT_BLK + 1, sizeof S);
    for (uint32_t k = 0, face = 6; k < t->stage_count[i]; k++) {
        uint32_t m = idx[k] % FACE, f = idx[k] / FACE;
        if (f != face && H0[f] != 0) candidates_transport(t, o, k, t->stage_count[i], f, scr, H);
        face = f;
        if (keep[k]) {
            if (m < 16) kept[f * 16 + m] = 1;
            continue;
        }
        for (int ch = 0; ch < 3; ch++) {
            if (m < (uint32_t)nb) coarse[(ch * 6 + f) * 16 + m] = val[3 * k + ch];
            else E[(ch * 6 + f) * 16 + block_of(m, b)] += (double)val[3 * k + ch] * tb->W[m];
            if (H0[f] != 0) S[ch * 6 + f] += val[3 * k + ch] * H[m];
        }
    }
    unsigned kept0 = 0;
    for (int f = 0; f < 6; f++) kept0 |= (unsigned)kept[f * 16] << f;
    unsigned smooth = smooth_mask(H0, kept0);   /* H0 all 0 without smooth_faces */
    for (int q = 0; q < 18; q++) {   /* q = channel * 6 + face */
        if (smooth >> (q % 6) & 1) continue;
        block_coarse(coarse + q * 16, tb->wsum[b], b, E + q * 16);
        block_adjust(E + q * 16, kept + (q % 6) * 16, tb->wsum[b], b, adj + q * 16);
    }
    smooth_adjust(S, H0, smooth, adj);
}
