/* accuracy_img.c - the image work of make accuracy (tools/accuracy.sh): the floor's shadow
 * region as a mask, rel_rmse over a mask, and the contact sheets. Not a test: it measures.
 *
 *     tools/accuracy_img.sh uniform OUT.exr
 *     tools/accuracy_img.sh mask COVER.exr MODEL.exr REF.exr OUT.exr
 *     tools/accuracy_img.sh model MODEL.exr OUT.exr
 *     tools/accuracy_img.sh cmp A.exr B.exr [MASK.exr]
 *     tools/accuracy_img.sh sheet OUT.png TILE_W TITLE LIST
 *
 * uniform: a 64x32 latitude-longitude probe of radiance 1 everywhere; under it every surface
 *   point that sees any sky renders above zero, so a render with --no-background covers the
 *   scene's geometry exactly (the rasterizer's coverage, the same as the PRT images').
 * mask: the floor's shadow region of one reference image. COVER is the scene rendered under the
 *   uniform probe (model and floor above zero), MODEL the scene without its floor under it (the
 *   model above zero: the floor lies below the model and the camera above both, so nothing of
 *   the model hides behind it). Floor pixels are those of COVER but not MODEL whose 8 neighbours
 *   are too: the reference blends the model, the floor and the background at their silhouettes,
 *   and that is no shadow. The shadow region is the floor pixels whose RGB sum in REF is below
 *   60% of the floor pixels' median: the unshadowed floor is one value in a distant light (every
 *   floor normal is up and nothing but the model occludes it), the median stands for it where
 *   the shadow covers less than half the floor, and 60% is the per-vertex region tools/shadows.sh
 *   measures. Writes OUT (1 in the region, 0 elsewhere); prints "floor_px=F shadow_px=S".
 * model: the model's own pixels: those of MODEL (as above) above zero with their 8 neighbours too
 *   (no silhouette); writes OUT (1 there, 0 elsewhere); prints "model_px=M".
 * cmp: rel_rmse of A against the reference B (cmp_arrays, the metric of prt compare) over the
 *   pixels where MASK is above 0.5 (every pixel without one); prints "rel_rmse=X items=N", or
 *   "rel_rmse=- items=0" for an empty mask.
 * sheet: one row per line of LIST: "LABEL<TAB>PRT.exr<TAB>REF.exr<TAB>ERR.png[<TAB>...]", each
 *   four fields a cell drawn as its label over PRT | reference | error image, every tile TILE_W
 *   wide (box-filtered down, the height by the images' aspect). PRT and reference share one exposure per cell, the
 *   one putting the reference's 97th-percentile RGB sum of its non-black pixels at 0.85 (display
 *   linear, then sRGB): the probes differ by orders of magnitude in brightness. The error images
 *   (prt compare --error-image) are drawn as they are, with their colour scale at the bottom.
 *
 * Errors: one line naming the file or the argument, exit 2 for usage, 1 for data. */
#include "compare.h"
#include "font6x13.h"
#include "image.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { GAP = 4, LINE = 16, MAX_CELLS = 8, CELL_FIELDS = 4, LEGEND_X = 70, LEGEND_BAR = 300, LEGEND_W = 400 };

static int usage(void) {
    fprintf(stderr, "usage: accuracy_img uniform OUT.exr | mask COVER.exr MODEL.exr REF.exr OUT.exr | model MODEL.exr OUT.exr |\n"
                    "       cmp A.exr B.exr [MASK.exr] | sheet OUT.png TILE_W TITLE LIST\n");
    return 2;
}

static int fail(const prt_error *err) {
    fprintf(stderr, "accuracy_img: %s\n", err->msg);
    return 1;
}

static float rgb_sum(const prt_image *im, long i) { return im->data[3 * i] + im->data[3 * i + 1] + im->data[3 * i + 2]; }

static int cmp_float(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

/* Reads the images at paths[0..n) into ims, all of one size. 0, or -1 with err (nothing left allocated). */
static int read_same(char **paths, int n, prt_image *ims, prt_error *err) {
    for (int i = 0; i < n; i++) {
        int bad = image_read(paths[i], &ims[i], err);
        if (!bad && (ims[i].w != ims[0].w || ims[i].h != ims[0].h)) {
            prt_fail(err, "%s is %dx%d but %s is %dx%d", paths[i], ims[i].w, ims[i].h, paths[0], ims[0].w, ims[0].h);
            image_free(&ims[i]);
            bad = 1;
        }
        if (bad) {
            for (int j = 0; j < i; j++) image_free(&ims[j]);
            return -1;
        }
    }
    return 0;
}

static int cmd_uniform(const char *out) {
    prt_image im = { 0 };
    prt_error err;
    if (image_alloc(&im, 64, 32, 3, &err)) return fail(&err);
    for (long i = 0; i < 64 * 32 * 3; i++) im.data[i] = 1.f;
    image_desc d = { 0 };
    int rc = image_write(out, &im, &d, &err);
    image_free(&im);
    return rc ? fail(&err) : 0;
}

/* Floor pixels of cover/model (see header) into floor[w*h]; returns their count. */
static long floor_pixels(const prt_image *cover, const prt_image *model, uint8_t *floor) {
    int w = cover->w, h = cover->h;
    long n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            bool ok = x > 0 && y > 0 && x < w - 1 && y < h - 1;
            for (int dy = -1; ok && dy <= 1; dy++)
                for (int dx = -1; ok && dx <= 1; dx++) {
                    long j = (long)(y + dy) * w + x + dx;
                    ok = rgb_sum(cover, j) > 0 && !(rgb_sum(model, j) > 0);
                }
            floor[(long)y * w + x] = ok;
            n += ok;
        }
    return n;
}

static int cmd_mask(char **paths, const char *out) {
    prt_image im[3] = { { 0 } }, m = { 0 };
    prt_error err;
    if (read_same(paths, 3, im, &err)) return fail(&err);
    long np = (long)im[0].w * im[0].h, nf, ns = 0;
    uint8_t *floor = malloc((size_t)np);
    float *v = malloc(sizeof(float) * (size_t)np);
    int rc = 1;
    if (!floor || !v) prt_fail(&err, "out of memory");
    else if (image_alloc(&m, im[0].w, im[0].h, 3, &err) == 0) {
        nf = floor_pixels(&im[0], &im[1], floor);
        long k = 0;
        for (long i = 0; i < np; i++)
            if (floor[i]) v[k++] = rgb_sum(&im[2], i);
        qsort(v, (size_t)nf, sizeof(float), cmp_float);
        float cut = nf > 0 ? 0.6f * v[nf / 2] : 0;
        for (long i = 0; i < np; i++) {
            bool s = floor[i] && rgb_sum(&im[2], i) < cut;
            m.data[3 * i] = m.data[3 * i + 1] = m.data[3 * i + 2] = s;
            ns += s;
        }
        image_desc d = { 0 };
        if (image_write(out, &m, &d, &err) == 0) {
            printf("floor_px=%ld shadow_px=%ld\n", nf, ns);
            rc = 0;
        }
    }
    free(floor);
    free(v);
    image_free(&m);
    for (int i = 0; i < 3; i++) image_free(&im[i]);
    return rc ? fail(&err) : 0;
}

/* model: the model's own pixels of MODEL (above zero with their 8 neighbours: no silhouette, where
 * the reference blends model and background); writes OUT (1 there, 0 elsewhere), prints model_px. */
static int cmd_model(const char *path, const char *out) {
    prt_image im = { 0 }, m = { 0 };
    prt_error err;
    if (image_read(path, &im, &err) || image_alloc(&m, im.w, im.h, 3, &err)) {
        image_free(&im);
        return fail(&err);
    }
    long n = 0;
    for (int y = 0; y < im.h; y++)
        for (int x = 0; x < im.w; x++) {
            bool ok = x > 0 && y > 0 && x < im.w - 1 && y < im.h - 1;
            for (int dy = -1; ok && dy <= 1; dy++)
                for (int dx = -1; ok && dx <= 1; dx++) ok = rgb_sum(&im, (long)(y + dy) * im.w + x + dx) > 0;
            long i = (long)y * im.w + x;
            m.data[3 * i] = m.data[3 * i + 1] = m.data[3 * i + 2] = ok;
            n += ok;
        }
    image_desc d = { 0 };
    int rc = image_write(out, &m, &d, &err);
    if (rc == 0) printf("model_px=%ld\n", n);
    image_free(&im);
    image_free(&m);
    return rc ? fail(&err) : 0;
}

static int cmd_cmp(char **paths, int n) {
    prt_image im[3] = { { 0 } };
    prt_error err;
    if (read_same(paths, n, im, &err)) return fail(&err);
    long np = (long)im[0].w * im[0].h, k = 0;
    float *a = malloc(sizeof(float) * 3 * (size_t)np), *b = malloc(sizeof(float) * 3 * (size_t)np);
    int rc = 1;
    cmp_result r;
    if (!a || !b) prt_fail(&err, "out of memory");
    else {
        for (long i = 0; i < np; i++) {
            if (n == 3 && !(im[2].data[3 * i] > 0.5f)) continue;
            memcpy(a + 3 * k, im[0].data + 3 * i, sizeof(float) * 3);
            memcpy(b + 3 * k, im[1].data + 3 * i, sizeof(float) * 3);
            k++;
        }
        if (k == 0) {
            printf("rel_rmse=- items=0\n");
            rc = 0;
        } else if (cmp_arrays(a, b, k, 3, &r, NULL, &err) == 0) {
            printf("rel_rmse=%.6g items=%ld\n", r.rel_rmse, k);
            rc = 0;
        }
    }
    free(a);
    free(b);
    for (int i = 0; i < n; i++) image_free(&im[i]);
    return rc ? fail(&err) : 0;
}

/* --- the contact sheet ------------------------------------------------------------------------ */

typedef struct sheet {
    prt_image im;
    int tw, th;         /* tile size */
} sheet;

static void put(sheet *s, int x, int y, const float rgb[3]) {
    if (x < 0 || y < 0 || x >= s->im.w || y >= s->im.h) return;
    memcpy(s->im.data + 3 * ((long)y * s->im.w + x), rgb, sizeof(float) * 3);
}

/* Text in the 6x13 font, top-left corner at (x, y), in white. */
static void text(sheet *s, int x, int y, const char *str) {
    static const float white[3] = { 1, 1, 1 };
    for (; *str; str++, x += FONT_W) {
        int c = (unsigned char)*str;
        if (c < 32 || c > 126) c = '?';
        for (int r = 0; r < FONT_H; r++)
            for (int b = 0; b < FONT_W; b++)
                if (k_font[c - 32][r] & (0x80 >> b)) put(s, x + b, y + r, white);
    }
}

/* im box-filtered down into the tile at (x0, y0), every value times k. */
static void tile(sheet *s, const prt_image *im, int x0, int y0, float k) {
    for (int ty = 0; ty < s->th; ty++)
        for (int tx = 0; tx < s->tw; tx++) {
            int xa = tx * im->w / s->tw, xb = (tx + 1) * im->w / s->tw, ya = ty * im->h / s->th, yb = (ty + 1) * im->h / s->th;
            if (xb <= xa) xb = xa + 1;
            if (yb <= ya) yb = ya + 1;
            double acc[3] = { 0 };
            for (int y = ya; y < yb; y++)
                for (int x = xa; x < xb; x++)
                    for (int c = 0; c < 3; c++) acc[c] += im->data[3 * ((long)y * im->w + x) + c];
            float rgb[3];
            for (int c = 0; c < 3; c++) rgb[c] = (float)(k * acc[c] / ((xb - xa) * (yb - ya)));
            put(s, x0 + tx, y0 + ty, rgb);
        }
}

/* The exposure of a cell: 0.85 over the 97th percentile of ref's non-black RGB sums (x 3: per channel). */
static float exposure(const prt_image *ref) {
    long np = (long)ref->w * ref->h, k = 0;
    float *v = malloc(sizeof(float) * (size_t)np), e = 1;
    if (!v) return 1;
    for (long i = 0; i < np; i++)
        if (rgb_sum(ref, i) > 0) v[k++] = rgb_sum(ref, i);
    if (k > 0) {
        qsort(v, (size_t)k, sizeof(float), cmp_float);
        float p = v[(long)(0.97 * (double)(k - 1))];
        if (p > 0 && isfinite(p)) e = 0.85f * 3 / p;
    }
    free(v);
    return e;
}

/* One cell (PRT | reference | error) at (x, y) from the three files. 0 or -1 with err. */
static int cell(sheet *s, char **paths, int x, int y, prt_error *err) {
    prt_image im[3] = { { 0 } };
    if (read_same(paths, 2, im, err)) return -1;
    if (image_read(paths[2], &im[2], err)) {
        image_free(&im[0]);
        image_free(&im[1]);
        return -1;
    }
    float k = exposure(&im[1]);
    for (int i = 0; i < 3; i++) tile(s, &im[i], x + i * (s->tw + GAP), y, i < 2 ? k : 1.f);
    for (int i = 0; i < 3; i++) image_free(&im[i]);
    return 0;
}

/* Splits line at tabs into f (at most max fields); returns the count. */
static int fields(char *line, char **f, int max) {
    int n = 0;
    line[strcspn(line, "\r\n")] = 0;
    for (char *p = strtok(line, "\t"); p && n < max; p = strtok(NULL, "\t")) f[n++] = p;
    return n;
}

/* The error colour scale of prt compare (compare.h), in display values turned linear for image_write. */
static void legend(sheet *s, int x, int y) {
    const int bw = LEGEND_BAR;
    for (int i = 0; i < bw; i++) {
        float rgb[3];
        cmp_colormap((float)i / (bw - 1), rgb);
        for (int c = 0; c < 3; c++) rgb[c] = rgb[c] <= 0.04045f ? rgb[c] / 12.92f : powf((rgb[c] + 0.055f) / 1.055f, 2.4f);
        for (int j = 0; j < 8; j++) put(s, x + LEGEND_X + i, y + 3 + j, rgb);
    }
    text(s, x, y, "error:");
    static const char *ticks[4] = { "0.1%", "1%", "10%", "100%" };
    for (int t = 0; t < 4; t++) text(s, x + LEGEND_X + t * (bw - 1) / 3 - 6, y + 13, ticks[t]);
}

static int cmd_sheet(const char *out, int tw, const char *title, const char *list) {
    FILE *f = fopen(list, "r");
    prt_error err;
    if (!f) return fprintf(stderr, "accuracy_img: cannot open %s\n", list), 1;
    char line[8192], *fl[CELL_FIELDS * MAX_CELLS];
    int rows = 0, cells = 0, aw = 0, ah = 0, label = 0;
    while (fgets(line, sizeof line, f)) {
        int n = fields(line, fl, CELL_FIELDS * MAX_CELLS);
        if (n < CELL_FIELDS) continue;
        rows++;
        if (n / CELL_FIELDS > cells) cells = n / CELL_FIELDS;
        for (int c = 0; c < n / CELL_FIELDS; c++)
            if ((int)strlen(fl[CELL_FIELDS * c]) > label) label = (int)strlen(fl[CELL_FIELDS * c]);
        prt_image p = { 0 };
        if (!aw && image_read(fl[1], &p, &err) == 0) { aw = p.w; ah = p.h; }
        image_free(&p);
    }
    if (!rows || !aw) return fclose(f), fprintf(stderr, "accuracy_img: %s lists no readable row\n", list), 1;
    sheet s = { .tw = tw, .th = tw * ah / aw };
    /* a cell as wide as its tiles or its longest label; the sheet as its cells, title or legend */
    int cw = 3 * (tw + GAP) + 2 * GAP, rh = LINE + s.th + GAP, sw;
    if (label * FONT_W + 2 * GAP > cw) cw = label * FONT_W + 2 * GAP;
    sw = GAP + cells * cw;
    if ((int)strlen(title) * FONT_W + 2 * GAP > sw) sw = (int)strlen(title) * FONT_W + 2 * GAP;
    if (LEGEND_W + 2 * GAP > sw) sw = LEGEND_W + 2 * GAP;
    if (image_alloc(&s.im, sw, 2 * LINE + rows * rh + 2 * LINE + GAP, 3, &err)) return fclose(f), fail(&err);
    for (long i = 0; i < 3L * s.im.w * s.im.h; i++) s.im.data[i] = 0.01f;
    text(&s, GAP, 2, title);
    for (int c = 0; c < cells; c++) {
        text(&s, GAP + c * cw, LINE + 2, "PRT");
        text(&s, GAP + c * cw + tw + GAP, LINE + 2, "reference");
        text(&s, GAP + c * cw + 2 * (tw + GAP), LINE + 2, "error (prt compare)");
    }
    rewind(f);
    int r = 0, rc = 0;
    while (rc == 0 && fgets(line, sizeof line, f)) {
        int n = fields(line, fl, CELL_FIELDS * MAX_CELLS);
        if (n < CELL_FIELDS) continue;
        int y = 2 * LINE + r++ * rh;
        for (int c = 0; rc == 0 && c < n / CELL_FIELDS; c++) {
            text(&s, GAP + c * cw, y + 2, fl[CELL_FIELDS * c]);
            rc = cell(&s, fl + CELL_FIELDS * c + 1, GAP + c * cw, y + LINE, &err);
        }
    }
    fclose(f);
    legend(&s, GAP, 2 * LINE + rows * rh + 4);
    image_desc d = { 0 };
    if (rc == 0) rc = image_write(out, &s.im, &d, &err);
    image_free(&s.im);
    return rc ? fail(&err) : 0;
}

int main(int argc, char **argv) {
    if (argc == 3 && !strcmp(argv[1], "uniform")) return cmd_uniform(argv[2]);
    if (argc == 6 && !strcmp(argv[1], "mask")) return cmd_mask(argv + 2, argv[5]);
    if (argc == 4 && !strcmp(argv[1], "model")) return cmd_model(argv[2], argv[3]);
    if ((argc == 4 || argc == 5) && !strcmp(argv[1], "cmp")) return cmd_cmp(argv + 2, argc - 2);
    if (argc == 6 && !strcmp(argv[1], "sheet")) {
        int tw = atoi(argv[3]);
        if (tw < 16 || tw > 4096) return fprintf(stderr, "accuracy_img: bad TILE_W '%s' (16..4096)\n", argv[3]), 2;
        return cmd_sheet(argv[2], tw, argv[4], argv[5]);
    }
    return usage();
}
