/* planfx.c - the effects plan's measurements (planfx.h): the local lights' one bounce at a sample
 * of vertices, by a few rays each, and the floor's vertex spacing against a sun's penumbra. */
#include "planfx.h"
#include "lights.h"
#include "vec3.h"
#include <math.h>
#include <string.h>

/* An orthonormal frame (s, t) around unit n (Duff et al. 2017's branchless construction). */
static void pf_frame(const float n[3], float s[3], float t[3]) {
    float sign = copysignf(1.f, n[2]), a = -1.f / (sign + n[2]), b = n[0] * n[1] * a;
    v3_set(s, 1.f + sign * n[0] * n[0] * a, sign * b, -sign * n[0]);
    v3_set(t, b, sign + n[1] * n[1] * a, -n[1]);
}

/* A hash of v to [0, 1) (splitmix64's finalizer): the lattice shift of one vertex. */
static double pf_hash01(uint64_t v) {
    v += 0x9e3779b97f4a7c15ull;
    v = (v ^ (v >> 30)) * 0xbf58476d1ce4e5b9ull;
    v = (v ^ (v >> 27)) * 0x94d049bb133111ebull;
    v ^= v >> 31;
    return (double)(v >> 11) * 0x1p-53;
}

/* Luminance of the light every local light sends to point p (normal n) reflected by material bp
 * toward wo, shadowed (one ray each); E_d when bp is NULL (irradiance: no BRDF). Counts its rays. */
static double pf_direct(const prt_scene *s, const vis_scene *vs, const brdf_params *bp, const float p[3], const float n[3],
                        const float wo[3], long *rays) {
    float eps = vis_eps(vs), org[3], sum[3] = { 0, 0, 0 };
    v3_madd(org, p, n, eps);
    for (int l = 0; l < s->lights.count; l++) {
        const prt_light *lt = &s->lights.light[l];
        float wi[3], rgb[3], d;
        if (bp) {
            d = light_shade(lt, bp, p, n, wo, wi, rgb);
        } else {
            v3_sub(wi, lt->pos, p);
            d = v3_normalize(wi);
            float c = v3_dot(n, wi), away[3] = { -wi[0], -wi[1], -wi[2] };
            if (!(d > 0.f) || c <= 0.f) continue;
            light_intensity_toward(lt, away, rgb);
            v3_scale(rgb, rgb, c / (d * d));
        }
        if (!(d > 0.f) || prt_luminancef(rgb) <= 0.f) continue;
        ++*rays;
        if (!vis_occluded(vs, org, wi, eps, d - 2 * eps)) v3_add(sum, sum, rgb);
    }
    return prt_luminance(sum);
}

/* The radiance luminance the first hit along dir from p reflects back toward p (0: a miss or a
 * surface's back). Counts its rays. */
static double pf_hit_radiance(const prt_scene *s, const vis_scene *vs, const float p[3], const float n[3], const float dir[3],
                              long *rays) {
    const prt_mesh *m = &s->mesh;
    float eps = vis_eps(vs), org[3];
    v3_madd(org, p, n, eps);
    vis_hit h;
    ++*rays;
    if (!vis_closest(vs, org, dir, eps, INFINITY, &h) || h.tri < 0) return 0;
    const uint32_t *t = m->tris + 3 * h.tri;
    float w[3] = { 1.f - h.u - h.v, h.u, h.v }, q[3] = { 0, 0, 0 }, nq[3] = { 0, 0, 0 }, wo[3] = { -dir[0], -dir[1], -dir[2] };
    for (int k = 0; k < 3; k++) {
        v3_madd(q, q, m->pos + 3 * t[k], w[k]);
        v3_madd(nq, nq, m->nrm + 3 * t[k], w[k]);
    }
    if (v3_normalize(nq) <= 0.f || v3_dot(nq, wo) <= 0.f) return 0;
    int mat = m->mat ? m->mat[t[0]] : 0;
    return pf_direct(s, vs, &s->materials[mat], q, nq, wo, rays);
}

/* E_1 at vertex v: pi times the mean hit radiance over `rays` cosine-distributed lattice directions. */
static double pf_bounce_at(const prt_scene *s, const vis_scene *vs, int v, int rays, long *nrays) {
    const float *p = s->mesh.pos + 3 * v, *n = s->mesh.nrm + 3 * v;
    float ts[3], tt[3];
    pf_frame(n, ts, tt);
    const double a = pf_hash01(2 * (uint64_t)v), b = pf_hash01(2 * (uint64_t)v + 1), phi = 0.5 * (1 + sqrt(5.0));
    double sum = 0;
    for (int i = 0; i < rays; i++) {
        double u1 = fmod((i + a) / rays, 1.0), u2 = fmod(i / phi + b, 1.0);
        double r = sqrt(u1), ph = 2 * M_PI * u2, z = sqrt(fmax(0.0, 1 - u1));
        float dir[3];
        for (int k = 0; k < 3; k++) dir[k] = (float)(r * cos(ph) * ts[k] + r * sin(ph) * tt[k] + z * n[k]);
        v3_normalize(dir);
        sum += pf_hit_radiance(s, vs, p, n, dir, nrays);
    }
    return M_PI * sum / rays;
}

void planfx_measure_bounce(const prt_scene *s, const vis_scene *vs, const int *verts, int n, int rays, planfx_bounce *out) {
    memset(out, 0, sizeof *out);
    if (s->lights.count == 0 || rays <= 0) return;
    for (int i = 0; i < n; i++) {
        int v = verts[i];
        const float *p = s->mesh.pos + 3 * v, *nv = s->mesh.nrm + 3 * v;
        bool glossy = s->materials[s->mesh.mat ? s->mesh.mat[v] : 0].type != BRDF_LAMBERT;
        double e1 = pf_bounce_at(s, vs, v, rays, &out->rays);
        out->direct += pf_direct(s, vs, NULL, p, nv, NULL, &out->rays);
        out->bounce += e1;
        if (glossy) { out->glossy += e1; out->glossy_vertices++; }
        out->vertices++;
    }
}

/* The mean of the shortest edge of each floor triangle (the triangles whose vertices are all first or later). */
static double pf_floor_spacing(const prt_mesh *m, int first) {
    double sum = 0;
    int cnt = 0;
    for (int t = 0; t < m->ntris; t++) {
        const uint32_t *tri = m->tris + 3 * t;
        if ((int)tri[0] < first || (int)tri[1] < first || (int)tri[2] < first) continue;
        float best = INFINITY;
        for (int k = 0; k < 3; k++) {
            float e[3];
            v3_sub(e, m->pos + 3 * tri[k], m->pos + 3 * tri[(k + 1) % 3]);
            best = fminf(best, v3_len(e));
        }
        sum += best;
        cnt++;
    }
    return cnt ? sum / cnt : 0;
}

void planfx_measure_receivers(const prt_scene *s, planfx_receivers *out) {
    memset(out, 0, sizeof *out);
    const prt_mesh *m = &s->mesh;
    int first = s->floor_first_vertex;
    out->point_light = s->lights.count > 0;
    if (first < 0 || first >= m->nverts) return;
    out->floor = true;
    float fy = m->pos[3 * first + 1], top = fy;
    for (int v = 0; v < first; v++) top = fmaxf(top, m->pos[3 * v + 1]);
    out->models = first > 0 && top > fy;
    out->spacing = pf_floor_spacing(m, first);
    out->height = top - fy;
    out->penumbra = out->height * tan(PLANFX_SUN_RAD);
    out->refine = out->models && (out->point_light || out->spacing > out->penumbra);
}
