/* test_render.c - cameras and the headless rasterizer (gpu/render.h).
 *
 * Truths are independent of the GL path: pixel colours are compared with the
 * perspective-correct barycentric interpolation obtained by intersecting
 * camera_ray with the triangles on the CPU, the background with an analytic
 * function of the ray direction that the probe texels sample, and the camera
 * matrices with the pixel coordinates camera_ray was built from; multisampling's
 * resolve against the sample counts its coverage allows (antialias). */
#include "harness.h"
#include "glctx.h"
#include "render.h"
#include "vec3.h"
#include <stdlib.h>
#include <string.h>

/* Ray-triangle intersection (Moller-Trumbore): t and barycentrics (b1, b2) of vertices 1, 2. */
static bool ray_tri(const float o[3], const float d[3], const float *p0, const float *p1, const float *p2, float *t,
                    float *b1, float *b2) {
    float e1[3], e2[3], pv[3], tv[3], qv[3];
    v3_sub(e1, p1, p0);
    v3_sub(e2, p2, p0);
    v3_cross(pv, d, e2);
    float det = v3_dot(e1, pv);
    if (fabsf(det) < 1e-12f) return false;
    float inv = 1.0f / det;
    v3_sub(tv, o, p0);
    *b1 = v3_dot(tv, pv) * inv;
    v3_cross(qv, tv, e1);
    *b2 = v3_dot(d, qv) * inv;
    *t = v3_dot(e2, qv) * inv;
    return *t > 0;
}

/* Expected colour of pixel (x, y) by CPU ray casting; returns 1 when the pixel is inside a triangle by a
 * margin, 0 when it misses every triangle by a margin, -1 when it is too close to an edge to say. */
static int expected_pixel(const prt_mesh *m, const float *rgb, const prt_camera *cam, int w, int h, int x, int y,
                          float out[3]) {
    float d[3];
    camera_ray(cam, w, h, x + 0.5f, y + 0.5f, d);
    float best = INFINITY;
    int state = 0;
    for (int t = 0; t < m->ntris; t++) {
        const uint32_t *v = m->tris + 3 * t;
        float tt, b1, b2;
        if (!ray_tri(cam->eye, d, m->pos + 3 * v[0], m->pos + 3 * v[1], m->pos + 3 * v[2], &tt, &b1, &b2)) continue;
        float b0 = 1 - b1 - b2, mn = fminf(b0, fminf(b1, b2));
        if (mn > -0.02f && mn < 0.02f) state = -1;
        if (mn >= 0.02f && tt < best) {
            best = tt;
            for (int c = 0; c < 3; c++)
                out[c] = b0 * rgb[3 * v[0] + c] + b1 * rgb[3 * v[1] + c] + b2 * rgb[3 * v[2] + c];
        }
    }
    if (state == -1) return -1;
    return best < INFINITY ? 1 : 0;
}

/* Two quads: a near one (z = 0) and a far one (z = -1) shifted right; colours per vertex. */
static void make_scene(prt_mesh *m, float **rgb, bool far_first) {
    static const float quad[4][2] = { { -1, -1 }, { 1, -1 }, { 1, 1 }, { -1, 1 } };
    m->nverts = 8;
    m->ntris = 4;
    m->pos = calloc(24, sizeof(float));
    m->nrm = calloc(24, sizeof(float));
    m->tris = calloc(12, sizeof(uint32_t));
    m->mat = calloc(8, sizeof(uint16_t));
    *rgb = calloc(24, sizeof(float));
    for (int q = 0; q < 2; q++)
        for (int i = 0; i < 4; i++) {
            int v = 4 * q + i;
            m->pos[3 * v] = quad[i][0] + (q ? 0.8f : 0.0f);
            m->pos[3 * v + 1] = quad[i][1];
            m->pos[3 * v + 2] = q ? -1.0f : 0.0f;
            m->nrm[3 * v + 2] = 1;
            /* Near quad: red ramp + blue per corner; far quad: green. */
            (*rgb)[3 * v + 0] = q ? 0.0f : 0.25f + 0.5f * (float)i;
            (*rgb)[3 * v + 1] = q ? 1.0f + (float)i : 0.0f;
            (*rgb)[3 * v + 2] = q ? 0.0f : (i == 2 ? 3.0f : 0.1f);
        }
    uint32_t t[12] = { 0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7 };
    if (far_first)
        for (int i = 0; i < 12; i++) t[i] = (t[i] + 4) % 8;
    memcpy(m->tris, t, sizeof t);
}

static void free_scene(prt_mesh *m, float *rgb) {
    free(m->pos);
    free(m->nrm);
    free(m->tris);
    free(m->mat);
    free(rgb);
}

/* A latlong probe whose texels hold f(d) = (1 + d.x, 1 + d.y, 1 + d.z) at texel centres (smooth, so
 * bilinear lookups approach f to O(texel^2)). */
static void make_probe(prt_probe *p, int w) {
    memset(p, 0, sizeof *p);
    p->layout = PROBE_LATLONG;
    p->img.w = w;
    p->img.h = w / 2;
    p->img.c = 3;
    p->img.data = calloc((size_t)w * (w / 2) * 3, sizeof(float));
    for (int y = 0; y < w / 2; y++)
        for (int x = 0; x < w; x++) {
            float phi = ((x + 0.5f) / w - 0.5f) * 2 * (float)M_PI, th = (y + 0.5f) / (w / 2) * (float)M_PI;
            float d[3] = { sinf(th) * sinf(phi), cosf(th), -sinf(th) * cosf(phi) };
            for (int c = 0; c < 3; c++) p->img.data[3 * ((size_t)y * w + x) + c] = 1 + d[c];
        }
    p->max_value = 2;
}

static void camera(void) {
    prt_camera cam = { .eye = { 0, 0, 5 }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 40 };
    prt_camera c = cam;
    CHECK(camera_parse("1,2,3", &c) == 0, "eye only rejected");
    CHECK(c.eye[0] == 1 && c.eye[1] == 2 && c.eye[2] == 3 && c.target[2] == 0 && c.fov_deg == 40, "eye only: target/fov not kept");
    CHECK(camera_parse(" 1, 2 ,3,4,5,6,30", &c) == 0, "7 numbers rejected");
    CHECK(c.target[0] == 4 && c.target[1] == 5 && c.target[2] == 6 && c.fov_deg == 30, "7 numbers parsed wrong");
    const char *bad[] = { "", "1,2", "1,2,3,4", "a,b,c", "1,2,3,", "1,2,3,4,5,6,200", "1,2,3,1,2,3", "1,2,3,4,5,6,7,8",
                          "1,2,nan", "1,2,3x" };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        prt_camera b = cam;
        CHECK(camera_parse(bad[i], &b) == -1, "'%s' accepted", bad[i]);
        CHECK(memcmp(&b, &cam, sizeof b) == 0, "'%s' changed the camera", bad[i]);
    }

    /* camera_ray and the matrices agree: a point along the ray through (px, py) projects to that pixel. */
    prt_camera cams[2] = { { .eye = { 1, 2, 5 }, .target = { 0, 0.5f, 0 }, .up = { 0, 1, 0 }, .fov_deg = 50 },
                           { .eye = { 0, 6, 0 }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 0 } };
    double worst = 0, worst_len = 0;
    for (int k = 0; k < 2; k++) {
        int w = 320, h = 200;
        float view[16], proj[16];
        camera_matrices(&cams[k], (float)w / h, 0.1f, 100, view, proj);
        for (int s = 0; s < 25; s++) {
            float px = (float)(s % 5) / 4 * w, py = (float)(s / 5) / 4 * h, d[3];
            camera_ray(&cams[k], w, h, px, py, d);
            worst_len = fmax(worst_len, fabs(v3_len(d) - 1));
            float p[4] = { cams[k].eye[0] + 3 * d[0], cams[k].eye[1] + 3 * d[1], cams[k].eye[2] + 3 * d[2], 1 }, e[4], c4[4];
            for (int r = 0; r < 4; r++) {
                e[r] = 0;
                for (int j = 0; j < 4; j++) e[r] += view[j * 4 + r] * p[j];
            }
            for (int r = 0; r < 4; r++) {
                c4[r] = 0;
                for (int j = 0; j < 4; j++) c4[r] += proj[j * 4 + r] * e[j];
            }
            double nx = c4[0] / c4[3], ny = c4[1] / c4[3];
            worst = fmax(worst, fabs((nx + 1) * 0.5 * w - px));
            worst = fmax(worst, fabs((1 - ny) * 0.5 * h - py));
            /* Eye space: the point lies 3 units away, in front of the camera (-z). */
            CHECK_NEAR(sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), 3.0, 1e-4, "eye-space distance");
            CHECK(e[2] < 0, "point behind the camera");
        }
    }
    CHECK_LE(worst, 1e-3, "pixel mismatch between camera_ray and camera_matrices");
    CHECK_LE(worst_len, 1e-6, "ray not unit length");

    /* camera_default: every corner of the box projects inside the image, from above. */
    const float bmin[3] = { -2, 0, -1 }, bmax[3] = { 3, 1.5f, 0.5f };
    const float aspects[3] = { 4.0f / 3, 0.5f, 2.5f };
    for (int a = 0; a < 3; a++) {
        prt_camera dc;
        camera_default(bmin, bmax, aspects[a], &dc);
        CHECK(dc.eye[1] > dc.target[1] && dc.fov_deg > 0, "default camera not above the target");
        float view[16], proj[16];
        camera_matrices(&dc, aspects[a], 0.01f, 1000, view, proj);
        double maxndc = 0;
        for (int c = 0; c < 8; c++) {
            float p[4] = { c & 1 ? bmax[0] : bmin[0], c & 2 ? bmax[1] : bmin[1], c & 4 ? bmax[2] : bmin[2], 1 }, e[4], c4[4];
            for (int r = 0; r < 4; r++) {
                e[r] = 0;
                for (int j = 0; j < 4; j++) e[r] += view[j * 4 + r] * p[j];
            }
            for (int r = 0; r < 4; r++) {
                c4[r] = 0;
                for (int j = 0; j < 4; j++) c4[r] += proj[j * 4 + r] * e[j];
            }
            CHECK(c4[3] > 0, "corner behind the camera");
            maxndc = fmax(maxndc, fmax(fabs(c4[0] / c4[3]), fabs(c4[1] / c4[3])));
        }
        CHECK_LE(maxndc, 1.0, "aspect %g: a corner is out of view", aspects[a]);
        CHECK(maxndc > 0.5, "aspect %g: the box is tiny in view (%g)", aspects[a], maxndc);
    }
}

static void raster(void) {
    prt_camera cam = { .eye = { 0.3f, 0.2f, 4 }, .target = { 0.3f, 0, -0.5f }, .up = { 0, 1, 0 }, .fov_deg = 45 };
    const int w = 160, h = 120;
    prt_image ref = { 0 };
    for (int order = 0; order < 2; order++) {
        prt_mesh m = { 0 };
        float *rgb;
        make_scene(&m, &rgb, order == 1);
        render_desc d = { .width = w, .height = h, .camera = cam };
        prt_image img;
        prt_error err = { { 0 } };
        int rc = render_vertex_colors(&m, rgb, &d, &img, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) { free_scene(&m, rgb); continue; }
        CHECK(img.w == w && img.h == h && img.c == 3, "image %dx%dx%d", img.w, img.h, img.c);
        double maxerr = 0;
        int checked = 0, inside = 0, outside_bad = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                float e[3];
                int s = expected_pixel(&m, rgb, &cam, w, h, x, y, e);
                const float *p = img.data + 3 * ((size_t)y * w + x);
                if (s == 1) {
                    inside++;
                    for (int c = 0; c < 3; c++) maxerr = fmax(maxerr, fabs(p[c] - e[c]) / (1 + fabs(e[c])));
                } else if (s == 0 && (p[0] != 0 || p[1] != 0 || p[2] != 0)) outside_bad++;
                if (s >= 0) checked++;
            }
        /* Float interpolation in GL vs the CPU ray cast: well below 8-bit output precision. */
        CHECK_LE(maxerr, 2e-3, "order %d: colour mismatch", order);
        CHECK(outside_bad == 0, "order %d: %d background pixels not black", order, outside_bad);
        CHECK(checked > w * h * 9 / 10, "only %d of %d pixels were decidable", checked, w * h);
        CHECK(inside > w * h / 5, "the quads cover only %d pixels", inside);
        if (order == 0) ref = img;
        else {
            /* Draw order does not matter (depth test). */
            double diff = 0;
            for (size_t i = 0; i < (size_t)w * h * 3; i++) diff = fmax(diff, fabs(img.data[i] - ref.data[i]));
            CHECK_LE(diff, 1e-6, "draw order changed the image");
            image_free(&img);
        }
        free_scene(&m, rgb);
    }
    image_free(&ref);
}

/* Multisampling (render_desc.samples): a square of constant radiance 8 (beyond 1: the resolve must
 * average linear floats, not clamped or 8-bit codes), turned 20 degrees in its plane so its edges cross
 * the pixel grid obliquely, over black. With one sample every pixel is 0 or 8; with 4, every pixel is
 * 8 k / 4 for the k of its 4 samples the square covers (2, 4 and 6 are exact floats), the pixels whose
 * 3 x 3 neighbourhood of the one-sample image is uniform keep their value (multisampling changes
 * edges only), pixels strictly between 0 and 8 exist and each lies next to a one-sample edge, and
 * samples 0 is samples 1. */
static void antialias(void) {
    const int w = 64, h = 48;
    const float a = 20 * (float)M_PI / 180, c = cosf(a), sn = sinf(a);
    const float corners[4][2] = { { -1, -1 }, { 1, -1 }, { 1, 1 }, { -1, 1 } };
    float pos[12], rgb[12];
    uint32_t tris[6] = { 0, 1, 2, 0, 2, 3 };
    for (int i = 0; i < 4; i++) {
        pos[3 * i] = c * corners[i][0] - sn * corners[i][1];
        pos[3 * i + 1] = sn * corners[i][0] + c * corners[i][1];
        pos[3 * i + 2] = 0;
        rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = 8;
    }
    prt_mesh m = { .nverts = 4, .ntris = 2, .pos = pos, .tris = tris };
    prt_camera cam = { .eye = { 0, 0, 4 }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 40 };
    prt_image img[3];
    prt_error err = { { 0 } };
    const int samples[3] = { 1, 4, 0 };
    for (int k = 0; k < 3; k++) {
        render_desc d = { .width = w, .height = h, .camera = cam, .samples = samples[k] };
        CHECK(render_vertex_colors(&m, rgb, &d, &img[k], &err) == 0, "samples %d: %s", samples[k], err.msg);
    }
    int odd1 = 0, odd4 = 0, mixed = 0, moved = 0, lone = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const size_t i = 3 * ((size_t)y * w + x);
            const float v1 = img[0].data[i], v4 = img[1].data[i];
            odd1 += v1 != 0 && v1 != 8;
            odd4 += v4 != 0 && v4 != 2 && v4 != 4 && v4 != 6 && v4 != 8;
            bool uniform = true, edge_near = false;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
                    uniform &= img[0].data[3 * ((size_t)yy * w + xx)] == v1;
                }
            edge_near = !uniform;
            moved += uniform && v4 != v1;
            if (v4 > 0 && v4 < 8) {
                mixed++;
                lone += !edge_near;
            }
        }
    CHECK(odd1 == 0, "one sample: %d pixels neither 0 nor 8", odd1);
    CHECK(odd4 == 0, "4 samples: %d pixels not a multiple of 8 / 4", odd4);
    CHECK(moved == 0, "4 samples changed %d pixels away from every edge", moved);
    CHECK(mixed > 2 * (w + h) / 4 && lone == 0, "4 samples: %d edge pixels mixed, %d of them away from an edge", mixed, lone);
    CHECK(memcmp(img[0].data, img[2].data, sizeof(float) * 3 * w * h) == 0, "samples 0 is one sample");
    for (int k = 0; k < 3; k++) image_free(&img[k]);
}

/* One-sided, as prt reference: a square whose normals face the eye shows its colour; the same square
 * with its normals turned away (the inside of a body seen through a gap) is black at every pixel, and
 * one whose normals turn from toward to away across it is black exactly where the interpolated
 * normal faces away (the centre column's sign of n.(eye - p), linear in x). */
static void one_sided(void) {
    const int w = 32, h = 24;
    float pos[12] = { -1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0 }, rgb[12], nrm[12];
    uint32_t tris[6] = { 0, 1, 2, 0, 2, 3 };
    for (int i = 0; i < 12; i++) rgb[i] = 3;
    prt_mesh m = { .nverts = 4, .ntris = 2, .pos = pos, .tris = tris, .nrm = nrm };
    prt_camera cam = { .eye = { 0, 0, 4 }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 40 };
    prt_error err = { { 0 } };
    const float nz[3] = { 1, -1, 0 };   /* toward, away, and (0 below) mixed: +z at x = -1, -z at x = +1 */
    for (int k = 0; k < 3; k++) {
        for (int v = 0; v < 4; v++) {
            nrm[3 * v] = 0, nrm[3 * v + 1] = 0;
            nrm[3 * v + 2] = k < 2 ? nz[k] : -pos[3 * v];
        }
        prt_image img;
        render_desc d = { .width = w, .height = h, .camera = cam, .samples = 1 };
        CHECK(render_vertex_colors(&m, rgb, &d, &img, &err) == 0, "%s", err.msg);
        const float *c = img.data + 3 * ((size_t)(h / 2) * w + w / 2 - 4), *r = img.data + 3 * ((size_t)(h / 2) * w + w / 2 + 4);
        if (k == 0) CHECK(c[0] == 3 && r[0] == 3, "normals toward the eye: %g, %g", c[0], r[0]);
        if (k == 1) CHECK(c[0] == 0 && r[0] == 0, "normals away: %g, %g", c[0], r[0]);
        if (k == 2) CHECK(c[0] == 3 && r[0] == 0, "left half toward, right half away: %g, %g", c[0], r[0]);
        image_free(&img);
    }
}

/* Two vertical unit squares facing +z, centred at (0, 1), the back one (green) a gap g behind the front
 * one (red) and listed first, on a grey floor y = 0 tessellated over [-50, 50]^2. */
static void make_gap_scene(prt_mesh *m, float **rgb, float g) {
    prt_error err;
    memset(m, 0, sizeof *m);
    CHECK(mesh_make_plane(m, -50, 50, -50, 50, 0, 24, 24, &err) == 0, "%s", err.msg);
    const int nf = m->nverts;
    for (int q = 0; q < 2; q++) {
        prt_mesh sq = { 0 };
        CHECK(mesh_make_plane(&sq, -0.5f, 0.5f, -0.5f, 0.5f, 0, 2, 2, &err) == 0, "%s", err.msg);
        const float R[9] = { 1, 0, 0, 0, 0, -1, 0, 1, 0 }, t[3] = { 0, 1, q ? 0 : -g };   /* +y -> +z */
        mesh_transform(&sq, R, 1, t);
        CHECK(mesh_append(m, &sq, &err) == 0, "%s", err.msg);
        mesh_free(&sq);
    }
    *rgb = calloc((size_t)m->nverts * 3, sizeof(float));
    for (int v = 0; v < m->nverts; v++) {
        const bool back = v >= nf && v < nf + 4, front = v >= nf + 4;
        (*rgb)[3 * v] = front ? 1.0f : back ? 0.0f : 0.2f;
        (*rgb)[3 * v + 1] = back ? 1.0f : front ? 0.0f : 0.2f;
        (*rgb)[3 * v + 2] = back || front ? 0.0f : 0.2f;
    }
}

/* A floor much wider than the camera's distance reaches behind the camera, so the mesh bounds say
 * nothing about where the visible geometry starts. The near plane must still hold every visible
 * point and keep the depth steps at the squares far below their 0.2 mm gap: each pixel shows the
 * surface a CPU ray cast finds first (the back square, drawn first, must never win, nor the floor
 * at the image's bottom edge be cut). A near plane at 1e-5 of the far one (~6e-4 here) would step
 * the depth by ~3 mm at the squares (z^2 / znear * 2^-24) and let green through. A high camera
 * (above the bounds) and a low one (inside them). */
static void clip_planes(void) {
    const float g = 2e-4f;
    prt_mesh m;
    float *rgb;
    make_gap_scene(&m, &rgb, g);
    const prt_camera cams[2] = { { .eye = { 0.4f, 2.0f, 5 }, .target = { 0, 1, 0 }, .up = { 0, 1, 0 }, .fov_deg = 40 },
                                 { .eye = { -0.3f, 0.6f, 4 }, .target = { 0, 1, 0 }, .up = { 0, 1, 0 }, .fov_deg = 40 } };
    const int w = 160, h = 120;
    for (int k = 0; k < 2; k++) {
        render_desc d = { .width = w, .height = h, .camera = cams[k] };
        prt_image img;
        prt_error err = { { 0 } };
        int rc = render_vertex_colors(&m, rgb, &d, &img, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) continue;
        int front = 0, floor = 0, wrong = 0;
        double maxerr = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                float e[3];
                if (expected_pixel(&m, rgb, &cams[k], w, h, x, y, e) != 1) continue;
                const float *p = img.data + 3 * ((size_t)y * w + x);
                double err1 = 0;
                for (int c = 0; c < 3; c++) err1 = fmax(err1, fabs(p[c] - e[c]));
                maxerr = fmax(maxerr, err1);
                wrong += err1 > 0.1;   /* another surface (the colours differ by 0.2 or more) */
                front += e[0] == 1.0f;
                floor += e[0] == 0.2f && y >= h - 3;
            }
        printf("camera %d: %d wrong pixels (%d on the front square, %d on the floor's bottom rows), max error %.2g\n", k,
               wrong, front, floor, maxerr);
        CHECK(front > w * h / 40, "camera %d: the front square covers only %d pixels", k, front);
        CHECK(floor > w, "camera %d: the floor fills only %d pixels of the bottom rows", k, floor);
        CHECK(wrong == 0, "camera %d: %d pixels show another surface than the first hit", k, wrong);
        CHECK_LE(maxerr, 2e-3, "camera %d: colour mismatch", k);
        image_free(&img);
    }
    mesh_free(&m);
    free(rgb);
}

static void background(void) {
    prt_probe probe;
    make_probe(&probe, 512);
    prt_mesh empty = { 0 };
    const int w = 96, h = 64;
    prt_camera cam = { .eye = { 0, 0, 0 }, .target = { 0.3f, 0.8f, -1 }, .up = { 0, 1, 0 }, .fov_deg = 90 };
    /* Yaw 90 degrees about +y (row-major): a light at d moves to R d; the background shows f(R^T d). */
    const float R[9] = { 0, 0, 1, 0, 1, 0, -1, 0, 0 };
    for (int rot = 0; rot < 2; rot++) {
        render_desc d = { .width = w, .height = h, .camera = cam, .background = &probe,
                          .background_rotation = rot ? R : NULL };
        prt_image img;
        prt_error err = { { 0 } };
        int rc = render_vertex_colors(&empty, NULL, &d, &img, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) continue;
        double maxerr = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                float dir[3], q[3];
                camera_ray(&cam, w, h, x + 0.5f, y + 0.5f, dir);
                if (rot)
                    for (int i = 0; i < 3; i++) q[i] = R[0 * 3 + i] * dir[0] + R[1 * 3 + i] * dir[1] + R[2 * 3 + i] * dir[2];
                else v3_copy(q, dir);
                for (int c = 0; c < 3; c++) maxerr = fmax(maxerr, fabs(img.data[3 * ((size_t)y * w + x) + c] - (1 + q[c])));
            }
        /* Texel spacing pi/256: bilinear error of a linear-in-d function is ~(pi/256)^2 / 8. */
        CHECK_LE(maxerr, 2e-3, "rotation %d", rot);
        image_free(&img);
    }
    image_free(&probe.img);
}

/* A probe in another layout (angular, 1:1) is resampled to latlong through probe_eval: texels hold
 * f at the directions probe_pixel_dir gives, the background must show f of each pixel's ray. */
static void background_angular(void) {
    prt_probe p;
    memset(&p, 0, sizeof p);
    p.layout = PROBE_ANGULAR;
    p.img.w = p.img.h = 384;
    p.img.c = 3;
    p.img.data = calloc((size_t)384 * 384 * 3, sizeof(float));
    for (int y = 0; y < 384; y++)
        for (int x = 0; x < 384; x++) {
            float d[3], sa;
            if (!probe_pixel_dir(&p, x, y, d, &sa)) continue;
            for (int c = 0; c < 3; c++) p.img.data[3 * ((size_t)y * 384 + x) + c] = 1 + d[c];
        }
    prt_mesh empty = { 0 };
    const int w = 80, h = 60;
    /* Looking toward -z, the middle of the angular map (away from its singular rim at +z). */
    prt_camera cam = { .eye = { 0, 0, 0 }, .target = { 0.2f, -0.3f, -1 }, .up = { 0, 1, 0 }, .fov_deg = 70 };
    render_desc d = { .width = w, .height = h, .camera = cam, .background = &p };
    prt_image img;
    prt_error err = { { 0 } };
    int rc = render_vertex_colors(&empty, NULL, &d, &img, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        double maxerr = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                float dir[3];
                camera_ray(&cam, w, h, x + 0.5f, y + 0.5f, dir);
                for (int c = 0; c < 3; c++) maxerr = fmax(maxerr, fabs(img.data[3 * ((size_t)y * w + x) + c] - (1 + dir[c])));
            }
        /* Two bilinear resamplings (angular -> latlong -> pixel) of a linear function. */
        CHECK_LE(maxerr, 5e-3, "angular probe background");
        image_free(&img);
    }
    free(p.img.data);
}

static void errors_and_backends(void) {
    prt_mesh m = { 0 };
    float *rgb;
    make_scene(&m, &rgb, false);
    rgb[0] = NAN;
    rgb[4] = INFINITY;
    prt_camera cam = { .eye = { 0, 0, 4 }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 45 };
    prt_error err = { { 0 } };
    prt_image img;
    render_desc bad = { .width = -3, .height = 10, .camera = cam };
    CHECK(render_vertex_colors(&m, rgb, &bad, &img, &err) == -1, "negative size accepted");
    CHECK(strstr(err.msg, "size") != NULL, "%s", err.msg);
    render_desc d = { .width = 64, .height = 48, .camera = cam };
    const char *old = getenv("PRT_GL");
    char *saved = old ? strdup(old) : NULL;
    setenv("PRT_GL", "bogus", 1);
    err.msg[0] = 0;
    CHECK(render_vertex_colors(&m, rgb, &d, &img, &err) == -1, "PRT_GL=bogus accepted");
    CHECK(strstr(err.msg, "PRT_GL") != NULL, "%s", err.msg);
    /* OSMesa and EGL (Mesa's software device here, the GPU on an NVIDIA machine) give the same image. */
    prt_image im[2] = { { 0 } };
    const char *kinds[2] = { "osmesa", "egl" };
    for (int k = 0; k < 2; k++) {
        setenv("PRT_GL", kinds[k], 1);
        int rc = render_vertex_colors(&m, rgb, &d, &im[k], &err);
        CHECK(rc == 0, "%s: %s", kinds[k], err.msg);
        if (rc) continue;
        bool finite = true;
        for (size_t i = 0; i < (size_t)64 * 48 * 3; i++) finite = finite && isfinite(im[k].data[i]);
        CHECK(finite, "%s: non-finite pixel", kinds[k]);
    }
    if (im[0].data && im[1].data) {
        double diff = 0, sum = 0;
        for (size_t i = 0; i < (size_t)64 * 48 * 3; i++) {
            diff = fmax(diff, fabs(im[0].data[i] - im[1].data[i]));
            sum += im[0].data[i];
        }
        CHECK_LE(diff, 1e-4, "OSMesa and EGL images differ");
        CHECK(sum > 10, "empty image");
    }
    for (int k = 0; k < 2; k++) image_free(&im[k]);
    if (saved) setenv("PRT_GL", saved, 1);
    else unsetenv("PRT_GL");
    free(saved);
    free_scene(&m, rgb);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(camera);
    CHECK_CASE(raster);
    CHECK_CASE(antialias);
    CHECK_CASE(one_sided);
    CHECK_CASE(clip_planes);
    CHECK_CASE(background);
    CHECK_CASE(background_angular);
    CHECK_CASE(errors_and_backends);
    return check_summary();
}
