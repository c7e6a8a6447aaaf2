/* camera.h - the pinhole camera every image of prt is made through.
 *
 * Usage:
 *     prt_camera cam; camera_default(bmin, bmax, 4.0f/3, &cam);
 *     camera_parse("0,1,5,0,0,0,35", &cam);      // overrides, -1 on junk
 *     float dir[3]; camera_ray(&cam, w, h, x + 0.5f, y + 0.5f, dir);
 *
 * Perspective, vertical field of view fov_deg (0: 40). camera_default frames the
 * bounds from a three-quarter view above, from the -z side where the shared models
 * (Spot) face (every corner of the box in view).
 * camera_parse reads "ex,ey,ez[,tx,ty,tz[,fov]]". Pure math (no GL): the
 * rasterizer (gpu/render.h), the GLSL runtime and the reference path tracer all
 * build their rays from these functions, so their images line up pixel for pixel. */
#ifndef PRT_CAMERA_H
#define PRT_CAMERA_H
#include "common.h"

typedef struct prt_camera {
    float eye[3], target[3], up[3];
    float fov_deg;
} prt_camera;

void camera_default(const float bmin[3], const float bmax[3], float aspect, prt_camera *out);
/* Moves cam, keeping its target's distance and azimuth, to el_deg above the target and turns it to
 * look pitch_deg below the horizontal with a vertical field of fov_deg: the horizon then crosses
 * the image at tan(pitch) / (2 tan(fov/2)) above its middle (the demo's sky in its upper third). */
void camera_lower(prt_camera *cam, float el_deg, float pitch_deg, float fov_deg);
/* Parses "ex,ey,ez[,tx,ty,tz[,fov]]" into cam (target and fov keep cam's values when absent). Returns 0 or -1. */
int camera_parse(const char *s, prt_camera *cam);
/* camera_parse saying why: NULL (parsed into cam), else a static phrase (cam unchanged): the syntax,
 * a field of view outside (0, 180), or an eye on the target. */
const char *camera_parse_error(const char *s, prt_camera *cam);
/* Column-major 4x4 view and projection matrices (OpenGL conventions). */
void camera_matrices(const prt_camera *cam, float aspect, float znear, float zfar, float view[16], float proj[16]);
/* World-space unit direction of the ray through image point (px, py) of a w x h image, in
 * continuous pixel coordinates: (0, 0) is the top-left corner, so pixel (x, y)'s centre is
 * (x + 0.5, y + 0.5) (py grows downward). This is the ray GL rasterizes at that pixel centre. */
void camera_ray(const prt_camera *cam, int w, int h, float px, float py, float dir[3]);
/* Orthonormal camera frame: forward (eye -> target), right, up (up re-orthogonalized; when up
 * is zero or parallel to forward, world y, else z, is used instead). */
void camera_basis(const prt_camera *cam, float fwd[3], float right[3], float up[3]);
#endif
