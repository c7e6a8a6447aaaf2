/* haar.c - orthonormal nonstandard 2D Haar transform of cube-map faces (section 4.1.1).
 *
 * Transport vectors (Eq. 3 sampled on the cube) and the light vector are
 * projected onto the same orthonormal wavelet basis, so Eq. 5's inner product
 * can be taken between the sparse (non-linearly approximated) coefficient sets.
 * One level maps each 2x2 block
 *     a b        s  = (a + b + c + d) / 2      (average, stays in the top-left quadrant)
 *     c d   ->   dx = (a - b + c - d) / 2      (at (i + h, j))
 *                dy = (a + b - c - d) / 2      (at (i, j + h))
 *                dd = (a - b - c + d) / 2      (at (i + h, j + h))
 * which is an orthogonal 4x4 matrix (rows of +-1/2), so the whole transform is
 * orthonormal: after log2(res) levels the scaling coefficient is sum / res.
 *
 * The wavelet index is face*res^2 + morton(i, j) of the quadrant position, so
 * every coarse level precedes finer ones within a face (haar.h).
 *
 * Speed: each level streams its n x n region once into tmp and copies it back;
 * a 64x64 face is 1,365 block operations (about 2 us; the Morton scatter of a
 * whole cube adds a few more). */
#include "haar.h"
#include <math.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

/* One forward level on the top-left n x n region of face (row stride res). */
static void forward_level(float *restrict face, int res, int n, float *restrict tmp) {
    int h = n / 2;
    for (int j = 0; j < h; j++) {
        const float *r0 = face + (size_t)(2 * j) * res, *r1 = r0 + res;
        float *s = tmp + (size_t)j * res, *dy = tmp + (size_t)(j + h) * res;
        float *dx = s + h, *dd = dy + h;
        for (int i = 0; i < h; i++) {
            float a = r0[2 * i], b = r0[2 * i + 1], c = r1[2 * i], d = r1[2 * i + 1];
            float ab = a + b, cd = c + d, amb = a - b, cmd = c - d;
            s[i] = 0.5f * (ab + cd);
            dx[i] = 0.5f * (amb + cmd);
            dy[i] = 0.5f * (ab - cd);
            dd[i] = 0.5f * (amb - cmd);
        }
    }
    for (int j = 0; j < n; j++) memcpy(face + (size_t)j * res, tmp + (size_t)j * res, sizeof(float) * (size_t)n);
}

/* One inverse level: top-left n x n region of face in quadrant layout -> averages of level n. */
static void inverse_level(float *restrict face, int res, int n, float *restrict tmp) {
    int h = n / 2;
    for (int j = 0; j < h; j++) {
        const float *s = face + (size_t)j * res, *dy = face + (size_t)(j + h) * res;
        const float *dx = s + h, *dd = dy + h;
        float *r0 = tmp + (size_t)(2 * j) * res, *r1 = r0 + res;
        for (int i = 0; i < h; i++) {
            float sp = s[i] + dy[i], sm = s[i] - dy[i], xp = dx[i] + dd[i], xm = dx[i] - dd[i];
            r0[2 * i] = 0.5f * (sp + xp);
            r0[2 * i + 1] = 0.5f * (sp - xp);
            r1[2 * i] = 0.5f * (sm + xm);
            r1[2 * i + 1] = 0.5f * (sm - xm);
        }
    }
    for (int j = 0; j < n; j++) memcpy(face + (size_t)j * res, tmp + (size_t)j * res, sizeof(float) * (size_t)n);
}

/* In-place forward transform into quadrant layout; tmp[res*res] is scratch. */
void haar_forward(float *face, int res, float *tmp) {
    PRT_CHECK(res > 0 && (res & (res - 1)) == 0);
    for (int n = res; n >= 2; n /= 2) forward_level(face, res, n, tmp);
}

/* In-place inverse of haar_forward; tmp[res*res] is scratch. */
void haar_inverse(float *face, int res, float *tmp) {
    PRT_CHECK(res > 0 && (res & (res - 1)) == 0);
    for (int n = 2; n <= res; n *= 2) inverse_level(face, res, n, tmp);
}

/* Bits 0..15 of x moved to the even bit positions 0, 2, ..., 30. */
static uint32_t spread16(uint32_t x) {
    x &= 0xFFFFu;
    x = (x | (x << 8)) & 0x00FF00FFu;
    x = (x | (x << 4)) & 0x0F0F0F0Fu;
    x = (x | (x << 2)) & 0x33333333u;
    x = (x | (x << 1)) & 0x55555555u;
    return x;
}

/* Inverse of spread16: the even bits of x packed into bits 0..15. */
static uint32_t compact16(uint32_t x) {
    x &= 0x55555555u;
    x = (x | (x >> 1)) & 0x33333333u;
    x = (x | (x >> 2)) & 0x0F0F0F0Fu;
    x = (x | (x >> 4)) & 0x00FF00FFu;
    x = (x | (x >> 8)) & 0x0000FFFFu;
    return x;
}

/* Z-order index: bit k of i -> bit 2k, bit k of j -> bit 2k+1 (i, j < 65536). */
uint32_t haar_morton(uint32_t i, uint32_t j) { return spread16(i) | (spread16(j) << 1); }

/* Inverse of haar_morton. */
void haar_unmorton(uint32_t m, uint32_t *i, uint32_t *j) {
    *i = compact16(m);
    *j = compact16(m >> 1);
}

/* Morton order is tiled: indices 4k..4k+3 are the 2x2 block at (2i', 2j') with
 * (i', j') = unmorton(k), in the order (0,0) (1,0) (0,1) (1,1). So the scatter moves
 * whole 2x2 blocks (one 16-byte store of two 8-byte row pieces), and within an 8x8
 * tile (16 blocks) the block offsets are precomputed: boff[16] = 2j'*res + 2i'. */
static void block_offsets(int res, int *boff) {
    for (uint32_t k = 0; k < 16; k++) {
        uint32_t i, j;
        haar_unmorton(k, &i, &j);
        boff[k] = (int)(2 * j) * res + (int)(2 * i);
    }
}

/* Quadrant layout (row-major) -> Morton order for one face. */
static void face_to_morton(const float *restrict face, int res, float *restrict out) {
    if (res < 8) {
        for (uint32_t m = 0; m < (uint32_t)(res * res); m++) {
            uint32_t i, j;
            haar_unmorton(m, &i, &j);
            out[m] = face[j * res + i];
        }
        return;
    }
    int boff[16];
    block_offsets(res, boff);
    for (uint32_t t = 0; t < (uint32_t)(res * res) / 64; t++, out += 64) {
        uint32_t ti, tj;
        haar_unmorton(t, &ti, &tj);
        const float *base = face + (size_t)(8 * tj) * res + 8 * ti;
        for (int k = 0; k < 16; k++) {
            const float *p = base + boff[k];
#ifdef __SSE2__
            __m128 top = _mm_castpd_ps(_mm_load_sd((const double *)(const void *)p));
            __m128 bot = _mm_castpd_ps(_mm_load_sd((const double *)(const void *)(p + res)));
            _mm_storeu_ps(out + 4 * k, _mm_movelh_ps(top, bot));
#else
            out[4 * k] = p[0]; out[4 * k + 1] = p[1]; out[4 * k + 2] = p[res]; out[4 * k + 3] = p[res + 1];
#endif
        }
    }
}

/* Morton order -> quadrant layout (row-major) for one face. */
static void morton_to_face(const float *restrict in, int res, float *restrict face) {
    if (res < 8) {
        for (uint32_t m = 0; m < (uint32_t)(res * res); m++) {
            uint32_t i, j;
            haar_unmorton(m, &i, &j);
            face[j * res + i] = in[m];
        }
        return;
    }
    int boff[16];
    block_offsets(res, boff);
    for (uint32_t t = 0; t < (uint32_t)(res * res) / 64; t++, in += 64) {
        uint32_t ti, tj;
        haar_unmorton(t, &ti, &tj);
        float *base = face + (size_t)(8 * tj) * res + 8 * ti;
        for (int k = 0; k < 16; k++) {
            float *p = base + boff[k];
            p[0] = in[4 * k]; p[1] = in[4 * k + 1]; p[res] = in[4 * k + 2]; p[res + 1] = in[4 * k + 3];
        }
    }
}

void haar_face_to_morton(const float *face, int res, float *morton) { face_to_morton(face, res, morton); }
void haar_face_from_morton(const float *morton, int res, float *face) { morton_to_face(morton, res, face); }

/* Six faces: texels[f*res^2 + j*res + i] -> wavelet[f*res^2 + morton(i, j)] of the transform. */
void haar_cube_forward(const float *texels, int res, float *wavelet, float *tmp) {
    haar_cube_forward_weighted(texels, res, NULL, wavelet, tmp);
}

/* See haar.h; w NULL: unweighted. */
void haar_cube_forward_weighted(const float *texels, int res, const float *w, float *wavelet, float *tmp) {
    size_t nn = (size_t)res * res;
    for (int f = 0; f < 6; f++) {
        if (w)
            for (size_t k = 0; k < nn; k++) tmp[k] = texels[f * nn + k] * w[k];
        else
            memcpy(tmp, texels + f * nn, sizeof(float) * nn);
        haar_forward(tmp, res, tmp + nn);
        face_to_morton(tmp, res, wavelet + f * nn);
    }
}

/* Inverse of haar_cube_forward: wavelet-index order -> row-major texels. */
void haar_cube_inverse(const float *wavelet, int res, float *texels, float *tmp) {
    size_t nn = (size_t)res * res;
    for (int f = 0; f < 6; f++) {
        morton_to_face(wavelet + f * nn, res, texels + f * nn);
        haar_inverse(texels + f * nn, res, tmp);
    }
}

void haar_face_solid_angle(float *w, int res, bool inverse) {
    const float h = 2.f / (float)res, a = h * h;
    for (int j = 0; j < res; j++)
        for (int i = 0; i < res; i++) {
            float x = ((float)i + 0.5f) * h - 1.f, y = ((float)j + 0.5f) * h - 1.f, r2 = 1.f + x * x + y * y;
            float r3 = r2 * sqrtf(r2);
            w[j * res + i] = inverse ? r3 / a : a / r3;
        }
}

/* Transformed in a row-major face (tmp), then reordered by morton index into W. */
void haar_face_solid_angle_coeffs(float *W, int res, float *tmp) {
    haar_face_solid_angle(tmp, res, false);
    haar_forward(tmp, res, W);
    face_to_morton(tmp, res, W);
}
