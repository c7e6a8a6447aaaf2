/* camera.c - the pinhole camera every image of prt is made through (camera.h):
 * look-at frames, framing of bounds, parsing, GL matrices and per-pixel rays.
 * The camera math here is the single source of truth: the rasterizer, the
 * background shader and the reference path tracer build rays exactly as
 * camera_ray does. */
#include "camera.h"
#include "vec3.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Orthonormal forward/right/up of cam (see camera.h). */
void camera_basis(const prt_camera *cam, float fwd[3], float right[3], float up[3]) {
    v3_sub(fwd, cam->target, cam->eye);
    if (v3_normalize(fwd) == 0.0f) v3_set(fwd, 0, 0, -1);
    float u[3];
    v3_copy(u, cam->up);
    if (v3_len(u) == 0.0f) v3_set(u, 0, 1, 0);
    v3_cross(right, fwd, u);
    if (v3_len(right) < 1e-6f * v3_len(u)) {
        /* up parallel to the view: fall back to world y, or z when looking along y. */
        v3_set(u, 0, 1, 0);
        if (fabsf(fwd[1]) > 0.999f) v3_set(u, 0, 0, -1);
        v3_cross(right, fwd, u);
    }
    v3_normalize(right);
    v3_cross(up, right, fwd);
    v3_normalize(up);
}

/* Frames the box: its bounding sphere fits the narrower half field of view. */
void camera_default(const float bmin[3], const float bmax[3], float aspect, prt_camera *out) {
    float c[3];
    double r2 = 0;   /* double: a box 1e20 across squares past FLT_MAX, one 1e-20 across below FLT_MIN */
    for (int i = 0; i < 3; i++) {
        float lo = bmin[i], hi = bmax[i];
        if (!isfinite(lo) || !isfinite(hi) || hi < lo) lo = hi = 0;
        c[i] = 0.5f * lo + 0.5f * hi;
        r2 += 0.25 * ((double)hi - lo) * ((double)hi - lo);
    }
    float r = (float)sqrt(r2);       /* the bounding sphere holds every corner of the box */
    if (!(r > 0) || !isfinite(r)) r = 1;
    if (!(aspect > 0) || !isfinite(aspect)) aspect = 4.0f / 3;
    out->fov_deg = 40;
    float half_v = 20.0f * (float)M_PI / 180.0f;
    float half_h = atanf(tanf(half_v) * aspect);
    float half = half_v < half_h ? half_v : half_h;
    float dist = r / sinf(half) * 1.02f; /* the sphere's cone fits inside the narrower half angle */
    /* Three-quarter view from above, on the -z side: 145 degrees around from +z toward +x (35 from
     * -z), 25 degrees up. The shared models face -z (Spot's head; the bunny and the teapot are seen
     * side on from either side), so a view from +z would show Spot from behind. */
    float az = 145.0f * (float)M_PI / 180.0f, el = 25.0f * (float)M_PI / 180.0f;
    float dir[3] = { sinf(az) * cosf(el), sinf(el), cosf(az) * cosf(el) };
    v3_copy(out->target, c);
    v3_madd(out->eye, c, dir, dist);
    v3_set(out->up, 0, 1, 0);
}

void camera_lower(prt_camera *cam, float el_deg, float pitch_deg, float fov_deg) {
    float d[3];
    v3_sub(d, cam->eye, cam->target);
    float dist = v3_len(d), hl = v3_len((const float[3]){ d[0], 0, d[2] });
    if (!(hl > 0) || !(dist > 0)) return;   /* looking straight down or at itself: no azimuth to keep */
    float hx = d[0] / hl, hz = d[2] / hl, el = el_deg * (float)M_PI / 180, pitch = pitch_deg * (float)M_PI / 180;
    v3_set(cam->eye, cam->target[0] + dist * cosf(el) * hx, cam->target[1] + dist * sinf(el), cam->target[2] + dist * cosf(el) * hz);
    v3_set(cam->target, cam->eye[0] - dist * cosf(pitch) * hx, cam->eye[1] - dist * sinf(pitch), cam->eye[2] - dist * cosf(pitch) * hz);
    v3_set(cam->up, 0, 1, 0);
    cam->fov_deg = fov_deg;
}

/* Parses 3, 6 or 7 comma-separated finite numbers into cam; NULL (cam set) or why not (cam unchanged). */
const char *camera_parse_error(const char *s, prt_camera *cam) {
    static const char *const k_syntax = "expected EX,EY,EZ[,TX,TY,TZ[,FOV]] (3, 6 or 7 numbers)";
    if (!s) return k_syntax;
    float v[7];
    int n = 0;
    const char *p = s;
    for (;;) {
        char *end;
        while (*p == ' ' || *p == '\t') p++;
        float x = strtof(p, &end);
        if (end == p || !isfinite(x) || n == 7) return k_syntax;
        v[n++] = x;
        p = end;
        while (*p == ' ' || *p == '\t') p++;
        if (*p == 0) break;
        if (*p != ',') return k_syntax;
        p++;
    }
    if (n != 3 && n != 6 && n != 7) return k_syntax;
    prt_camera c = *cam;
    v3_set(c.eye, v[0], v[1], v[2]);
    if (n >= 6) v3_set(c.target, v[3], v[4], v[5]);
    if (n == 7) {
        if (!(v[6] > 0 && v[6] < 180)) return "the field of view must be between 0 and 180 degrees";
        c.fov_deg = v[6];
    }
    float d[3];
    v3_sub(d, c.target, c.eye);
    if (v3_len(d) == 0.0f) return "the eye and the target coincide (the camera would look nowhere)";
    if (v3_len(c.up) == 0.0f) v3_set(c.up, 0, 1, 0);
    *cam = c;
    return NULL;
}

int camera_parse(const char *s, prt_camera *cam) { return camera_parse_error(s, cam) ? -1 : 0; }

/* gluLookAt / gluPerspective equivalents, column-major. */
void camera_matrices(const prt_camera *cam, float aspect, float znear, float zfar, float view[16], float proj[16]) {
    float f[3], r[3], u[3];
    camera_basis(cam, f, r, u);
    memset(view, 0, 16 * sizeof(float));
    for (int i = 0; i < 3; i++) {
        view[i * 4 + 0] = r[i];
        view[i * 4 + 1] = u[i];
        view[i * 4 + 2] = -f[i];
    }
    view[12] = -v3_dot(r, cam->eye);
    view[13] = -v3_dot(u, cam->eye);
    view[14] = v3_dot(f, cam->eye);
    view[15] = 1;
    float fov = cam->fov_deg > 0 ? cam->fov_deg : 40.0f;
    float t = 1.0f / tanf(fov * (float)M_PI / 360.0f);
    memset(proj, 0, 16 * sizeof(float));
    proj[0] = t / aspect;
    proj[5] = t;
    proj[10] = (zfar + znear) / (znear - zfar);
    proj[11] = -1;
    /* double: the product of the planes leaves float for scenes beyond ~1e19 or below ~1e-19 */
    proj[14] = (float)(2.0 * zfar * znear / ((double)znear - zfar));
}

/* Unit ray through continuous image point (px, py), top-left origin. */
void camera_ray(const prt_camera *cam, int w, int h, float px, float py, float dir[3]) {
    float f[3], r[3], u[3];
    camera_basis(cam, f, r, u);
    float fov = cam->fov_deg > 0 ? cam->fov_deg : 40.0f;
    float ty = tanf(fov * (float)M_PI / 360.0f), tx = ty * (float)w / (float)h;
    float sx = (2.0f * px / (float)w - 1.0f) * tx, sy = (1.0f - 2.0f * py / (float)h) * ty;
    for (int i = 0; i < 3; i++) dir[i] = f[i] + sx * r[i] + sy * u[i];
    v3_normalize(dir);
}
