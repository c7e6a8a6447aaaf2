/* relight.h - CPU relighting: colour = h(view) . g(light) per vertex (Eq. 5).
 *
 * Usage:
 *     relight_ctx *rc = relight_create(&data, &err);     // data is SHARED: keep it alive
 *     relight_set_light(rc, L);       // light change: sparse T x L for every vector (both cores)
 *     relight_view(rc, eye, rgb);     // view change: view maps at each vertex's view direction
 *     relight_destroy(rc);
 *
 * The light-dependent K-vectors g are cached between calls, so a view change
 * costs only the view-map lookups and a K-term dot product per vertex. kmax
 * limits the terms used (0: all). Lambertian materials skip the lookups.
 *
 * Several transfers: relight handles the sparse ones (ops->linear->light_range), each
 * with its own g and its own light vector (relight_set_light_at); a vertex's
 * colour is the sum over the sparse transfers whose mask holds its material.
 * Non-linear transfers (vmf) are not relight's: the runtime adds their
 * ops->view->shade_vertices. relight_set_light, relight_use_direct and the gvec calls
 * concern the first sparse transfer (prt_data_transfer), the only one today. */
#ifndef PRT_RELIGHT_H
#define PRT_RELIGHT_H
#include "prtfile.h"

typedef struct relight_ctx relight_ctx;

relight_ctx *relight_create(const prt_data *d, int nthreads, prt_error *err);
void relight_destroy(relight_ctx *rc);
/* L: [CUBE_TEXELS][4] light vector (light.h) of the first sparse transfer. */
void relight_set_light(relight_ctx *rc, const float (*L)[4]);
/* The light change of transfer i of the data (index in d->transfers; PRT_CHECKed to be sparse). */
void relight_set_light_at(relight_ctx *rc, int i, const float (*L)[4]);
/* Adds open[3 * nvecs] to transfer i's g (the open sky of a split transfer, runtime_light.open), after its
 * light change. */
void relight_add_open(relight_ctx *rc, int i, const float *open);
/* Light changes from now on use the direct-only transport (true; only when the file keeps
 * one, prt_data_transfer(d)->direct.nvecs > 0) or direct + bounces (false, the default). Returns false when
 * the direct set is asked for but absent. Call relight_set_light again to see the change. */
bool relight_use_direct(relight_ctx *rc, bool direct);
/* The cached light-dependent K-vectors ([3 * nvecs]). */
const float *relight_gvec(const relight_ctx *rc);
/* Per-vertex outgoing radiance toward eye: rgb[3*nverts]. kmax 0 = all terms. */
void relight_view(relight_ctx *rc, const float eye[3], int kmax, float *rgb);
/* Outgoing radiance of vertex v toward a unit world direction wo (for tests and the reference). */
void relight_vertex(const relight_ctx *rc, int v, const float wo[3], int kmax, float rgb[3]);
/* Textures (texture.h): each textured vertex's sum is multiplied by its texture sample (the
 * default, apply true) or left without it (false: the part a raster multiplies per pixel).
 * relight_albedo gives the samples ([3 * nverts]; NULL when the scene has no texture). */
void relight_apply_albedo(relight_ctx *rc, bool apply);
const float *relight_albedo(const relight_ctx *rc);
/* Replaces the cached K-vectors with g[3 * nvecs] computed elsewhere (the GL runtime's, read back),
 * so that relight_view finishes them per vertex. */
void relight_set_gvec(relight_ctx *rc, const float *g);
#endif
