/* texture.c - base-colour textures: sRGB bytes, their linear values, bilinear samples and
 * triangle means (texture.h). */
#include "texture.h"
#include "image.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The sRGB transfer function and its inverse (IEC 61966-2-1). */
static float srgb_decode(float c) { return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f); }
static float srgb_encode(float x) { return x <= 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1.f / 2.4f) - 0.055f; }

void texture_free(scene_texture *t) {
    free(t->srgb);
    free(t->lin);
    memset(t, 0, sizeof *t);
}

int texture_from_srgb(scene_texture *t, const char *name, int w, int h, const uint8_t *srgb, prt_error *err) {
    memset(t, 0, sizeof *t);
    if (w < 1 || h < 1 || w > TEXTURE_MAX_SIDE || h > TEXTURE_MAX_SIDE)
        return prt_fail(err, "%s: texture size %dx%d outside 1..%d", name, w, h, TEXTURE_MAX_SIDE);
    size_t n = 3 * (size_t)w * h;
    t->srgb = malloc(n);
    t->lin = t->srgb ? malloc(n * sizeof *t->lin) : NULL;
    if (!t->lin) {
        texture_free(t);
        return prt_fail(err, "%s: out of memory for a %dx%d texture", name, w, h);
    }
    float lut[256];
    for (int i = 0; i < 256; i++) lut[i] = srgb_decode(i / 255.f);
    memcpy(t->srgb, srgb, n);
    for (size_t i = 0; i < n; i++) t->lin[i] = lut[srgb[i]];
    t->w = w, t->h = h;
    snprintf(t->name, sizeof t->name, "%.127s", name);
    return 0;
}

int texture_from_image(scene_texture *t, const char *name, const prt_image *im, prt_error *err) {
    memset(t, 0, sizeof *t);
    if (im->w < 1 || im->h < 1 || im->w > TEXTURE_MAX_SIDE || im->h > TEXTURE_MAX_SIDE)
        return prt_fail(err, "%s: texture size %dx%d outside 1..%d", name, im->w, im->h, TEXTURE_MAX_SIDE);
    size_t n = (size_t)im->w * im->h;
    uint8_t *b = malloc(3 * n);
    if (!b) return prt_fail(err, "%s: out of memory for a %dx%d texture", name, im->w, im->h);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float x = im->data[i * (size_t)im->c + c];
            x = x > 0 ? (x < 1 ? x : 1) : 0;   /* also a NaN: 0 */
            b[3 * i + c] = (uint8_t)lrintf(255.f * srgb_encode(x));
        }
    int rc = texture_from_srgb(t, name, im->w, im->h, b, err);
    free(b);
    return rc;
}

/* x mod n for the repeat wrap (n > 0). */
static int wrap(long x, int n) {
    long r = x % n;
    return (int)(r < 0 ? r + n : r);
}

void texture_sample(const scene_texture *t, float u, float v, float rgb[3]) {
    if (!isfinite(u) || !isfinite(v)) u = v = 0;
    /* texel centres at (i + 0.5) / w; row 0 at v = 1; fractions in double keep large u exact enough */
    double x = (double)u * t->w - 0.5, y = (1.0 - (double)v) * t->h - 0.5;
    double fx = floor(x), fy = floor(y);
    float ax = (float)(x - fx), ay = (float)(y - fy);
    long x0 = (long)fmod(fx, 1 << 30), y0 = (long)fmod(fy, 1 << 30);
    int xs[2] = { wrap(x0, t->w), wrap(x0 + 1, t->w) }, ys[2] = { wrap(y0, t->h), wrap(y0 + 1, t->h) };
    for (int c = 0; c < 3; c++) {
        const float *L = t->lin;
        float a = L[3 * ((size_t)ys[0] * t->w + xs[0]) + c], b = L[3 * ((size_t)ys[0] * t->w + xs[1]) + c];
        float d = L[3 * ((size_t)ys[1] * t->w + xs[0]) + c], e = L[3 * ((size_t)ys[1] * t->w + xs[1]) + c];
        rgb[c] = (1 - ay) * ((1 - ax) * a + ax * b) + ay * ((1 - ax) * d + ax * e);
    }
}

void texture_mean_triangle(const scene_texture *t, const float uv[6], float rgb[3]) {
    double area = 0.5 * fabs(((double)uv[2] - uv[0]) * ((double)uv[5] - uv[1]) - ((double)uv[4] - uv[0]) * ((double)uv[3] - uv[1]));
    double texels = area * t->w * t->h;
    /* n^2 equal-area sub-triangles, each sampled at its centroid: about one sample a texel */
    int n = texels > 16 ? (int)ceil(sqrt(texels)) : 4;
    if (!(n <= 64)) n = 64;
    double acc[3] = { 0, 0, 0 };
    for (int i = 0; i < n; i++)
        for (int j = 0; i + j < n; j++)
            for (int up = 0; up < 2 - (i + j == n - 1); up++) {
                double b1 = (i + (up ? 2.0 : 1.0) / 3) / n, b2 = (j + (up ? 2.0 : 1.0) / 3) / n, b0 = 1 - b1 - b2;
                float s[3];
                texture_sample(t, (float)(b0 * uv[0] + b1 * uv[2] + b2 * uv[4]), (float)(b0 * uv[1] + b1 * uv[3] + b2 * uv[5]), s);
                for (int c = 0; c < 3; c++) acc[c] += s[c];
            }
    for (int c = 0; c < 3; c++) rgb[c] = (float)(acc[c] / ((double)n * n));
}
