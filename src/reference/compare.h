/* compare.h - error metrics between a result A and a reference B (images or per-vertex values).
 *
 * Usage:
 *     cmp_result r; prt_error err;
 *     cmp_desc d = { .error_image = "err.png" };
 *     if (cmp_files("prt.exr", "ref.exr", &d, &r, &err)) puts(err.msg);
 *     printf("rel_rmse=%.6g max_rel_err=%.6g\n", r.rel_rmse, r.max_rel_err);
 *
 * Definitions (B is the reference; an "item" is a pixel or a vertex; |.| of an item is
 * the Euclidean norm of its RGB triple):
 *   rel_rmse    = sqrt( sum over items and channels (a - b)^2  /  sum over items and channels b^2 )
 *   max_rel_err = max over items with |b| > 1% of mean_items |b| of  |a - b| / |b|
 * The 1% floor keeps near-black items (shadow cores, vertices facing away) from
 * dominating the maximum with 0/0-like ratios; items below it still count in rel_rmse.
 * When B is all zero: both metrics are 0 if A is all zero too, otherwise an error.
 *
 * Error image (images only): per pixel e = |a - b| / max(|b|, 1% of mean |b|), shown
 * through the "turbo" colour map on a log scale: log10(e) from -3 (0.1% or less: near
 * black) through blue (0.2%), green (3%), orange (10%) to 0 (100% or more: dark red).
 *
 * Inputs: two images of the same size (any format image_read reads; EXR for radiance),
 * or two per-vertex CSV files with a header naming columns r, g, b and optionally vertex,
 * stderr_r/g/b and facing (as `prt render --vertices` and `prt reference --vertices` write).
 * Vertex files must list the same vertex ids. If B has stderr columns, ref_noise =
 * sqrt(sum stderr^2 / sum b^2) is reported too (the reference's own noise level: a
 * rel_rmse near it means "no measurable difference").
 *
 * Facing: outgoing radiance toward the eye only exists for a vertex whose normal faces
 * the eye (n . (eye - p) > 0); the reference writes it as 0 otherwise (one-sided surfaces),
 * while PRT's Lambertian shortcut (relight.h) keeps the diffuse value. Such vertices are
 * never seen in an image (they are back faces), so when B has a `facing` column only the
 * vertices with facing = 1 are compared, unless desc.all_vertices.
 *
 * Errors: missing or unreadable files, mixed kinds, size or vertex-set mismatch,
 * non-finite values, a malformed CSV line (with its line number): -1 with one line in err. */
#ifndef PRT_COMPARE_H
#define PRT_COMPARE_H
#include "common.h"

typedef struct cmp_result {
    double rel_rmse;
    double max_rel_err;
    double ref_noise;     /* < 0 when B carries no standard errors */
    long items;           /* pixels or vertices compared */
    long items_in_max;    /* items above the 1% floor (those max_rel_err ranges over) */
    int worst_item;       /* index (vertex id for CSV) of the item giving max_rel_err (-1 if none) */
    long skipped;         /* vertices left out because B marks them as facing away */
    int width;            /* images: their width, so worst_item is pixel (x, y) = (i % width, i / width),
                           * row 0 at the top; 0 for CSV */
} cmp_result;

typedef struct cmp_desc {
    const char *error_image;  /* images only: false-colour error map to write (NULL: none) */
    bool all_vertices;        /* CSV: compare vertices facing away too */
} cmp_desc;

/* A per-vertex CSV file in memory, rows sorted by vertex id. */
typedef struct cmp_vertices {
    int n;
    int *ids;           /* [n] ascending */
    float *rgb;         /* [3n] */
    float *se;          /* [3n] standard errors, NULL when the file has no stderr columns */
    uint8_t *facing;    /* [n], NULL when the file has no facing column */
} cmp_vertices;

/* Metrics of a against reference b: n items of ch channels each (interleaved). If rel_err is
 * non-NULL it receives the per-item relative error e (see header) [n]. Returns 0, or -1 when b is
 * all zero and a is not, or a value is non-finite. */
int cmp_arrays(const float *a, const float *b, long n, int ch, cmp_result *out, float *rel_err, prt_error *err);

/* Reads a per-vertex CSV (see header). Returns 0 or -1; free with cmp_vertices_free. */
int cmp_read_vertex_csv(const char *path, cmp_vertices *out, prt_error *err);
void cmp_vertices_free(cmp_vertices *v);

/* Colour map: rgb in [0,1] (display values) of turbo at t in [0,1]. */
void cmp_colormap(float t, float rgb[3]);

/* Compares two files (kind from the extension: .csv is per-vertex, anything else an image).
 * desc may be NULL (defaults). */
int cmp_files(const char *a, const char *b, const cmp_desc *desc, cmp_result *out, prt_error *err);
#endif
