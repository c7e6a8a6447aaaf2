/* render.h - cameras and offscreen rasterization of per-vertex colours.
 *
 * Usage:
 *     prt_camera cam; camera_default(bmin, bmax, 4.0f/3, &cam);
 *     render_desc d = { .width = 800, .height = 600, .camera = cam };
 *     prt_image img;
 *     if (render_vertex_colors(&mesh, rgb, &d, &img, &err)) puts(err.msg);
 *
 * Rendering is headless through OSMesa (no window or display needed; the
 * "dummy backend" that lets GL-facing code run in CI); $PRT_GL=egl selects an
 * EGL device context instead (gpu/glctx.h). The framebuffer is
 * 32-bit float, so the image holds linear radiance (HDR) for EXR output;
 * colours are interpolated (Gouraud) between vertices as in the paper. Where no
 * surface is drawn the background is the probe seen through the camera (if
 * given), else black.
 *
 * Camera: perspective, vertical field of view fov_deg (0: 40). camera_default
 * frames the bounds from a three-quarter view above (every corner of the box in
 * view). camera_parse reads "ex,ey,ez[,tx,ty,tz[,fov]]".
 *
 * Ownership: the returned image belongs to the caller (image_free). */
#ifndef PRT_RENDER_H
#define PRT_RENDER_H
#include "common.h"
#include "mesh.h"
#include "image.h"
#include "probe.h"

typedef struct prt_camera {
    float eye[3], target[3], up[3];
    float fov_deg;
} prt_camera;

void camera_default(const float bmin[3], const float bmax[3], float aspect, prt_camera *out);
/* Parses "ex,ey,ez[,tx,ty,tz[,fov]]" into cam (target and fov keep cam's values when absent). Returns 0 or -1. */
int camera_parse(const char *s, prt_camera *cam);
/* Column-major 4x4 view and projection matrices (OpenGL conventions). */
void camera_matrices(const prt_camera *cam, float aspect, float znear, float zfar, float view[16], float proj[16]);
/* World-space unit direction of the ray through image point (px, py) of a w x h image, in
 * continuous pixel coordinates: (0, 0) is the top-left corner, so pixel (x, y)'s centre is
 * (x + 0.5, y + 0.5) (py grows downward). This is the ray GL rasterizes at that pixel centre. */
void camera_ray(const prt_camera *cam, int w, int h, float px, float py, float dir[3]);
/* Orthonormal camera frame: forward (eye -> target), right, up (up re-orthogonalized; when up
 * is zero or parallel to forward, world y, else z, is used instead). */
void camera_basis(const prt_camera *cam, float fwd[3], float right[3], float up[3]);

typedef struct render_desc {
    int width, height;           /* 0: 800 x 600 */
    prt_camera camera;
    const prt_probe *background; /* may be NULL */
    const float *background_rotation; /* 3x3 applied to the probe (as in probe_to_cube), may be NULL */
    bool direct_only;            /* GL runtime (glrt_render_image): light with the file's direct-only set */
} render_desc;

/* Rasterizes m with per-vertex colours rgb[3*nverts] into a linear RGB float image. */
int render_vertex_colors(const prt_mesh *m, const float *rgb, const render_desc *d, prt_image *out, prt_error *err);
#endif
