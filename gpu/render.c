/* render.c - the headless offscreen rasterizer of per-vertex colours (render.h);
 * the camera it draws through lives in src/core/camera.c.
 *
 * render_vertex_colors makes a headless GL context for the call (OSMesa, or
 * EGL when $PRT_GL=egl; glctx.h), draws into a 32-bit float framebuffer through gldraw.c (background from the
 * probe per pixel, then the mesh with Gouraud colours and a depth test), and
 * reads the linear radiance back. */
#include "render.h"
#include "gldraw.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* See render.h; out is the caller's (image_free); -1 with err. */
int render_vertex_colors(const prt_mesh *m, const float *rgb, const render_desc *d, prt_image *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    int w = d->width, h = d->height;
    if (w == 0 && h == 0) { w = 800; h = 600; }
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384)
        return prt_fail(err, "render: image size %dx%d out of range (1..16384)", w, h);
    if (m->ntris > 0 && (!rgb || m->nverts <= 0)) return prt_fail(err, "render: no vertex colours");
    /* OSMesa unless $PRT_GL says otherwise: this is the CPU backend's raster, it must work on any
     * machine (the GPU path, EGL, is the GLSL runtime's; glrt.h). */
    glctx_kind kind;
    if (glctx_kind_from_env(GLCTX_OSMESA, &kind, err)) return -1;
    glctx *ctx = glctx_create(kind, NULL, err);
    if (!ctx) return -1;
    gldraw gd;
    int rc = -1;
    if (gldraw_init(&gd, &ctx->gl, err) == 0 && gldraw_set_mesh(&gd, m, err) == 0 &&
        gldraw_set_probe(&gd, d->background, err) == 0 && gldraw_target(&gd, w, h, err) == 0) {
        gldraw_background(&gd, &d->camera, w, h, d->background_rotation);
        if (gldraw_vertex_colors(&gd, &d->camera, w, h, rgb, err) == 0) rc = gldraw_read(&gd, out, err);
    }
    gldraw_free(&gd);
    glctx_destroy(ctx);
    return rc;
}
