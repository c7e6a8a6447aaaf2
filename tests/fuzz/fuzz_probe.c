/* fuzz_probe.c - probe layouts on in-memory images (probe_from_image): the first 4 bytes pick
 * the width and height (1..16), the channels (3 or 4) and the layout (auto, latlong, angular,
 * vcross, hcross, cross); the rest are the texels' raw floats (NaN, Inf, negatives, denormals
 * included), zero-padded. An accepted probe: every texel finite and >= 0, max_value their
 * maximum, and its lookups (probe_eval, probe_pixel_dir, a 2 x 2 probe_to_cube) finite; a
 * refused one: one line naming the probe.
 * Sized for millions of inputs: 16 x 16 holds every layout's shapes (crosses with faces of 1 to
 * 4 pixels) at a quarter of 64 x 64's per-pixel work (the refinement's scan, the clamp, the
 * checks), and inputs stop at 4,100 bytes (fuzz_probe.options: the largest image filled). The
 * cube is resampled at 1 sub-sample per texel, and the fuzz build caps the refinement near bright
 * pixels at 4 x 4 sub-samples (PROBE_MAX_SS, Makefile) instead of 64 x 64: the same code paths,
 * without the 37,000 lookups a bright pixel at a pole or an angular map's rim costs. */
#include "fuzz.h"
#include "cubemap.h"
#include "probe.h"

#define FUZZ_PROBE_NAME "fuzz-probe.exr"

static void check_probe(const prt_probe *p) {
    const prt_image *im = &p->img;
    FUZZ_REQUIRE(im->c == 3 && im->w > 0 && im->h > 0, "probe image %dx%dx%d", im->w, im->h, im->c);
    float mx = 0;
    for (size_t i = 0; i < (size_t)im->w * im->h * 3; i++) {
        FUZZ_REQUIRE(isfinite(im->data[i]) && im->data[i] >= 0, "texel %zu = %g", i, (double)im->data[i]);
        if (im->data[i] > mx) mx = im->data[i];
    }
    FUZZ_REQUIRE(p->max_value == mx, "max_value %g, largest texel %g", (double)p->max_value, (double)mx);
    static const float dirs[5][3] = { { 0, 1, 0 }, { 0, -1, 0 }, { 1, 0, 0 }, { 0, 0, -1 }, { 0.48f, 0.6f, -0.64f } };
    for (int i = 0; i < 5; i++) {
        float c[3];
        probe_eval(p, dirs[i], c);
        for (int k = 0; k < 3; k++) FUZZ_REQUIRE(isfinite(c[k]) && c[k] >= 0, "probe_eval = %g", (double)c[k]);
    }
    for (int y = 0; y < im->h; y += 7)
        for (int x = 0; x < im->w; x += 7) {
            float d[3], dw;
            if (!probe_pixel_dir(p, x, y, d, &dw)) continue;
            double l = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
            FUZZ_REQUIRE(fabs(l - 1) < 1e-3 && isfinite(dw) && dw >= 0, "pixel %d,%d: |d| %g, solid angle %g", x, y, l, (double)dw);
        }
    enum { res = 2 };
    float cube[6 * res * res * 3];
    probe_to_cube(p, res, NULL, 1, cube);
    for (int i = 0; i < 6 * res * res * 3; i++) FUZZ_REQUIRE(isfinite(cube[i]) && cube[i] >= 0, "cube texel %d = %g", i, (double)cube[i]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 4) return 0;
    static const probe_layout layouts[6] = { PROBE_AUTO, PROBE_LATLONG, PROBE_ANGULAR, PROBE_VCROSS, PROBE_HCROSS, PROBE_CROSS };
    int w = 1 + data[0] % 16, h = 1 + data[1] % 16, c = data[2] & 1 ? 4 : 3;
    probe_layout layout = layouts[data[3] % 6];
    prt_image im = { 0 };
    prt_error err = { { 0 } };
    if (image_alloc(&im, w, h, c, &err)) abort();
    size_t n = (size_t)w * h * c, have = (size - 4) / sizeof(float);
    memcpy(im.data, data + 4, (have < n ? have : n) * sizeof(float));
    prt_probe p = { 0 };
    if (probe_from_image(&im, layout, FUZZ_PROBE_NAME, &p, &err) == 0) check_probe(&p);
    else fuzz_check_error(&err, FUZZ_PROBE_NAME);
    image_free(&im);
    probe_free(&p);
    return 0;
}
