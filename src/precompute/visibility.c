/* visibility.c - Embree 3 ray casting for the visibility cube maps of section
 * 4.1 (Eq. 3's V) and for the gathering rays of section 4.2.
 *
 * The paper rasterizes a 6x128x128 visibility cube per vertex on the GPU; we
 * ray cast the same texel centres with Embree instead, which needs no simplified
 * "visibility model" and no GL context. Rays go out in 4x4 texel packets
 * (rtcOccluded16): neighbouring texels of one cube face have nearly parallel
 * directions from a common origin, so a packet traverses the BVH almost as one
 * ray. Packets whose 16 texels all lie below the horizon are never traced, so
 * about half the cube costs nothing.
 *
 * Rays settled without tracing (vis_cull_floor): a scene's floor is a flat rectangle under the
 * models, so a ray that goes down from above it and crosses its plane inside the rectangle is
 * blocked (by the floor, or by something before it). That is the answer Embree gives, so the cube
 * maps are byte for byte those of tracing everything (test: visibility/floor_culling). It saves a
 * model vertex the rays of its lower hemisphere, which would traverse the BVH to reach the floor:
 * the refined bunny + floor's direct pass takes 103 s with it, 130.5 s without. The converse for
 * the floor's vertices (their rays that miss the models' box are open) is not done: it settles 45%
 * of the reduced scene's rays but saves no time (130.6 s against 130.5 s on the refined scene),
 * since Embree leaves such a packet at the first nodes anyway.
 *
 * Buffers: Embree reads vertex buffers with 16-byte SSE loads, so the last
 * float3 vertex must be followed by 4 readable bytes. A prt_mesh's pos array
 * is exactly 3*nverts floats, so we copy the positions into a padded buffer
 * that the vis_scene owns (12 bytes a vertex: 430 KB for the bunny); the
 * triangle index buffer needs no padding and is shared with the mesh, which
 * therefore must outlive the vis_scene.
 *
 * Self-intersection: a ray leaves p + eps n with tnear = eps (eps from the
 * bounding-box diagonal and the largest coordinate magnitude, see
 * visibility.h), so it neither re-hits the triangles around p nor loses the
 * float precision of a model far from the origin.
 *
 * Device configuration: $PRT_EMBREE_CONFIG, when set, is passed as rtcNewDevice's config
 * string (Embree's "key=value,..." syntax), e.g. PRT_EMBREE_CONFIG=isa=sse4.2 caps the SIMD
 * width that Embree otherwise picks by CPU, and "verbose=1" prints the ISA it chose. Unset or
 * empty: Embree's defaults. `make test-portable` runs the suite once capped this way, so the
 * tests' tolerances are checked against a traversal that another CPU would run
 * (tools/test_portable.sh). It is read where the device is created, not kept in any global.
 *
 * Scale: Embree's triangle test multiplies three lengths (a distance times an edge cross
 * product), which leaves float at scene sizes near 1e13 or 1e-13 (a sphere over a plane at
 * 1e15 lost its shadows; at 1e-15 and 1e20 every ray escaped). So the copy Embree holds is
 * scaled by k, the power of two that brings the bounding-box diagonal into [1, 2), and every
 * ray's origin, tnear and tfar are scaled by k on the way in and hit distances by 1/k on the
 * way out. A power of two is exact in float, so Embree solves exactly the caller's problem in
 * units where the scene is about 1 across, whatever the caller's units (docs/design/scale.md).
 *
 * Thread safety: the Embree scene is immutable after rtcCommitScene, and every
 * call builds its own RTCIntersectContext on the stack. */
#include "visibility.h"
#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct vis_scene {
    RTCDevice device;
    RTCScene scene;
    float *pos;      /* owned padded copy of the mesh positions times k [3*nverts + 4] */
    float eps;       /* the ray offset in the caller's units */
    float k, kinv;   /* Embree's units per caller unit (a power of two) and its inverse */
    float eps_k;     /* eps * k */
    int ntris;
    /* vis_cull_floor: a ray that goes down (d.up < 0) from above the floor (o.up > floor_top)
     * and crosses its plane (floor_h) inside the rectangle [u0, u1] x [v0, v1] of the in-plane
     * axes tu, tv (shrunk by a margin) at t > tnear + eps is blocked untraced. Set only when the
     * floor is flat and its triangles tile that rectangle (their areas sum to its area). Lengths
     * are in Embree's units (times k). */
    bool cull;
    float up[3], tu[3], tv[3], floor_top, floor_h, u0, u1, v0, v1;
};

/* Embree's error code as words (for the one-line messages). */
static const char *vis_rtc_error_name(enum RTCError e) {
    switch (e) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    default: return "unknown error";
    }
}

/* Frees everything vis_create allocated; safe on a half-built scene. */
void vis_destroy(vis_scene *vs) {
    if (!vs) return;
    if (vs->scene) rtcReleaseScene(vs->scene);
    if (vs->device) rtcReleaseDevice(vs->device);
    free(vs->pos);
    free(vs);
}

/* Sets k = 2^-e with the diagonal times k in [1, 2), held where the largest coordinate times k
 * stays below 2^64 (a scene far smaller than its distance from the origin), and 1 for an empty
 * or single-point scene. */
static void vis_choose_scale(vis_scene *vs, double diag, double maxabs) {
    int e = 0;
    if (diag > 0 && isfinite(diag)) e = ilogb(diag);
    if (maxabs > 0 && isfinite(maxabs) && ilogb(maxabs) - e > 63) e = ilogb(maxabs) - 63;
    e = e < -120 ? -120 : e > 120 ? 120 : e;   /* k and 1/k normal floats */
    vs->k = ldexpf(1.f, -e);
    vs->kinv = ldexpf(1.f, e);
    vs->eps_k = vs->eps * vs->k;
}

/* Builds the Embree scene over m. Returns a scene the caller frees with vis_destroy, or NULL
 * with err set (an invalid mesh or an Embree failure; nothing to free then). */
vis_scene *vis_create(const prt_mesh *m, prt_error *err) {
    if (!m || m->nverts < 0 || m->ntris < 0 || (m->ntris > 0 && (!m->pos || !m->tris))) {
        prt_fail(err, "visibility: invalid mesh");
        return NULL;
    }
    /* Embree does not range-check indices: a bad one would be read out of bounds. */
    for (size_t i = 0; i < 3 * (size_t)m->ntris; i++)
        if (m->tris[i] >= (uint32_t)m->nverts) {
            prt_fail(err, "visibility: triangle %zu uses vertex %u of %d", i / 3, m->tris[i], m->nverts);
            return NULL;
        }
    vis_scene *vs = prt_calloc(1, sizeof *vs, err);
    if (!vs) return NULL;
    vs->ntris = m->ntris;
    /* Padded copy: 4 floats of slack after the last vertex (see the file comment). */
    vs->pos = prt_calloc((size_t)3 * (size_t)m->nverts + 4, sizeof(float), err);
    if (!vs->pos) { vis_destroy(vs); return NULL; }

    /* eps: 1e-4 of the bounding-box diagonal plus 1e-6 of the largest coordinate magnitude. */
    double lo[3] = { 0, 0, 0 }, hi[3] = { 0, 0, 0 }, maxabs = 0;
    for (int v = 0; v < m->nverts; v++)
        for (int c = 0; c < 3; c++) {
            double x = m->pos[3 * v + c];
            if (v == 0 || x < lo[c]) lo[c] = x;
            if (v == 0 || x > hi[c]) hi[c] = x;
            if (fabs(x) > maxabs) maxabs = fabs(x);
        }
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    vs->eps = (float)(1e-4 * diag + 1e-6 * maxabs);
    if (!(vs->eps > 0)) vs->eps = 1e-6f;
    vis_choose_scale(vs, diag, maxabs);
    for (size_t i = 0; i < 3 * (size_t)m->nverts; i++) vs->pos[i] = m->pos[i] * vs->k;

    /* $PRT_EMBREE_CONFIG: Embree's device config (see the file comment); NULL for its defaults. */
    const char *cfg = getenv("PRT_EMBREE_CONFIG");
    if (cfg && !*cfg) cfg = NULL;
    vs->device = rtcNewDevice(cfg);
    if (!vs->device) {
        prt_fail(err, "visibility: cannot create the Embree device%s%s: %s", cfg ? " with PRT_EMBREE_CONFIG=" : "",
                 cfg ? cfg : "", vis_rtc_error_name(rtcGetDeviceError(NULL)));
        vis_destroy(vs);
        return NULL;
    }
    vs->scene = rtcNewScene(vs->device);
    if (!vs->scene) {
        prt_fail(err, "visibility: cannot create the Embree scene: %s", vis_rtc_error_name(rtcGetDeviceError(vs->device)));
        vis_destroy(vs);
        return NULL;
    }
    /* Robust (watertight) traversal: measured on the bunny + floor it costs ~10% of the ray rate
     * (26 against 29 Mrays/s a core) and closes ~2 leaks in 10^7 rays through shared edges; a leak is a
     * pinhole that can let the sun through, so we pay. RTC_BUILD_QUALITY_HIGH gives no measurable
     * traversal gain, so the build is Embree's default (medium). */
    rtcSetSceneFlags(vs->scene, RTC_SCENE_FLAG_ROBUST);
    if (m->ntris > 0) {
        RTCGeometry g = rtcNewGeometry(vs->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (!g) {
            prt_fail(err, "visibility: cannot create the Embree geometry: %s",
                     vis_rtc_error_name(rtcGetDeviceError(vs->device)));
            vis_destroy(vs);
            return NULL;
        }
        rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vs->pos, 0, 3 * sizeof(float),
                                   (size_t)m->nverts);
        rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m->tris, 0, 3 * sizeof(uint32_t),
                                   (size_t)m->ntris);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(vs->scene, g, 0);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(vs->scene);
    enum RTCError e = rtcGetDeviceError(vs->device);
    if (e != RTC_ERROR_NONE) {
        prt_fail(err, "visibility: building the Embree scene failed: %s", vis_rtc_error_name(e));
        vis_destroy(vs);
        return NULL;
    }
    return vs;
}

/* The ray offset chosen at creation. */
float vis_eps(const vis_scene *vs) { return vs->eps; }

/* In-plane axes of the unit normal up with tu x tv = up (an axis-aligned floor keeps an
 * axis-aligned rectangle: up = +y gives tu = +x, tv = -z). */
static void vis_plane_axes(const double up[3], double tu[3], double tv[3]) {
    const double a[3] = { fabs(up[0]) < 0.9 ? 1 : 0, fabs(up[0]) < 0.9 ? 0 : 1, 0 };
    const double d = a[0] * up[0] + a[1] * up[1];
    double l = 0;
    for (int c = 0; c < 3; c++) { tu[c] = a[c] - d * up[c]; l += tu[c] * tu[c]; }
    for (int c = 0; c < 3; c++) tu[c] /= sqrt(l);
    tv[0] = up[1] * tu[2] - up[2] * tu[1];
    tv[1] = up[2] * tu[0] - up[0] * tu[2];
    tv[2] = up[0] * tu[1] - up[1] * tu[0];
}

/* See visibility.h. The floor's triangles (all three vertices >= floor_first) must be flat to
 * far below eps, face up, and tile the rectangle their in-plane extents span: then the floor
 * covers every point of that rectangle, shrunk by a margin far above float rounding (the ray
 * offset), and a ray that crosses the plane there from above meets it, or something before. */
void vis_cull_floor(vis_scene *vs, const prt_mesh *m, int floor_first) {
    vs->cull = false;
    if (floor_first < 0 || floor_first >= m->nverts || !m->nrm) return;
    const float *u = m->nrm + 3 * (size_t)floor_first;
    const double ul = sqrt((double)u[0] * u[0] + (double)u[1] * u[1] + (double)u[2] * u[2]);
    if (!(ul > 0.5)) return;
    double up[3] = { u[0] / ul, u[1] / ul, u[2] / ul }, tu[3], tv[3];
    vis_plane_axes(up, tu, tv);
    double top = -INFINITY, bot = INFINITY, r[4] = { INFINITY, -INFINITY, INFINITY, -INFINITY }, area = 0;
    bool any = false, upward = true;
    for (int t = 0; t < m->ntris; t++) {
        const uint32_t *tr = m->tris + 3 * (size_t)t;
        if (tr[0] < (uint32_t)floor_first || tr[1] < (uint32_t)floor_first || tr[2] < (uint32_t)floor_first) continue;
        double q[3][2];
        for (int k = 0; k < 3; k++) {
            const float *x = m->pos + 3 * (size_t)tr[k];
            const double h = x[0] * up[0] + x[1] * up[1] + x[2] * up[2];
            top = fmax(top, h); bot = fmin(bot, h);
            q[k][0] = x[0] * tu[0] + x[1] * tu[1] + x[2] * tu[2];
            q[k][1] = x[0] * tv[0] + x[1] * tv[1] + x[2] * tv[2];
            r[0] = fmin(r[0], q[k][0]); r[1] = fmax(r[1], q[k][0]); r[2] = fmin(r[2], q[k][1]); r[3] = fmax(r[3], q[k][1]);
        }
        /* signed area in the plane: tu x tv = up, so a triangle facing up is positive */
        const double a2 = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
        upward &= a2 > 0;
        area += 0.5 * fabs(a2);
        any = true;
    }
    const double e = vs->eps, rect = (r[1] - r[0]) * (r[3] - r[2]);
    if (!any || !upward || !(top - bot < 0.01 * e) || !(fabs(area - rect) <= 1e-6 * rect) || !(r[1] - r[0] > 16 * e) ||
        !(r[3] - r[2] > 16 * e))
        return;
    for (int c = 0; c < 3; c++) { vs->up[c] = (float)up[c]; vs->tu[c] = (float)tu[c]; vs->tv[c] = (float)tv[c]; }
    /* in Embree's units: each length rounded to float as the caller's, then times k (exact) */
    const float k = vs->k;
    vs->floor_top = (float)(top + 0.25 * e) * k;   /* the margin: o.up is rounded once more */
    vs->floor_h = (float)bot * k;
    vs->u0 = (float)(r[0] + 4 * e) * k; vs->u1 = (float)(r[1] - 4 * e) * k;
    vs->v0 = (float)(r[2] + 4 * e) * k; vs->v1 = (float)(r[3] - 4 * e) * k;
    vs->cull = true;
}

/* 1/sqrt(x) for x in [1, 3] (a face-plane direction's squared length) to ~1e-7 relative: the
 * bit-level first guess plus three Newton steps. Unlike sqrtf (errno), it is branch- and
 * call-free, so the 16-lane direction loop below vectorizes. */
static inline float vis_rsqrt(float x) {
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    u = 0x5f375a86u - (u >> 1);
    float y;
    memcpy(&y, &u, sizeof y);
    y = y * (1.5f - 0.5f * x * y * y);
    y = y * (1.5f - 0.5f * x * y * y);
    y = y * (1.5f - 0.5f * x * y * y);
    return y;
}

/* Face f's texel directions are d = o + sc * a + tc * b (cubemap.h's table, unnormalized). */
static const float vis_face_o[6][3] = { { 1, 0, 0 }, { -1, 0, 0 }, { 0, 1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 } };
static const float vis_face_a[6][3] = { { 0, 0, -1 }, { 0, 0, 1 }, { 1, 0, 0 }, { 1, 0, 0 }, { 1, 0, 0 }, { -1, 0, 0 } };
static const float vis_face_b[6][3] = { { 0, -1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 }, { 0, -1, 0 }, { 0, -1, 0 } };

/* Lane l of a 4x4 packet is texel (bi + l % 4, bj + l / 4). */
static const float vis_lane_s[16] = { 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3 };
static const float vis_lane_t[16] = { 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3 };

/* Sets the fields of packet r that every packet of one vertex shares: origin p + eps n, tnear eps,
 * in Embree's units (times k, exact: the same floats as the caller's units times k). */
static inline void vis_packet_origin(const vis_scene *vs, struct RTCRay16 *r, const float p[3], const float n[3]) {
    const float eps = vs->eps, k = vs->k;
    for (int l = 0; l < 16; l++) {
        r->org_x[l] = (p[0] + eps * n[0]) * k;
        r->org_y[l] = (p[1] + eps * n[1]) * k;
        r->org_z[l] = (p[2] + eps * n[2]) * k;
        r->tnear[l] = vs->eps_k;
        r->time[l] = 0;
        r->mask[l] = 0xffffffffu;
        r->id[l] = (unsigned)l;
        r->flags[l] = 0;
    }
}

/* Sets the 16 normalized directions o + sc a + tc b of the packet whose first texel centre is
 * (sc0, tc0), and resets tfar; straight-line over the lanes so it vectorizes. */
static inline void vis_packet_dirs(struct RTCRay16 *r, const float *o, const float *a, const float *b, float sc0,
                                   float tc0, float inv) {
    for (int l = 0; l < 16; l++) {
        const float sc = sc0 + vis_lane_s[l] * inv, tc = tc0 + vis_lane_t[l] * inv;
        const float dx = o[0] + sc * a[0] + tc * b[0], dy = o[1] + sc * a[1] + tc * b[1];
        const float dz = o[2] + sc * a[2] + tc * b[2];
        const float q = vis_rsqrt(dx * dx + dy * dy + dz * dz);
        r->dir_x[l] = dx * q;
        r->dir_y[l] = dy * q;
        r->dir_z[l] = dz * q;
        r->tfar[l] = INFINITY;
    }
}

/* Marks valid[l] (-1 / 0) the lanes of packet (bi, bj) inside the face and above the horizon,
 * n.d = no + sc na + tc nb > 0; returns their count. */
static inline int vis_packet_valid(int *valid, int res, int bi, int bj, float sc0, float tc0, float inv, float no,
                                   float na, float nb) {
    int nvalid = 0;
    for (int l = 0; l < 16; l++) {
        const int i = bi + (l & 3), j = bj + (l >> 2);
        const float sc = sc0 + vis_lane_s[l] * inv, tc = tc0 + vis_lane_t[l] * inv;
        const int ok = i < res && j < res && no + sc * na + tc * nb > 0;
        valid[l] = ok ? -1 : 0;
        nvalid += ok;
    }
    return nvalid;
}

/* See visibility.h. */
bool vis_culling(const vis_scene *vs) { return vs->cull; }

/* Settles the lanes of r that go down from o (above the floor: the caller checked) and cross the
 * floor's rectangle past tnear + eps: they are blocked, valid[l] is cleared and got[l] = 1 (else 0).
 * Returns how many lanes are left to trace. */
static int vis_packet_cull(const vis_scene *vs, const struct RTCRay16 *r, const float o[3], int *valid, int *got) {
    const float oh = o[0] * vs->up[0] + o[1] * vs->up[1] + o[2] * vs->up[2] - vs->floor_h;
    const float ou = o[0] * vs->tu[0] + o[1] * vs->tu[1] + o[2] * vs->tu[2];
    const float ov = o[0] * vs->tv[0] + o[1] * vs->tv[1] + o[2] * vs->tv[2];
    int left = 0;
    for (int l = 0; l < 16; l++) {
        const float dx = r->dir_x[l], dy = r->dir_y[l], dz = r->dir_z[l];
        const float du = dx * vs->up[0] + dy * vs->up[1] + dz * vs->up[2];
        const float t = du < 0 ? oh / -du : 0;   /* where the ray crosses the floor's plane */
        const float qu = ou + t * (dx * vs->tu[0] + dy * vs->tu[1] + dz * vs->tu[2]);
        const float qv = ov + t * (dx * vs->tv[0] + dy * vs->tv[1] + dz * vs->tv[2]);
        got[l] = valid[l] && du < 0 && t > r->tnear[l] + vs->eps_k && qu > vs->u0 && qu < vs->u1 && qv > vs->v0 && qv < vs->v1;
        if (got[l]) valid[l] = 0;
        left += valid[l] != 0;
    }
    return left;
}

/* Fills vis[6*res*res] (1 = escapes); see visibility.h.
 * n.d is linear in (sc, tc) on a face, so its extremes over a 4x4 packet's texel centres are at
 * the packet's corner centres: a packet with all four corners below the horizon is skipped
 * without touching its lanes, and one with all four above needs no per-lane test. Texel
 * coordinates (i + 0.5) 2/res - 1 are exact in float for res a power of two, so the per-lane
 * test gives exactly opposite answers for antipodal texels: exactly half the cube is traced. */
void vis_cube(const vis_scene *vs, const float p[3], const float n[3], int res, uint8_t *vis, long *traced, long *hits) {
    const float inv = 2.0f / (float)res;
    long nt = 0, nh = 0;
    memset(vis, 0, (size_t)6 * res * res);
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(64) struct RTCRay16 r;
    RTC_ALIGN(64) int valid[16];
    vis_packet_origin(vs, &r, p, n);
    const float org[3] = { r.org_x[0], r.org_y[0], r.org_z[0] };
    /* A normal within 2.6 degrees of the floor's up (every floor vertex) has next to no rays down: the
     * per-lane test would find none to settle, so it is left out (tracing is always exact). */
    const bool cull = vs->cull && n[0] * vs->up[0] + n[1] * vs->up[1] + n[2] * vs->up[2] < 0.999f &&
                      org[0] * vs->up[0] + org[1] * vs->up[1] + org[2] * vs->up[2] > vs->floor_top;
    int got[16];
    for (int face = 0; face < 6; face++) {
        uint8_t *fv = vis + (size_t)face * res * res;
        const float *o = vis_face_o[face], *a = vis_face_a[face], *b = vis_face_b[face];
        /* n.d = no + sc na + tc nb */
        const float no = n[0] * o[0] + n[1] * o[1] + n[2] * o[2];
        const float na = n[0] * a[0] + n[1] * a[1] + n[2] * a[2];
        const float nb = n[0] * b[0] + n[1] * b[1] + n[2] * b[2];
        /* whole face below the horizon (its four corners are): nothing to trace */
        if (no + fabsf(na) + fabsf(nb) <= 0) continue;
        for (int bj = 0; bj < res; bj += 4) {
            const float tc0 = (bj + 0.5f) * inv - 1.0f;
            for (int bi = 0; bi < res; bi += 4) {
                const float sc0 = (bi + 0.5f) * inv - 1.0f;
                const float s3 = 3 * inv;
                float c00 = no + sc0 * na + tc0 * nb, c10 = c00 + s3 * na, c01 = c00 + s3 * nb, c11 = c10 + s3 * nb;
                float cmax = fmaxf(fmaxf(c00, c10), fmaxf(c01, c11)), cmin = fminf(fminf(c00, c10), fminf(c01, c11));
                /* the margin covers rounding, so the shortcuts agree with the per-lane test exactly
                 * (which keeps antipodal texels' decisions complementary) */
                if (!(cmax > -1e-5f)) continue;
                const bool all_up = cmin > 1e-5f && bi + 4 <= res && bj + 4 <= res;
                vis_packet_dirs(&r, o, a, b, sc0, tc0, inv);
                int nvalid = 16;
                if (!all_up) nvalid = vis_packet_valid(valid, res, bi, bj, sc0, tc0, inv, no, na, nb);
                else
                    for (int l = 0; l < 16; l++) valid[l] = -1;
                if (!nvalid) continue;
                nt += nvalid;   /* the culled lanes count as traced: the plan's hit share stays per ray */
                if (cull) {
                    const int left = vis_packet_cull(vs, &r, org, valid, got);
                    for (int l = 0; l < 16; l++) nh += got[l];   /* blocked: vis stays 0 */
                    if (!left) continue;
                }
                rtcOccluded16(valid, vs->scene, &ctx, &r);
                for (int l = 0; l < 16; l++) {
                    if (!valid[l]) continue;
                    const bool open = r.tfar[l] >= 0;   /* Embree sets tfar = -inf on a hit */
                    fv[(bj + (l >> 2)) * res + bi + (l & 3)] = (uint8_t)open;
                    nh += !open;
                }
            }
        }
    }
    if (traced) *traced = nt;
    if (hits) *hits = nh;
}

/* See visibility.h: packets of 16 from vis_cube's origin, lanes below the horizon left out. */
long vis_open_many(const vis_scene *vs, const float p[3], const float n[3], const float *dirs, int count, uint8_t *open) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTC_ALIGN(64) struct RTCRay16 r;
    RTC_ALIGN(64) int valid[16];
    vis_packet_origin(vs, &r, p, n);
    long nt = 0;
    for (int b = 0; b < count; b += 16) {
        int nvalid = 0;
        for (int l = 0; l < 16; l++) {
            const float *d = dirs + 3 * (size_t)(b + l);
            const bool up = b + l < count && d[0] * n[0] + d[1] * n[1] + d[2] * n[2] > 0;
            valid[l] = up ? -1 : 0;
            nvalid += up;
            r.dir_x[l] = up ? d[0] : 0; r.dir_y[l] = up ? d[1] : 0; r.dir_z[l] = up ? d[2] : 1;
            r.tfar[l] = INFINITY;
        }
        if (nvalid) rtcOccluded16(valid, vs->scene, &ctx, &r);
        nt += nvalid;
        for (int l = 0; l < 16 && b + l < count; l++) open[b + l] = (uint8_t)(valid[l] && r.tfar[l] >= 0);
    }
    return nt;
}

/* One closest-hit query; false (and hit->tri = -1) on a miss. */
bool vis_closest(const vis_scene *vs, const float org[3], const float dir[3], float tnear, float tfar, vis_hit *hit) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    const float k = vs->k;
    rh.ray.org_x = org[0] * k; rh.ray.org_y = org[1] * k; rh.ray.org_z = org[2] * k;
    rh.ray.dir_x = dir[0]; rh.ray.dir_y = dir[1]; rh.ray.dir_z = dir[2];
    rh.ray.tnear = tnear * k;
    rh.ray.tfar = tfar * k;
    rh.ray.time = 0;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(vs->scene, &ctx, &rh);
    bool got = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    if (hit) {
        hit->tri = got ? (int)rh.hit.primID : -1;
        hit->u = got ? rh.hit.u : 0;
        hit->v = got ? rh.hit.v : 0;
        hit->t = got ? rh.ray.tfar * vs->kinv : INFINITY;
        hit->ng[0] = got ? rh.hit.Ng_x : 0;
        hit->ng[1] = got ? rh.hit.Ng_y : 0;
        hit->ng[2] = got ? rh.hit.Ng_z : 0;
    }
    return got;
}

/* Closest hits of n rays from org, 16 at a time (rtcIntersect16); misses get tri = -1. */
void vis_closest_many(const vis_scene *vs, const float org[3], const float *dirs, int n, float tnear, vis_hit *hits) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(64) struct RTCRayHit16 rh;
    RTC_ALIGN(64) int valid[16];
    const float k = vs->k, o[3] = { org[0] * k, org[1] * k, org[2] * k };
    for (int b = 0; b < n; b += 16) {
        int m = n - b < 16 ? n - b : 16;
        for (int l = 0; l < 16; l++) {
            valid[l] = l < m ? -1 : 0;
            const float *d = dirs + 3 * (size_t)(b + (l < m ? l : 0));
            rh.ray.org_x[l] = o[0]; rh.ray.org_y[l] = o[1]; rh.ray.org_z[l] = o[2];
            rh.ray.dir_x[l] = d[0]; rh.ray.dir_y[l] = d[1]; rh.ray.dir_z[l] = d[2];
            rh.ray.tnear[l] = tnear * k;
            rh.ray.tfar[l] = INFINITY;
            rh.ray.time[l] = 0;
            rh.ray.mask[l] = 0xffffffffu;
            rh.ray.id[l] = (unsigned)l;
            rh.ray.flags[l] = 0;
            rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.primID[l] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect16(valid, vs->scene, &ctx, &rh);
        for (int l = 0; l < m; l++) {
            vis_hit *h = &hits[b + l];
            bool got = rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID;
            h->tri = got ? (int)rh.hit.primID[l] : -1;
            h->u = got ? rh.hit.u[l] : 0;
            h->v = got ? rh.hit.v[l] : 0;
            h->t = got ? rh.ray.tfar[l] * vs->kinv : INFINITY;
            h->ng[0] = got ? rh.hit.Ng_x[l] : 0;
            h->ng[1] = got ? rh.hit.Ng_y[l] : 0;
            h->ng[2] = got ? rh.hit.Ng_z[l] : 0;
        }
    }
}

/* Any-hit query: true when something blocks the segment. */
bool vis_occluded(const vis_scene *vs, const float org[3], const float dir[3], float tnear, float tfar) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    const float k = vs->k;
    r.org_x = org[0] * k; r.org_y = org[1] * k; r.org_z = org[2] * k;
    r.dir_x = dir[0]; r.dir_y = dir[1]; r.dir_z = dir[2];
    r.tnear = tnear * k;
    r.tfar = tfar * k;
    r.time = 0;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(vs->scene, &ctx, &r);
    return r.tfar < 0;
}
