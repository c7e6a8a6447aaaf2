/* probe.c - HDR light probes: layouts, bilinear lookup, resampling to the
 * lighting cube map, and a procedural sky (see probe.h).
 *
 * At run time the paper samples the environment onto a 6 x 64 x 64 cube map
 * before the Haar transform (section 4.3). A 1024 x 512 latlong probe has about
 * four times the angular resolution of a 64-res cube texel, so point sampling
 * would alias (a sun smaller than a texel could vanish or flicker as the light
 * rotates); probe_to_cube therefore takes the solid-angle-weighted mean over
 * each texel, from ss x ss stratified sub-samples, each bilinearly filtered.
 * The sub-sample weights are the exact solid angles of the sub-squares (the
 * gnomonic area formula also used in cubemap.c), normalized by their sum, the
 * texel's solid angle, so a constant probe resamples to exactly that constant.
 * Sub-samples about a pixel apart still step over a sun one pixel wide (its
 * power came out anywhere between 0 and 2x), so texels reached by pixels far
 * brighter than the mean are re-sampled with sub-samples a quarter pixel apart
 * (refine_map below): on the eight 1024 x 512 test probes the cube then holds
 * the probe's total power to 0.1%, and a sub-pixel sun anywhere on a 512 to
 * 4096 wide probe to 2%.
 *
 * Layouts and their pixel <-> direction maps (world frame, y up, -z "front"
 * at the centre of the latlong and of the angular map):
 *   latlong  u = 0.5 + atan2(x, -z)/(2 pi), v = acos(y)/pi; wraps in u.
 *   angular  Debevec's light probe: r = acos(-z)/pi, (u, v) = (0.5 + 0.5 r x/|xy|,
 *            0.5 - 0.5 r y/|xy|); pixels whose centre lies outside the unit
 *            circle are invalid.
 *   crosses  face size F = width/3 (vertical) or width/4 (horizontal). Each face
 *            is an unfolded cube face seen from inside, with face coordinates
 *            s (right) and t (down) in [-1,1] and direction s*a + t*b + c:
 *
 *            vertical cross (3F x 4F)         horizontal cross (4F x 3F)
 *                 . +Y  .                          . +Y  .   .
 *                -X -Z +X                         -X -Z +X  +Z
 *                 . -Y  .                          . -Y  .   .
 *                 . +Z  .   (upside down)
 *
 *            -Z (front) (s, -t, -1)   +X (right) (1, -t, s)   -X (left) (-1, -t, -s)
 *            +Y (up)    (s, 1, -t)    -Y (down)  (s, -1, t)
 *            +Z (back)  (s, t, 1) in the vertical cross, (-s, -t, 1) in the horizontal one.
 *            Each face's edges meet its neighbours in the cross continuously, the usual
 *            arrangement of Debevec's vertical-cross probes (the back face
 *            below the down face, hence upside down). Pixels in the empty cells
 *            are invalid. Bilinear lookups clamp to the face they fall in.
 *
 * Sun of the procedural sky: its power L_sun * 2 pi (1 - cos r) must not
 * depend on how many pixels the disc covers, or a sun narrower than a pixel
 * would flicker or vanish. Each pixel near the sun gets its covered fraction
 * c_i from 8 x 8 equal-solid-angle sub-samples; the disc's power is then
 * distributed as L_sun Omega_disc c_i / sum_j(c_j Omega_j), which integrates to
 * exactly L_sun Omega_disc. If the disc is so small that no sub-sample hits it,
 * all of its power goes into the pixel containing its centre. */
#include "probe.h"
#include "cubemap.h"
#include "vec3.h"
#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define PI_D 3.14159265358979323846

/* One face of a cross layout: cell (col, row) and direction s*a + t*b + c. */
typedef struct cross_face {
    int col, row;
    float a[3], b[3], c[3];
} cross_face;

static const cross_face VCROSS[6] = {
    { 1, 0, { 1, 0, 0 }, { 0, 0, -1 }, { 0, 1, 0 } },    /* +Y, its bottom edge meets -Z's top edge */
    { 0, 1, { 0, 0, -1 }, { 0, -1, 0 }, { -1, 0, 0 } },  /* -X */
    { 1, 1, { 1, 0, 0 }, { 0, -1, 0 }, { 0, 0, -1 } },   /* -Z, front */
    { 2, 1, { 0, 0, 1 }, { 0, -1, 0 }, { 1, 0, 0 } },    /* +X */
    { 1, 2, { 1, 0, 0 }, { 0, 0, 1 }, { 0, -1, 0 } },    /* -Y, its top edge meets -Z's bottom edge */
    { 1, 3, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } },     /* +Z, below -Y: upside down */
};
static const cross_face HCROSS[6] = {
    { 1, 0, { 1, 0, 0 }, { 0, 0, -1 }, { 0, 1, 0 } },    /* +Y */
    { 0, 1, { 0, 0, -1 }, { 0, -1, 0 }, { -1, 0, 0 } },  /* -X */
    { 1, 1, { 1, 0, 0 }, { 0, -1, 0 }, { 0, 0, -1 } },   /* -Z */
    { 2, 1, { 0, 0, 1 }, { 0, -1, 0 }, { 1, 0, 0 } },    /* +X */
    { 3, 1, { -1, 0, 0 }, { 0, -1, 0 }, { 0, 0, 1 } },   /* +Z, right of +X */
    { 1, 2, { 1, 0, 0 }, { 0, 0, 1 }, { 0, -1, 0 } },    /* -Y */
};

/* Cross face table and face size of a cross probe (NULL if not a cross). */
static const cross_face *cross_table(const prt_probe *p, int *F) {
    if (p->layout == PROBE_VCROSS) {
        int a = p->img.w / 3, b = p->img.h / 4;
        *F = a < b ? a : b;
        return VCROSS;
    }
    if (p->layout == PROBE_HCROSS) {
        int a = p->img.w / 4, b = p->img.h / 3;
        *F = a < b ? a : b;
        return HCROSS;
    }
    *F = 0;
    return NULL;
}

/* Parses a layout name (case-insensitive). Returns 0, or -1 if unknown. */
int probe_parse_layout(const char *s, probe_layout *out) {
    static const struct { const char *name; probe_layout l; } names[] = {
        { "auto", PROBE_AUTO },       { "latlong", PROBE_LATLONG }, { "latlon", PROBE_LATLONG },
        { "equirect", PROBE_LATLONG }, { "angular", PROBE_ANGULAR }, { "probe", PROBE_ANGULAR },
        { "vcross", PROBE_VCROSS },   { "hcross", PROBE_HCROSS },   { "cross", PROBE_CROSS },
    };
    if (!s) return -1;
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcasecmp(s, names[i].name) == 0) {
            *out = names[i].l;
            return 0;
        }
    return -1;
}

/* Static name of a layout. */
const char *probe_layout_name(probe_layout l) {
    switch (l) {
    case PROBE_LATLONG: return "latlong";
    case PROBE_ANGULAR: return "angular";
    case PROBE_VCROSS: return "vcross";
    case PROBE_HCROSS: return "hcross";
    case PROBE_CROSS: return "cross";
    default: return "auto";
    }
}

/* Is w:h within 1% of num:den? */
static bool aspect_is(int w, int h, int num, int den) {
    double r = (double)w * den / ((double)h * num);
    return r > 0.99 && r < 1.01;
}

/* Resolves AUTO/CROSS from the image size and checks the size suits the layout.
 * Returns 0, or -1 with err naming `name`. */
static int resolve_layout(int w, int h, probe_layout want, const char *name, probe_layout *out, prt_error *err) {
    probe_layout l = want;
    if (l == PROBE_AUTO) {
        if (aspect_is(w, h, 2, 1)) l = PROBE_LATLONG;
        else if (aspect_is(w, h, 1, 1)) l = PROBE_ANGULAR;
        else if (aspect_is(w, h, 3, 4)) l = PROBE_VCROSS;
        else if (aspect_is(w, h, 4, 3)) l = PROBE_HCROSS;
        else
            return prt_fail(err,
                            "%s: cannot tell the probe layout from its size %dx%d (2:1 latlong, 1:1 angular, "
                            "3:4 or 4:3 cross); give the layout explicitly",
                            name, w, h);
    } else if (l == PROBE_CROSS) {
        l = h > w ? PROBE_VCROSS : PROBE_HCROSS;
    }
    if (l == PROBE_VCROSS || l == PROBE_HCROSS) {
        int cols = l == PROBE_VCROSS ? 3 : 4, rows = l == PROBE_VCROSS ? 4 : 3;
        if (!aspect_is(w, h, cols, rows) || w / cols < 2 || h / rows < 2)
            return prt_fail(err, "%s: %dx%d is not a %s cross (%d:%d)", name, w, h,
                            l == PROBE_VCROSS ? "vertical" : "horizontal", cols, rows);
    } else if (w < 2 || h < 2) {
        return prt_fail(err, "%s: %dx%d is too small for a probe", name, w, h);
    }
    *out = l;
    return 0;
}

/* Clamps negative and non-finite channels to 0, counting the texels, and finds the maximum. */
static void clamp_texels(prt_probe *p) {
    size_t n = (size_t)p->img.w * p->img.h;
    float *d = p->img.data, mx = 0.f;
    long neg = 0, nonfin = 0;
    for (size_t i = 0; i < n; i++) {
        bool had_neg = false, had_nf = false;
        for (int ch = 0; ch < 3; ch++) {
            float v = d[3 * i + ch];
            if (!isfinite(v)) { had_nf = true; v = 0.f; }
            else if (v < 0.f) { had_neg = true; v = 0.f; }
            d[3 * i + ch] = v;
            if (v > mx) mx = v;
        }
        neg += had_neg;
        nonfin += had_nf;
    }
    p->clamped_negative = neg;
    p->clamped_nonfinite = nonfin;
    p->max_value = mx;
}

/* The share of the probe's light its negative channels hold, by solid angle: the sum of -v omega
 * over the negative channels over the sum of |v| omega over all finite ones (probe.h); 0 when no
 * channel is negative. Pixels outside the layout's valid area light nothing and count for neither. */
static double negative_share(const prt_probe *p) {
    size_t n = 3 * (size_t)p->img.w * p->img.h, i = 0;
    const float *d = p->img.data;
    while (i < n && !(d[i] < 0.f && isfinite(d[i]))) i++;
    if (i == n) return 0;   /* the common case: one cheap scan, no solid angles */
    double neg = 0, all = 0;
    for (int y = 0; y < p->img.h; y++)
        for (int x = 0; x < p->img.w; x++) {
            float dir[3], om;
            if (!probe_pixel_dir(p, x, y, dir, &om)) continue;
            const float *t = d + 3 * ((size_t)y * p->img.w + x);
            for (int ch = 0; ch < 3; ch++) {
                if (!isfinite(t[ch])) continue;
                if (t[ch] < 0.f) neg -= (double)t[ch] * om;
                all += fabs((double)t[ch]) * om;
            }
        }
    return all > 0 ? neg / all : 0;
}

/* Takes ownership of *img (zeroed on return, freed on failure). Returns 0 or -1. */
int probe_from_image(prt_image *img, probe_layout layout, const char *name, prt_probe *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (!name) name = "probe";
    if (!img || !img->data || img->w <= 0 || img->h <= 0 || (img->c != 3 && img->c != 4)) {
        if (img) image_free(img);
        return prt_fail(err, "%s: empty probe image", name);
    }
    probe_layout l = PROBE_AUTO;
    if (resolve_layout(img->w, img->h, layout, name, &l, err)) {
        image_free(img);
        return -1;
    }
    out->img = *img;
    memset(img, 0, sizeof *img);
    if (out->img.c == 4) {   /* drop alpha in place */
        size_t n = (size_t)out->img.w * out->img.h;
        float *d = out->img.data;
        for (size_t i = 0; i < n; i++) {
            d[3 * i] = d[4 * i];
            d[3 * i + 1] = d[4 * i + 1];
            d[3 * i + 2] = d[4 * i + 2];
        }
        out->img.c = 3;
    }
    out->layout = l;
    out->clamped_negative_share = negative_share(out);
    clamp_texels(out);
    return 0;
}

/* Loads path with OIIO and makes it a probe. Returns 0 or -1 (err names the file). */
int probe_load(const char *path, probe_layout layout, prt_probe *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    prt_image img;
    if (image_read(path, &img, err)) return -1;
    return probe_from_image(&img, layout, path, out, err);
}

/* Frees the probe's image and zeroes it (NULL is fine). */
/* See probe.h. */
float probe_exposure(const prt_probe *p, const float R[9]) {
    enum { RES = 32 };
    float *rgb = malloc(sizeof(float) * 3 * 6 * RES * RES);
    if (!rgb) return 0;
    probe_to_cube(p, RES, R, 0, rgb);
    double e = 0;
    for (int t = 0; t < 6 * RES * RES; t++) {
        float d[3];
        cube_texel_dir(RES, t, d);
        int ij = t % (RES * RES);
        double lum = 0.2126 * rgb[3 * t] + 0.7152 * rgb[3 * t + 1] + 0.0722 * rgb[3 * t + 2];
        if (d[1] > 0 && isfinite(lum)) e += lum * d[1] * cube_texel_solid_angle(RES, ij % RES, ij / RES);
    }
    free(rgb);
    if (!(e > 0)) return 0;
    double stops = -log2(e / M_PI);
    return (float)(stops > PROBE_EXPOSURE_MAX ? PROBE_EXPOSURE_MAX : stops < -PROBE_EXPOSURE_MAX ? -PROBE_EXPOSURE_MAX : stops);
}

void probe_free(prt_probe *p) {
    if (!p) return;
    image_free(&p->img);
    memset(p, 0, sizeof *p);
}

/* ---- lookup ---------------------------------------------------------------------------- */

static inline const float *texel(const prt_probe *p, int x, int y) { return p->img.data + 3 * ((size_t)y * p->img.w + x); }

/* Is pixel (x, y) of an angular map inside the circle (by its centre)? */
static inline bool angular_valid(int w, int h, int x, int y) {
    double a = 2.0 * (x + 0.5) / w - 1.0, b = 2.0 * (y + 0.5) / h - 1.0;
    return a * a + b * b <= 1.0;
}

/* Bilinear latlong lookup: wraps in u, clamps at the poles. */
static void eval_latlong(const prt_probe *p, const float d[3], float rgb[3]) {
    int w = p->img.w, h = p->img.h;
    float y = d[1] > 1.f ? 1.f : (d[1] < -1.f ? -1.f : d[1]);
    float u = 0.5f + atan2f(d[0], -d[2]) * (float)(0.5 / PI_D), v = acosf(y) * (float)(1.0 / PI_D);
    float fx = u * (float)w - 0.5f, fy = v * (float)h - 0.5f;
    float x0f = floorf(fx), y0f = floorf(fy);
    float tx = fx - x0f, ty = fy - y0f;
    int x0 = (int)x0f % w;
    if (x0 < 0) x0 += w;
    int x1 = x0 + 1 == w ? 0 : x0 + 1;
    int y0 = (int)y0f, y1 = y0 + 1;
    if (y0 < 0) y0 = 0;
    if (y1 < 0) y1 = 0;
    if (y0 > h - 1) y0 = h - 1;
    if (y1 > h - 1) y1 = h - 1;
    const float *a = texel(p, x0, y0), *b = texel(p, x1, y0), *c = texel(p, x0, y1), *e = texel(p, x1, y1);
    for (int ch = 0; ch < 3; ch++)
        rgb[ch] = (1 - ty) * ((1 - tx) * a[ch] + tx * b[ch]) + ty * ((1 - tx) * c[ch] + tx * e[ch]);
}

/* Bilinear angular-map lookup over the taps inside the circle. */
static void eval_angular(const prt_probe *p, const float d[3], float rgb[3]) {
    int w = p->img.w, h = p->img.h;
    float z = -d[2] > 1.f ? 1.f : (-d[2] < -1.f ? -1.f : -d[2]);
    float r = acosf(z) * (float)(1.0 / PI_D), rxy = sqrtf(d[0] * d[0] + d[1] * d[1]);
    float a, b;
    if (rxy > 1e-12f) { a = r * d[0] / rxy; b = r * d[1] / rxy; }
    else { a = r; b = 0.f; }   /* straight ahead (r = 0) or straight behind (r = 1: any point of the rim) */
    float fx = (0.5f + 0.5f * a) * (float)w - 0.5f, fy = (0.5f - 0.5f * b) * (float)h - 0.5f;
    float x0f = floorf(fx), y0f = floorf(fy);
    float tx = fx - x0f, ty = fy - y0f;
    int xs[2] = { (int)x0f, (int)x0f + 1 }, ys[2] = { (int)y0f, (int)y0f + 1 };
    float wx[2] = { 1 - tx, tx }, wy[2] = { 1 - ty, ty };
    float acc[3] = { 0, 0, 0 }, wsum = 0;
    /* Bilinear over the taps inside the circle only, renormalized, so the black
     * outside of the probe does not bleed into directions near +z. */
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int x = xs[i], y = ys[j];
            if (x < 0 || y < 0 || x >= w || y >= h || !angular_valid(w, h, x, y)) continue;
            float wt = wx[i] * wy[j];
            const float *t = texel(p, x, y);
            acc[0] += wt * t[0]; acc[1] += wt * t[1]; acc[2] += wt * t[2];
            wsum += wt;
        }
    if (wsum > 0.f) {
        for (int ch = 0; ch < 3; ch++) rgb[ch] = acc[ch] / wsum;
        return;
    }
    /* No valid tap (on the rim, between pixel centres outside the circle): the
     * nearest pixel one pixel inward, whose centre is inside. */
    float rr = sqrtf(a * a + b * b), in = 1.f - 2.f / (float)(w < h ? w : h);
    if (rr > in && rr > 0.f) { a *= in / rr; b *= in / rr; }
    int x = (int)floorf((0.5f + 0.5f * a) * (float)w), y = (int)floorf((0.5f - 0.5f * b) * (float)h);
    x = x < 0 ? 0 : (x >= w ? w - 1 : x);
    y = y < 0 ? 0 : (y >= h ? h - 1 : y);
    const float *t = texel(p, x, y);
    rgb[0] = t[0]; rgb[1] = t[1]; rgb[2] = t[2];
}

/* Bilinear cross lookup on the face d falls in, taps clamped to that face. */
static void eval_cross(const prt_probe *p, const float d[3], float rgb[3]) {
    int F;
    const cross_face *tab = cross_table(p, &F);
    int best = 0;
    float bd = -FLT_MAX;
    for (int f = 0; f < 6; f++) {
        float dc = v3_dot(d, tab[f].c);
        if (dc > bd) { bd = dc; best = f; }
    }
    const cross_face *cf = &tab[best];
    float inv = bd > 0.f ? 1.f / bd : 0.f;
    float s = v3_dot(d, cf->a) * inv, t = v3_dot(d, cf->b) * inv;
    float fx = (s + 1.f) * 0.5f * (float)F - 0.5f, fy = (t + 1.f) * 0.5f * (float)F - 0.5f;
    float x0f = floorf(fx), y0f = floorf(fy);
    float tx = fx - x0f, ty = fy - y0f;
    int x0 = (int)x0f, y0 = (int)y0f, x1 = x0 + 1, y1 = y0 + 1;
    /* Clamp the taps to this face: the neighbouring cells of the image are other faces or empty. */
    x0 = x0 < 0 ? 0 : (x0 > F - 1 ? F - 1 : x0);
    x1 = x1 < 0 ? 0 : (x1 > F - 1 ? F - 1 : x1);
    y0 = y0 < 0 ? 0 : (y0 > F - 1 ? F - 1 : y0);
    y1 = y1 < 0 ? 0 : (y1 > F - 1 ? F - 1 : y1);
    int ox = cf->col * F, oy = cf->row * F;
    const float *a = texel(p, ox + x0, oy + y0), *b = texel(p, ox + x1, oy + y0);
    const float *c = texel(p, ox + x0, oy + y1), *e = texel(p, ox + x1, oy + y1);
    for (int ch = 0; ch < 3; ch++)
        rgb[ch] = (1 - ty) * ((1 - tx) * a[ch] + tx * b[ch]) + ty * ((1 - tx) * c[ch] + tx * e[ch]);
}

/* Bilinear radiance of the probe in unit direction d. */
void probe_eval(const prt_probe *p, const float d[3], float rgb[3]) {
    if (!isfinite(d[0]) || !isfinite(d[1]) || !isfinite(d[2]) || !p->img.data) {
        rgb[0] = rgb[1] = rgb[2] = 0.f;
        return;
    }
    switch (p->layout) {
    case PROBE_LATLONG: eval_latlong(p, d, rgb); break;
    case PROBE_ANGULAR: eval_angular(p, d, rgb); break;
    case PROBE_VCROSS:
    case PROBE_HCROSS: eval_cross(p, d, rgb); break;
    default: rgb[0] = rgb[1] = rgb[2] = 0.f; break;
    }
}

static double clampd(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* Solid angle of the gnomonic rectangle [s0,s1] x [t0,t1] at distance 1 (exact). */
static double gnomonic_area(double s0, double t0, double s1, double t1) {
#define GA(x, y) atan2((x) * (y), sqrt((x) * (x) + (y) * (y) + 1.0))
    return GA(s1, t1) - GA(s0, t1) - GA(s1, t0) + GA(s0, t0);
#undef GA
}

/* Angular map solid-angle density per unit (a, b) area at radius r: pi sin(pi r) / r. */
static double angular_density(double r) { return r < 1e-9 ? PI_D * PI_D : PI_D * sin(PI_D * r) / r; }

/* Centre direction and solid angle of pixel (x, y); false outside the layout's valid area. */
bool probe_pixel_dir(const prt_probe *p, int x, int y, float d[3], float *solid_angle) {
    int w = p->img.w, h = p->img.h;
    if (x < 0 || y < 0 || x >= w || y >= h) return false;
    switch (p->layout) {
    case PROBE_LATLONG: {
        double th = (y + 0.5) * PI_D / h, ph = ((x + 0.5) / w - 0.5) * 2.0 * PI_D;
        d[0] = (float)(sin(th) * sin(ph));
        d[1] = (float)cos(th);
        d[2] = (float)(-sin(th) * cos(ph));
        if (solid_angle) *solid_angle = (float)(2.0 * PI_D / w * (cos(y * PI_D / h) - cos((y + 1) * PI_D / h)));
        return true;
    }
    case PROBE_ANGULAR: {
        if (!angular_valid(w, h, x, y)) return false;
        double a = 2.0 * (x + 0.5) / w - 1.0, b = 1.0 - 2.0 * (y + 0.5) / h, r = sqrt(a * a + b * b);
        double th = PI_D * r;
        if (r > 1e-12) {
            d[0] = (float)(sin(th) * a / r);
            d[1] = (float)(sin(th) * b / r);
        } else {
            d[0] = d[1] = 0.f;
        }
        d[2] = (float)(-cos(th));
        if (solid_angle) {
            double da = 2.0 / w, db = 2.0 / h, area = da * db;
            /* Farthest corner from the centre: interior pixels use the midpoint rule,
             * pixels on the rim integrate the density over their inside part (8 x 8). */
            double fa = fabs(a) + 0.5 * da, fb = fabs(b) + 0.5 * db;
            double om;
            if (fa * fa + fb * fb < 1.0) {
                om = angular_density(r) * area;
            } else {
                om = 0;
                for (int j = 0; j < 8; j++)
                    for (int i = 0; i < 8; i++) {
                        double sa = a + ((i + 0.5) / 8 - 0.5) * da, sb = b + ((j + 0.5) / 8 - 0.5) * db;
                        double sr = sqrt(sa * sa + sb * sb);
                        if (sr <= 1.0) om += angular_density(sr) * area / 64;
                    }
            }
            *solid_angle = (float)om;
        }
        return true;
    }
    case PROBE_VCROSS:
    case PROBE_HCROSS: {
        int F;
        const cross_face *tab = cross_table(p, &F);
        int col = x / F, row = y / F;
        for (int f = 0; f < 6; f++) {
            if (tab[f].col != col || tab[f].row != row) continue;
            int i = x - col * F, j = y - row * F;
            float s = 2.f * (i + 0.5f) / F - 1.f, t = 2.f * (j + 0.5f) / F - 1.f;
            for (int k = 0; k < 3; k++) d[k] = s * tab[f].a[k] + t * tab[f].b[k] + tab[f].c[k];
            v3_normalize(d);
            if (solid_angle)
                *solid_angle = (float)gnomonic_area(2.0 * i / F - 1.0, 2.0 * j / F - 1.0, 2.0 * (i + 1) / F - 1.0,
                                                    2.0 * (j + 1) / F - 1.0);
            return true;
        }
        return false;
    }
    default: return false;
    }
}

/* ---- resampling to the cube map ---------------------------------------------------------- */

/* The most sub-samples per texel side (refined texels). The fuzz build (Makefile, FUZZ=1) sets
 * a smaller one: the same code paths at a fraction of a sun's 64 x 64 lookups per texel. */
#ifndef PROBE_MAX_SS
#define PROBE_MAX_SS 64
#endif
#define REFINE_K 4        /* refined sub-samples per probe pixel (a quarter pixel apart) */

/* Direction at continuous image position (fx, fy) (pixel x spans [x, x+1)); false outside the
 * valid area. Latlong wraps in x and clamps in y. */
static bool probe_pos_dir(const prt_probe *p, double fx, double fy, float d[3]) {
    int w = p->img.w, h = p->img.h;
    if (p->layout == PROBE_LATLONG) {
        double th = clampd(fy / h, 0, 1) * PI_D, ph = (fx / w - 0.5) * 2 * PI_D;
        d[0] = (float)(sin(th) * sin(ph)); d[1] = (float)cos(th); d[2] = (float)(-sin(th) * cos(ph));
        return true;
    }
    if (p->layout == PROBE_ANGULAR) {
        double a = 2 * fx / w - 1, b = 1 - 2 * fy / h, r = sqrt(a * a + b * b);
        if (r > 1) return false;
        double th = PI_D * r;
        d[0] = r > 1e-12 ? (float)(sin(th) * a / r) : 0.f;
        d[1] = r > 1e-12 ? (float)(sin(th) * b / r) : 0.f;
        d[2] = (float)(-cos(th));
        return true;
    }
    int F;
    const cross_face *tab = cross_table(p, &F);
    if (fx < 0 || fy < 0) return false;
    int col = (int)(fx / F), row = (int)(fy / F);
    for (int f = 0; f < 6; f++) {
        if (tab[f].col != col || tab[f].row != row) continue;
        float s = (float)(2 * (fx - col * F) / F - 1), t = (float)(2 * (fy - row * F) / F - 1);
        for (int k = 0; k < 3; k++) d[k] = s * tab[f].a[k] + t * tab[f].b[k] + tab[f].c[k];
        v3_normalize(d);
        return true;
    }
    return false;
}

/* Smallest angular size (radians) of pixel (x, y). */
static double pixel_extent(const prt_probe *p, int x, int y) {
    int w = p->img.w, h = p->img.h;
    if (p->layout == PROBE_LATLONG) {
        double st = sin((y + 0.5) * PI_D / h);
        return fmin(PI_D / h, 2 * PI_D * st / w);
    }
    if (p->layout == PROBE_ANGULAR) {
        double a = 2.0 * (x + 0.5) / w - 1, b = 1 - 2.0 * (y + 0.5) / h, r = clampd(sqrt(a * a + b * b), 1.0 / w, 1);
        return fmax(fmin(2 * PI_D / w, 2 * sin(PI_D * r) / (r * w)), 1e-9);
    }
    int F;
    cross_table(p, &F);
    double s = 2.0 * (x % F + 0.5) / F - 1, t = 2.0 * (y % F + 0.5) / F - 1;
    return 2.0 / F / (1 + s * s + t * t);
}

/* Refinement (why the default ss = 4 is enough): bilinear sub-samples spaced about one probe
 * pixel apart sum a smooth probe correctly, but a sun one or two pixels wide falls between
 * them, so its power comes out anywhere from 0 to twice its value (a 1024-wide probe with a
 * sub-pixel sun near the zenith lost all of it). So each pixel much brighter than the mean
 * (more than 16x, and at least 1/1000 of the maximum) marks the cube texels its bilinear
 * footprint reaches, and those texels are sampled with sub-samples at most a quarter pixel
 * apart, where bilinear sums are within a fraction of a percent. Suns cover few texels, so
 * this costs little. Returns per-texel ss in out[6 res^2] (NULL if memory is short). */
static uint8_t *refine_map(const prt_probe *p, int res, const float R[9], int ss) {
    int w = p->img.w, h = p->img.h;
    size_t n = (size_t)6 * res * res;
    uint8_t *m = malloc(n);
    if (!m) return NULL;
    memset(m, ss, n);
    /* Mean radiance (channel sum), solid-angle weighted over the valid pixels. */
    double pw = 0, om = 0;
    for (int y = 0; y < h; y++) {
        double orow = 2 * PI_D / w * (cos(y * PI_D / h) - cos((y + 1) * PI_D / h)), rsum = 0;
        for (int x = 0; x < w; x++) {
            const float *t = texel(p, x, y);
            float d[3], o;
            if (p->layout == PROBE_LATLONG) {
                rsum += (double)t[0] + t[1] + t[2];
                continue;
            }
            if (!probe_pixel_dir(p, x, y, d, &o)) continue;
            pw += (double)o * (t[0] + t[1] + t[2]);
            om += o;
        }
        if (p->layout == PROBE_LATLONG) {
            pw += orow * rsum;
            om += orow * w;
        }
    }
    double mean = om > 0 ? pw / om : 0, thresh = fmax(16 * mean, 3e-3 * p->max_value);
    if (!(thresh > 0)) return m;
    /* A texel's widest angular side (at a face centre, where texels are largest). */
    double texel_size = 2.0 / res;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *t = texel(p, x, y);
            if (t[0] + t[1] + t[2] <= thresh) continue;
            double want = ceil(REFINE_K * texel_size / pixel_extent(p, x, y));
            int sh = want > PROBE_MAX_SS ? PROBE_MAX_SS : (want < ss ? ss : (int)want);
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    float d[3], rd[3];
                    if (!probe_pos_dir(p, x + 0.5 + dx, y + 0.5 + dy, d)) continue;
                    rd[0] = R[0] * d[0] + R[1] * d[1] + R[2] * d[2];
                    rd[1] = R[3] * d[0] + R[4] * d[1] + R[5] * d[2];
                    rd[2] = R[6] * d[0] + R[7] * d[1] + R[8] * d[2];
                    int ti = cube_texel_index(res, rd);
                    if (m[ti] < sh) m[ti] = (uint8_t)sh;
                }
        }
    return m;
}

typedef struct cube_job {
    const prt_probe *p;
    const uint8_t *ss_map;   /* per-texel ss (refined near suns), or NULL: ss everywhere */
    int res, ss;
    float Rt[9];   /* R transposed: the cube texel at w shows the probe at R^T w */
    float *out;
} cube_job;

/* prt_parallel_for body: cube rows [begin,end) (face*res + j) into J->out. */
static void cube_rows(void *ctx, int begin, int end, int thread) {
    const cube_job *J = ctx;
    int res = J->res;
    const float *R = J->Rt;
    double A[(PROBE_MAX_SS + 1) * (PROBE_MAX_SS + 1)];
    for (int row = begin; row < end; row++) {   /* row = face * res + j */
        int face = row / res, j = row % res;
        for (int i = 0; i < res; i++) {
            int ss = J->ss_map ? J->ss_map[(size_t)row * res + i] : J->ss, n = res * ss;
            /* Exact solid angles of the ss x ss sub-squares from the area function at the grid corners. */
            for (int b = 0; b <= ss; b++)
                for (int a = 0; a <= ss; a++) {
                    double s = 2.0 * (i * ss + a) / n - 1.0, t = 2.0 * (j * ss + b) / n - 1.0;
                    A[b * (ss + 1) + a] = atan2(s * t, sqrt(s * s + t * t + 1.0));
                }
            double acc[3] = { 0, 0, 0 }, wsum = 0;
            for (int b = 0; b < ss; b++)
                for (int a = 0; a < ss; a++) {
                    double wt = A[(b + 1) * (ss + 1) + a + 1] - A[b * (ss + 1) + a + 1] - A[(b + 1) * (ss + 1) + a] +
                                A[b * (ss + 1) + a];
                    float dw[3], dp[3], rgb[3];
                    cube_dir(res, face, (float)i + (a + 0.5f) / ss, (float)j + (b + 0.5f) / ss, dw);
                    dp[0] = R[0] * dw[0] + R[1] * dw[1] + R[2] * dw[2];
                    dp[1] = R[3] * dw[0] + R[4] * dw[1] + R[5] * dw[2];
                    dp[2] = R[6] * dw[0] + R[7] * dw[1] + R[8] * dw[2];
                    probe_eval(J->p, dp, rgb);
                    acc[0] += wt * rgb[0]; acc[1] += wt * rgb[1]; acc[2] += wt * rgb[2];
                    wsum += wt;
                }
            float *o = J->out + 3 * ((size_t)row * res + i);
            for (int ch = 0; ch < 3; ch++) {
                double v = wsum > 0 ? acc[ch] / wsum : 0.0;
                o[ch] = v > FLT_MAX ? FLT_MAX : (v > 0 ? (float)v : 0.f);
            }
        }
    }
}

/* Area-averaged cube map of the rotated probe into out_rgb[6*res*res*3]. */
void probe_to_cube(const prt_probe *p, int res, const float R[9], int ss, float *out_rgb) {
    if (res <= 0) return;
    if (ss <= 0) ss = 4;
    if (ss > PROBE_MAX_SS) ss = PROBE_MAX_SS;
    cube_job J = { .p = p, .res = res, .ss = ss, .out = out_rgb };
    static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    if (!R) R = I;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) J.Rt[3 * r + c] = R[3 * c + r];
    uint8_t *map = refine_map(p, res, R, ss);   /* NULL (memory short): plain ss everywhere */
    J.ss_map = map;
    /* Grain 1 row: refined rows cost far more than the others. */
    prt_parallel_for(6 * res, 1, 0, cube_rows, &J);
    free(map);
}

/* R = pitch(P about +x) * yaw(Y about +y) from "Y" or "Y,P" in degrees. Returns 0 or -1. */
int probe_parse_rotation(const char *s, float R[9]) {
    if (!s) return -1;
    char *end;
    double yaw = strtod(s, &end), pitch = 0;
    if (end == s || !isfinite(yaw)) return -1;
    while (isspace((unsigned char)*end)) end++;
    if (*end == ',') {
        const char *q = end + 1;
        pitch = strtod(q, &end);
        if (end == q || !isfinite(pitch)) return -1;
        while (isspace((unsigned char)*end)) end++;
    }
    if (*end) return -1;
    probe_rotation(yaw, pitch, R);
    return 0;
}

/* See probe.h. */
void probe_rotation(double yaw, double pitch, float R[9]) {
    double y = yaw * PI_D / 180, x = pitch * PI_D / 180;
    double cy = cos(y), sy = sin(y), cx = cos(x), sx = sin(x);
    /* Ry = [cy 0 sy; 0 1 0; -sy 0 cy], Rx = [1 0 0; 0 cx -sx; 0 sx cx], R = Rx Ry. */
    double M[9] = { cy, 0, sy, sx * sy, cx, -sx * cy, -cx * sy, sx, cx * cy };
    for (int i = 0; i < 9; i++) R[i] = (float)M[i];
}

/* ---- procedural environments ------------------------------------------------------------- */

/* A constant 16 x 8 latlong probe of radiance rgb (negatives clamp to 0). */
int probe_make_constant(const float rgb[3], prt_probe *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    prt_image img;
    if (image_alloc(&img, 16, 8, 3, err)) return -1;
    for (int i = 0; i < 16 * 8; i++)
        for (int ch = 0; ch < 3; ch++) img.data[3 * i + ch] = rgb[ch];
    return probe_from_image(&img, PROBE_LATLONG, "constant probe", out, err);
}

typedef struct sky_job {
    prt_image *img;
    float zen[3], hor[3], gnd[3];
} sky_job;

/* Sky radiance without the sun: ground below the horizon, a gradient above that
 * is the horizon colour at the horizon and the zenith colour overhead. */
static void sky_base(const sky_job *S, const float d[3], float rgb[3]) {
    if (d[1] < 0.f) {
        v3_copy(rgb, S->gnd);
        return;
    }
    float t = 1.f - d[1];
    t = t * t * t;   /* most of the sky near the zenith colour, brightening toward the horizon */
    for (int ch = 0; ch < 3; ch++) rgb[ch] = S->zen[ch] + t * (S->hor[ch] - S->zen[ch]);
}

/* prt_parallel_for body: sky rows [begin,end) of the latlong, without the sun. */
static void sky_rows(void *ctx, int begin, int end, int thread) {
    const sky_job *S = ctx;
    int w = S->img->w, h = S->img->h;
    for (int y = begin; y < end; y++)
        for (int x = 0; x < w; x++) {
            double th = (y + 0.5) * PI_D / h, ph = ((x + 0.5) / w - 0.5) * 2.0 * PI_D;
            float d[3] = { (float)(sin(th) * sin(ph)), (float)cos(th), (float)(-sin(th) * cos(ph)) };
            sky_base(S, d, S->img->data + 3 * ((size_t)y * w + x));
        }
}

/* Fraction of latlong pixel (x, y) (of w x h) inside the cap {d : d.s >= cos_r}, from 8 x 8
 * sub-samples of equal solid angle (uniform in phi and cos theta). */
static double pixel_cap_fraction(int w, int h, int x, int y, const double s[3], double cos_r) {
    double c0 = cos(y * PI_D / h), c1 = cos((y + 1) * PI_D / h);
    int in = 0;
    for (int j = 0; j < 8; j++) {
        double ct = c0 + (c1 - c0) * (j + 0.5) / 8, st = sqrt(fmax(0.0, 1 - ct * ct));
        for (int i = 0; i < 8; i++) {
            double ph = ((x + (i + 0.5) / 8) / w - 0.5) * 2.0 * PI_D;
            double dd = st * sin(ph) * s[0] + ct * s[1] - st * cos(ph) * s[2];
            in += dd >= cos_r;
        }
    }
    return in / 64.0;
}

/* Latlong pixel containing direction s. */
static void latlong_pixel(int w, int h, const double s[3], int *x, int *y) {
    double u = 0.5 + atan2(s[0], -s[2]) / (2 * PI_D), v = acos(fmax(-1.0, fmin(1.0, s[1]))) / PI_D;
    int px = (int)floor(u * w), py = (int)floor(v * h);
    *x = ((px % w) + w) % w;
    *y = py < 0 ? 0 : (py >= h ? h - 1 : py);
}

/* Adds the sun disc to the sky with exact total power (see the file comment). Returns 0 or -1 (OOM). */
static int add_sun(prt_image *img, const double s[3], double radius, double L, prt_error *err) {
    int w = img->w, h = img->h;
    double cos_r = cos(radius), omega_disc = 2 * PI_D * (1 - cos_r);
    double ths = acos(fmax(-1.0, fmin(1.0, s[1]))), phs = atan2(s[0], -s[2]);
    double dth = PI_D / h, dph = 2 * PI_D / w, halfdiag = 0.5 * sqrt(dth * dth + dph * dph) + 1e-9;
    int y0 = (int)floor((ths - radius) / dth) - 1, y1 = (int)ceil((ths + radius) / dth) + 1;
    y0 = y0 < 0 ? 0 : y0;
    y1 = y1 > h - 1 ? h - 1 : y1;
    /* Columns: all of them if the cap holds a pole, else phi_s +- asin(sin r / sin theta_s) plus a margin. */
    int xs0 = 0, nx = w;
    if (ths - radius > 0 && ths + radius < PI_D) {
        double dphi = asin(fmin(1.0, sin(radius) / sin(ths)));
        double u = (phs / (2 * PI_D) + 0.5) * w;
        int a = (int)floor(u - dphi / dph) - 2, b = (int)ceil(u + dphi / dph) + 2;
        if (b - a + 1 < w) { xs0 = a; nx = b - a + 1; }
    }
    int ny = y1 - y0 + 1;
    double *cov = prt_calloc((size_t)nx * ny, sizeof(double), err);
    if (!cov) return -1;
    double total = 0;
    for (int yy = 0; yy < ny; yy++) {
        int y = y0 + yy;
        double pix_omega = dph * (cos(y * PI_D / h) - cos((y + 1) * PI_D / h));
        double th = (y + 0.5) * dth, st = sin(th), ct = cos(th);
        for (int xx = 0; xx < nx; xx++) {
            int x = ((xs0 + xx) % w + w) % w;
            double ph = ((x + 0.5) / w - 0.5) * 2 * PI_D;
            double dd = st * sin(ph) * s[0] + ct * s[1] - st * cos(ph) * s[2];
            double ang = acos(fmax(-1.0, fmin(1.0, dd)));
            double c;
            if (ang + halfdiag <= radius) c = 1;            /* wholly inside */
            else if (ang - halfdiag >= radius) c = 0;       /* wholly outside */
            else c = pixel_cap_fraction(w, h, x, y, s, cos_r);
            cov[(size_t)yy * nx + xx] = c;
            total += c * pix_omega;
        }
    }
    if (total > 0) {
        for (int yy = 0; yy < ny; yy++)
            for (int xx = 0; xx < nx; xx++) {
                double c = cov[(size_t)yy * nx + xx];
                if (c <= 0) continue;
                int x = ((xs0 + xx) % w + w) % w;
                float *px = img->data + 3 * ((size_t)(y0 + yy) * w + x);
                double add = L * omega_disc * c / total;
                for (int ch = 0; ch < 3; ch++) px[ch] = (float)(px[ch] * (1 - c) + add);
            }
    } else {
        /* Smaller than a sub-sample: all the power into the pixel holding the centre. */
        int x, y;
        latlong_pixel(w, h, s, &x, &y);
        double pix_omega = dph * (cos(y * PI_D / h) - cos((y + 1) * PI_D / h));
        float *px = img->data + 3 * ((size_t)y * w + x);
        for (int ch = 0; ch < 3; ch++) px[ch] = (float)(px[ch] + L * omega_disc / pix_omega);
    }
    free(cov);
    return 0;
}

static bool is_zero3(const float v[3]) { return v[0] == 0.f && v[1] == 0.f && v[2] == 0.f; }

/* The procedural sky as a latlong probe (see probe.h for the defaults). Returns 0 or -1. */
int probe_make_sky(const sky_desc *desc, prt_probe *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    sky_desc d = { 0 };
    if (desc) d = *desc;
    int w = d.width > 0 ? d.width : 512;
    if (w < 4 || w > 65536) return prt_fail(err, "sky: width %d out of range (4..65536)", d.width);
    w &= ~1;
    double s[3] = { 0.5, sqrt(0.5), -0.5 };   /* elevation 45 deg, in front and to the right */
    if (!is_zero3(d.sun_dir)) {
        double l = sqrt((double)d.sun_dir[0] * d.sun_dir[0] + (double)d.sun_dir[1] * d.sun_dir[1] +
                        (double)d.sun_dir[2] * d.sun_dir[2]);
        if (!(l > 0) || !isfinite(l)) return prt_fail(err, "sky: sun direction is not a finite non-zero vector");
        for (int k = 0; k < 3; k++) s[k] = d.sun_dir[k] / l;
    }
    double radius_deg = d.sun_radius_deg > 0 ? d.sun_radius_deg : 1.5;
    double L = d.sun_radiance > 0 ? d.sun_radiance : 2000.0;
    if (!isfinite(radius_deg) || radius_deg > 90 || !isfinite(L))
        return prt_fail(err, "sky: sun radius %g deg or radiance %g out of range", radius_deg, L);
    sky_job S;
    static const float zen[3] = { 0.20f, 0.38f, 0.90f }, hor[3] = { 0.85f, 0.90f, 1.00f }, gnd[3] = { 0.25f, 0.22f, 0.20f };
    v3_copy(S.zen, is_zero3(d.sky_zenith) ? zen : d.sky_zenith);
    v3_copy(S.hor, is_zero3(d.sky_horizon) ? hor : d.sky_horizon);
    v3_copy(S.gnd, is_zero3(d.ground) ? gnd : d.ground);
    prt_image img;
    if (image_alloc(&img, w, w / 2, 3, err)) return -1;
    S.img = &img;
    prt_parallel_for(img.h, 8, 0, sky_rows, &S);
    if (add_sun(&img, s, radius_deg * PI_D / 180, L, err)) {
        image_free(&img);
        return -1;
    }
    return probe_from_image(&img, PROBE_LATLONG, "sky", out, err);
}
