/* render.h - offscreen rasterization of per-vertex colours (the camera: camera.h).
 *
 * Usage:
 *     prt_camera cam; camera_default(bmin, bmax, 4.0f/3, &cam);
 *     render_desc d = { .width = 800, .height = 600, .camera = cam };
 *     prt_image img;
 *     if (render_vertex_colors(&mesh, rgb, &d, &img, &err)) puts(err.msg);
 *
 * render_desc (the frame: size, camera, background) is frame.h's, GL-free.
 * Rendering is headless through OSMesa (no window or display needed; the
 * "dummy backend" that lets GL-facing code run in CI); $PRT_GL=egl selects an
 * EGL device context instead (gpu/glctx.h). The framebuffer is
 * 32-bit float, so the image holds linear radiance (HDR) for EXR output;
 * colours are interpolated (Gouraud) between vertices as in the paper. Where no
 * surface is drawn the background is the probe seen through the camera (if
 * given), else black.
 *
 * Ownership: the returned image belongs to the caller (image_free). */
#ifndef PRT_RENDER_H
#define PRT_RENDER_H
#include "common.h"
#include "frame.h"
#include "mesh.h"
#include "image.h"

/* Rasterizes m with per-vertex colours rgb[3*nverts] into a linear RGB float image. */
int render_vertex_colors(const prt_mesh *m, const float *rgb, const render_desc *d, prt_image *out, prt_error *err);
struct prt_scene;
/* The same for a textured scene (texture.h): each pixel tex(uv) A + B, with A = rgb[0, 3n) the part
 * the texture multiplies and B = rgb[3n, 6n) the rest, both Gouraud; the texture per pixel. */
int render_textured_colors(const struct prt_scene *sc, const float *rgb, const render_desc *d, prt_image *out, prt_error *err);
#endif
