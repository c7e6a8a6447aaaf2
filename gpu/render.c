/* render.c - the headless offscreen rasterizer of per-vertex colours (render.h);
 * the camera it draws through lives in src/core/camera.c.
 *
 * render_vertex_colors makes a headless GL context for the call (OSMesa, or
 * EGL when $PRT_GL=egl; glctx.h), draws into a 32-bit float framebuffer through gldraw.c (background from the
 * probe per pixel, then the mesh with Gouraud colours and a depth test), and
 * reads the linear radiance back. runtime_raster_gl (runtime.h) is the cpu
 * runtime's raster over it, headless or into the caller's context. */
#include "render.h"
#include "gldraw.h"
#include "runtime.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int render_frame(const prt_mesh *m, const prt_scene *sc, const float *rgb, const render_desc *d, prt_image *out,
                        prt_error *err);

/* See render.h; out is the caller's (image_free); -1 with err. */
int render_vertex_colors(const prt_mesh *m, const float *rgb, const render_desc *d, prt_image *out, prt_error *err) {
    return render_frame(m, NULL, rgb, d, out, err);
}

int render_textured_colors(const prt_scene *sc, const float *rgb, const render_desc *d, prt_image *out, prt_error *err) {
    return render_frame(&sc->mesh, sc, rgb, d, out, err);
}

/* One headless frame of m's colours rgb: [3n] plain, or with sc's textures [6n] (A, B). */
static int render_frame(const prt_mesh *m, const prt_scene *sc, const float *rgb, const render_desc *d, prt_image *out,
                        prt_error *err) {
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
    bool ready = gldraw_init(&gd, &ctx->gl, err) == 0;
    if (ready) gldraw_set_samples(&gd, d->samples);
    if (ready && gldraw_set_mesh(&gd, m, err) == 0 && gldraw_set_probe(&gd, d->background, err) == 0 &&
        gldraw_target(&gd, w, h, err) == 0) {
        gldraw_background(&gd, &d->camera, w, h, d->background_rotation);
        int dr = sc ? (gldraw_set_textures(&gd, sc, err) ? -1 : gldraw_textured_colors(&gd, &d->camera, w, h, rgb, rgb + 3 * (size_t)m->nverts, err))
                    : gldraw_vertex_colors(&gd, &d->camera, w, h, rgb, err);
        if (dr == 0) rc = gldraw_read(&gd, out, err);
    }
    gldraw_free(&gd);
    glctx_destroy(ctx);
    return rc;
}

/* ---------------------------------------------------------------- the runtime's vertex raster
 * runtime_raster_gl (runtime.h), what the cpu backend draws its colours with: headless, the frame
 * is kept and rasterized by render_vertex_colors when the image is read (so `prt render` makes
 * exactly what render_vertex_colors makes, and `prt bench` times the view change alone); with the
 * caller's context, a gldraw of its own whose float target present blits. */
typedef struct vc_raster {
    const prt_mesh *m;
    const prt_scene *sc;        /* textured (set_textures): colours are [6*nverts], A then B */
    glctx *ctx;                 /* the caller's, or NULL: headless */
    gldraw draw;                /* with ctx: the float target */
    bool draw_ready;
    const prt_probe *bg;        /* with ctx: the probe uploaded as background (and its pixels) */
    const float *bg_pixels;
    render_desc frame;          /* headless: the last frame asked for, rasterized at read */
    float frame_R[9];
} vc_raster;

/* Frees the GL objects made in the caller's context, then the state. */
static void vc_destroy(void *self) {
    vc_raster *r = self;
    if (!r) return;
    if (r->draw_ready && glctx_make_current(r->ctx, NULL) == 0) gldraw_free(&r->draw);
    free(r);
}

/* With a context: a gldraw with the mesh, made in it. NULL with err. */
static void *vc_create(const prt_mesh *m, glctx *ctx, prt_error *err) {
    vc_raster *r = prt_calloc(1, sizeof *r, err);
    if (!r) return NULL;
    r->m = m;
    r->ctx = ctx;
    if (ctx) {
        if (glctx_make_current(ctx, err) || gldraw_init(&r->draw, &ctx->gl, err)) { vc_destroy(r); return NULL; }
        r->draw_ready = true;
        if (gldraw_set_mesh(&r->draw, m, err)) { vc_destroy(r); return NULL; }
    }
    return r;
}

/* Into the caller's context: background (uploaded again only for another probe), then the colours,
 * finished. Headless: the frame kept (its rotation copied) for read. */
static int vc_draw(void *self, const render_desc *rd, const float *rgb, prt_error *err) {
    vc_raster *r = self;
    if (!r->ctx) {
        r->frame = *rd;
        if (rd->background_rotation) {
            memcpy(r->frame_R, rd->background_rotation, sizeof r->frame_R);
            r->frame.background_rotation = r->frame_R;
        }
        return 0;
    }
    if (glctx_make_current(r->ctx, err)) return -1;
    const prt_probe *p = rd->background;
    if (p != r->bg || (p && p->img.data != r->bg_pixels)) {
        if (gldraw_set_probe(&r->draw, p, err)) return -1;
        r->bg = p;
        r->bg_pixels = p ? p->img.data : NULL;
    }
    int w = rd->width, h = rd->height;
    gldraw_set_samples(&r->draw, rd->samples);
    if (gldraw_target(&r->draw, w, h, err)) return -1;
    gldraw_background(&r->draw, &rd->camera, w, h, rd->background_rotation);
    if (r->sc ? gldraw_textured_colors(&r->draw, &rd->camera, w, h, rgb, rgb + 3 * (size_t)r->m->nverts, err)
              : gldraw_vertex_colors(&r->draw, &rd->camera, w, h, rgb, err)) return -1;
    r->ctx->gl.Finish();
    return glctx_check(&r->ctx->gl, "cpu runtime: drawing", err);
}

/* The context's target, or the kept frame rasterized now of rgb (headless). */
static int vc_read(void *self, const float *rgb, prt_image *out, prt_error *err) {
    vc_raster *r = self;
    if (r->ctx) return glctx_make_current(r->ctx, err) ? -1 : gldraw_read(&r->draw, out, err);
    return r->sc ? render_textured_colors(r->sc, rgb, &r->frame, out, err) : render_vertex_colors(r->m, rgb, &r->frame, out, err);
}

/* Textures: kept for the headless frames, uploaded into the caller's context. */
static int vc_set_textures(void *self, const prt_scene *sc, prt_error *err) {
    vc_raster *r = self;
    if (sc->ntextures < 1 || !sc->mesh.uv || &sc->mesh != r->m) return 0;
    if (r->ctx && (glctx_make_current(r->ctx, err) || gldraw_set_textures(&r->draw, sc, err))) return -1;
    r->sc = sc;
    return 0;
}

/* Tone-mapped blit of the target to the window (nothing headless). */
static void vc_present(void *self, int win_w, int win_h, float exposure_stops) {
    vc_raster *r = self;
    if (r->ctx && glctx_make_current(r->ctx, NULL) == 0) gldraw_present(&r->draw, win_w, win_h, exposure_stops);
}

const runtime_raster runtime_raster_gl = {
    .create = vc_create,
    .destroy = vc_destroy,
    .draw = vc_draw,
    .read = vc_read,
    .present = vc_present,
    .set_textures = vc_set_textures,
};
