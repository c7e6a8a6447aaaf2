/* test_data.c - the example scenes of data/: each one loads with the scene loader
 * and is the scene its JSON says, counted independently of the loader.
 *
 * Truth used here, none of it the loader's own arithmetic:
 *  - vertex and triangle counts of procedural shapes from their closed forms (a
 *    sphere of R rings and S segments has 2 + (R-1) S vertices and 2 S
 *    triangles, ...), read off the JSON with cJSON and the defaults of scene.h;
 *  - the shared models' 'v' and 'f' line counts from ../shared/data/SOURCES.md;
 *  - the demo built in code (demo_in_code below, an independent construction of
 *    data/demo.json's scene), compared bit for bit, so `prt demo` draws that scene;
 *  - the command lines of tools/bench.sh and tools/study.sh, which data/bunny-floor.json
 *    and data/spot-floor.json must reproduce exactly.
 * A scene whose model file is missing (a checkout without ../shared/data) must fail
 * with one line naming that file: the test checks that line and prints it, so a
 * missing file is visible and never passes silently. */
#include "harness.h"
#include "scene.h"
#include "vec3.h"
#include <cjson/cJSON.h>
#include <glob.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char g_data[PATH_MAX];     /* the repository's data/ folder */
static char g_shared[PATH_MAX];   /* a shared/ folder holding data/models, or "" */

static bool exists(const char *path) { return access(path, R_OK) == 0; }

/* snprintf that counts a truncated path as a failure rather than using it. */
__attribute__((format(printf, 3, 4))) static void sfmt(char *out, size_t cap, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(out, cap, fmt, ap);
    va_end(ap);
    CHECK(n >= 0 && (size_t)n < cap, "path too long: %s...", out);
}

/* data/: beside the working directory (make test runs in the repository root), else
 * found by walking up from the test binary. */
static void find_dirs(const char *argv0) {
    char p[PATH_MAX], q[PATH_MAX + 32];
    if (exists("data/demo.json") && realpath("data", g_data)) {
    } else if (argv0 && realpath(argv0, p)) {
        for (char *s = strrchr(p, '/'); s && !g_data[0]; s = strrchr(p, '/')) {
            *s = 0;
            snprintf(q, sizeof q, "%s/data/demo.json", p);
            if (exists(q)) sfmt(g_data, sizeof g_data, "%s/data", p);
        }
    }
    /* Shared assets as tools/bench.sh and tools/study.sh look for them. */
    const char *env = getenv("PRT_DATA");
    char cand[3][PATH_MAX + 32];
    snprintf(cand[0], sizeof cand[0], "%s", env && *env ? env : "");
    snprintf(cand[1], sizeof cand[1], "%s/../../shared/data", g_data);
    snprintf(cand[2], sizeof cand[2], "/work/shared/data");
    for (int i = 0; i < 3 && !g_shared[0]; i++) {
        sfmt(q, sizeof q, "%s/models", cand[i]);
        if (cand[i][0] && exists(q) && realpath(cand[i], p)) {
            char *s = strrchr(p, '/');
            if (s) *s = 0;    /* the folder that holds data/ */
            snprintf(g_shared, sizeof g_shared, "%s", p);
        }
    }
}

static const char *data_path(const char *name) {
    static char buf[4][PATH_MAX + 64];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", g_data, name);
    return buf[k];
}

/* ---------------------------------------------------------------- expected counts */

typedef struct expect {
    int nverts, ntris;      /* models, floor excluded */
    int floor_verts;        /* -1: no floor */
    int nobj;               /* OBJ models (their counts are not in nverts/ntris) */
    char obj[4][256];       /* their paths as written */
    char mat[16][256];      /* each model's material spec */
    int nmodels;
    char floor_mat[256];
} expect;

static int geti(const cJSON *o, const char *k, int def) {
    const cJSON *it = o ? cJSON_GetObjectItemCaseSensitive(o, k) : NULL;
    return it && cJSON_IsNumber(it) ? it->valueint : def;
}

/* Counts of one procedural shape from its closed form (defaults as in scene.h). */
static void shape_counts(const cJSON *m, int *nv, int *nt) {
    const cJSON *g;
    if ((g = cJSON_GetObjectItemCaseSensitive(m, "sphere"))) {
        int r = geti(g, "rings", 32), s = geti(g, "segments", 64);
        *nv = 2 + (r - 1) * s, *nt = 2 * s * (r - 1);
    } else if ((g = cJSON_GetObjectItemCaseSensitive(m, "box"))) {
        int n = geti(g, "n", 8), f = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(g, "open_top")) ? 5 : 6;
        *nv = f * (n + 1) * (n + 1), *nt = 2 * f * n * n;
    } else if ((g = cJSON_GetObjectItemCaseSensitive(m, "torus"))) {
        int nu = geti(g, "nu", 64), nv2 = geti(g, "nv", 32);
        *nv = nu * nv2, *nt = 2 * nu * nv2;
    } else if ((g = cJSON_GetObjectItemCaseSensitive(m, "plane"))) {
        int nx = geti(g, "nx", 32), nz = geti(g, "nz", 32);
        *nv = nx * nz, *nt = 2 * (nx - 1) * (nz - 1);
    } else *nv = *nt = -1000000;   /* unknown shape: no count can match */
}

/* Reads what the JSON file says, with cJSON, independently of scene.c. */
static int read_expect(const char *path, expect *e) {
    memset(e, 0, sizeof *e);
    char *text = check_read_file(path, NULL);
    cJSON *root = text ? cJSON_Parse(text) : NULL;
    free(text);
    if (!root) return -1;
    const cJSON *m;
    cJSON_ArrayForEach(m, cJSON_GetObjectItemCaseSensitive(root, "models")) {
        const cJSON *obj = cJSON_GetObjectItemCaseSensitive(m, "obj"), *mat = cJSON_GetObjectItemCaseSensitive(m, "material");
        if (e->nmodels < 16)
            snprintf(e->mat[e->nmodels], sizeof e->mat[0], "%s", cJSON_IsString(mat) ? mat->valuestring : "lambert:kd=0.8");
        e->nmodels++;
        if (cJSON_IsString(obj)) {
            if (e->nobj < 4) snprintf(e->obj[e->nobj], sizeof e->obj[0], "%s", obj->valuestring);
            e->nobj++;
            continue;
        }
        int nv, nt;
        shape_counts(m, &nv, &nt);
        e->nverts += nv, e->ntris += nt;
    }
    const cJSON *fl = cJSON_GetObjectItemCaseSensitive(root, "floor");
    e->floor_verts = -1;
    snprintf(e->floor_mat, sizeof e->floor_mat, "lambert:kd=0.7");
    if (cJSON_IsTrue(fl) || cJSON_IsObject(fl)) {
        int n = (int)lround(sqrt((double)geti(fl, "vertices", 31000)));
        e->floor_verts = n < 2 ? 4 : n * n;
        const cJSON *fm = cJSON_GetObjectItemCaseSensitive(fl, "material");
        if (cJSON_IsString(fm)) snprintf(e->floor_mat, sizeof e->floor_mat, "%s", fm->valuestring);
    }
    cJSON_Delete(root);
    return 0;
}

/* Every model's first vertex carries its material; the floor lies under the models. */
static void check_materials_floor(const char *name, const prt_scene *s, const expect *e, const int *first) {
    for (int k = 0; k < e->nmodels && k < 16; k++) {
        int v = first[k];
        CHECK(v >= 0 && v < s->mesh.nverts && strcmp(s->material_spec[s->mesh.mat[v]], e->mat[k]) == 0,
              "%s: model %d material '%s', want '%s'", name, k, v >= 0 && v < s->mesh.nverts ? s->material_spec[s->mesh.mat[v]] : "?", e->mat[k]);
    }
    if (e->floor_verts < 0) {
        CHECK(s->floor_first_vertex == -1, "%s: no floor", name);
        return;
    }
    int f = s->floor_first_vertex;
    CHECK(f > 0 && s->mesh.nverts - f == e->floor_verts, "%s: floor %d vertices, want %d", name, s->mesh.nverts - f, e->floor_verts);
    if (f <= 0) return;
    CHECK(strcmp(s->material_spec[s->mesh.mat[f]], e->floor_mat) == 0, "%s: floor material '%s'", name, s->material_spec[s->mesh.mat[f]]);
    float lo = 1e30f, fy = s->mesh.pos[3 * f + 1];
    for (int v = 0; v < f; v++) lo = fminf(lo, s->mesh.pos[3 * v + 1]);
    CHECK(fy < lo && fy > lo - 0.01f * (s->bmax[1] - s->bmin[1]), "%s: floor at %g just under the lowest model point %g", name, fy, lo);
}

/* ---------------------------------------------------------------- cases */

static const char *const k_scenes[] = { "demo.json", "sphere-phong.json", "teapot-floor.json", "bunny-floor.json",
                                        "spot-floor.json", "two-chrome-spheres.json", "bunny-shadows.json",
                                        "teapot-shadows.json" };
#define NSCENES (int)(sizeof k_scenes / sizeof k_scenes[0])

/* The scenes the README and later issues name are all there, every data/ JSON file is
 * valid JSON, and data/README.md gives each one its line. */
static void listed(void) {
    CHECK(g_data[0], "data/ not found (run from the repository root)");
    if (!g_data[0]) return;
    for (int i = 0; i < NSCENES; i++) CHECK(exists(data_path(k_scenes[i])), "%s missing", data_path(k_scenes[i]));
    char *readme = check_read_file(data_path("README.md"), NULL);
    CHECK(readme != NULL, "data/README.md missing");
    glob_t g;
    CHECK(glob(data_path("*.json"), 0, NULL, &g) == 0 && g.gl_pathc >= (size_t)NSCENES, "data/*.json");
    for (size_t i = 0; i < g.gl_pathc; i++) {
        const char *base = strrchr(g.gl_pathv[i], '/') + 1;
        char *text = check_read_file(g.gl_pathv[i], NULL);
        cJSON *root = text ? cJSON_Parse(text) : NULL;
        CHECK(root && cJSON_IsObject(root), "%s is not a JSON object", base);
        const cJSON *c = root ? cJSON_GetObjectItemCaseSensitive(root, "comment") : NULL;
        CHECK(cJSON_IsString(c) && strlen(c->valuestring) > 20, "%s: a \"comment\" says what it shows", base);
        char needle[300];
        snprintf(needle, sizeof needle, "`%s`", base);
        CHECK(readme && strstr(readme, needle), "data/README.md has no line for %s", base);
        cJSON_Delete(root);
        free(text);
    }
    globfree(&g);
    free(readme);
}

/* Loads one data/ scene and checks it against what its JSON implies. A scene whose
 * models are all procedural loads in full; one naming an OBJ is checked in
 * shared_models. */
static void procedural(void) {
    int loaded = 0;
    glob_t g;
    if (glob(data_path("*.json"), 0, NULL, &g) != 0) { CHECK(0, "no data/*.json"); return; }
    for (size_t i = 0; i < g.gl_pathc; i++) {
        const char *path = g.gl_pathv[i], *base = strrchr(path, '/') + 1;
        expect e;
        CHECK(read_expect(path, &e) == 0, "%s", base);
        if (e.nobj) continue;
        prt_scene s;
        prt_error err = { "" };
        CHECK(scene_load(path, NULL, &s, &err) == 0, "%s: %s", base, err.msg);
        int nmodel = s.floor_first_vertex >= 0 ? s.floor_first_vertex : s.mesh.nverts;
        int ftris = e.floor_verts > 0 ? 2 * ((int)lround(sqrt(e.floor_verts)) - 1) * ((int)lround(sqrt(e.floor_verts)) - 1) : 0;
        CHECK(nmodel == e.nverts, "%s: %d model vertices, want %d", base, nmodel, e.nverts);
        CHECK(s.mesh.ntris == e.ntris + ftris, "%s: %d triangles, want %d", base, s.mesh.ntris, e.ntris + ftris);
        /* Model k starts after the vertices of models 0..k-1 (counts from the JSON). */
        int first[16], at = 0, k = 0;
        char *text = check_read_file(path, NULL);
        cJSON *root = cJSON_Parse(text);
        const cJSON *m;
        cJSON_ArrayForEach(m, cJSON_GetObjectItemCaseSensitive(root, "models")) {
            int nv, nt;
            shape_counts(m, &nv, &nt);
            if (k < 16) first[k++] = at;
            at += nv;
        }
        cJSON_Delete(root);
        free(text);
        check_materials_floor(base, &s, &e, first);
        printf("  %-24s %6d vertices, %6d triangles, %d materials%s\n", base, s.mesh.nverts, s.mesh.ntris, s.nmaterials,
               s.floor_first_vertex >= 0 ? " (floor included)" : "");
        loaded++;
        scene_free(&s);
    }
    globfree(&g);
    CHECK(loaded >= 3, "demo, sphere-phong and two-chrome-spheres are procedural (%d loaded)", loaded);
}

/* sphere-phong.json is the glossy study's sphere exactly: every vertex at distance 1 from (0,1,0)
 * with its normal pointing out, poles on the y axis. */
static void sphere_phong(void) {
    prt_scene s;
    prt_error err = { "" };
    if (scene_load(data_path("sphere-phong.json"), NULL, &s, &err) != 0) { CHECK(0, "%s", err.msg); return; }
    double worst = 0, worst_n = 0;
    for (int v = 0; v < s.mesh.nverts; v++) {
        const float *p = s.mesh.pos + 3 * v, *n = s.mesh.nrm + 3 * v;
        double d[3] = { p[0], p[1] - 1.0, p[2] }, l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        worst = fmax(worst, fabs(l - 1));
        for (int c = 0; c < 3; c++) worst_n = fmax(worst_n, fabs(n[c] - d[c] / l));
    }
    /* float vertices from double sin/cos: each coordinate rounded once (<= 6e-8 in [1, 2)), so
     * | |p - c| - 1 | <= ~2e-7 on any libm; 1e-6 is five times that (normals: 1e-5, looser still) */
    CHECK_NEAR(worst, 0, 1e-6, "distance from the centre");
    CHECK_NEAR(worst_n, 0, 1e-5, "normal = radial direction");
    CHECK_NEAR(s.bmin[1], 0, 1e-6, "south pole");
    CHECK_NEAR(s.bmax[1], 2, 1e-6, "north pole");
    CHECK(s.nmaterials == 1 && s.materials[0].type == BRDF_PHONG && s.materials[0].n == 50.f, "paper-phong");
    scene_free(&s);
}

/* The shared models as SOURCES.md lists them ('v' and 'f' lines). */
static const struct { const char *file; int v, f; } k_models[] = {
    { "stanford-bunny.obj", 35947, 69451 }, { "teapot.obj", 3644, 6320 }, { "spot.obj", 2930, 5856 } };

static void check_obj_scene(const char *label, const char *path, const expect *e) {
    prt_scene s;
    prt_error err = { "" };
    if (scene_load(path, NULL, &s, &err) != 0) { CHECK(0, "%s: %s", label, err.msg); return; }
    const char *file = strrchr(e->obj[0], '/') ? strrchr(e->obj[0], '/') + 1 : e->obj[0];
    int want_v = -1, want_f = -1;
    for (size_t i = 0; i < sizeof k_models / sizeof k_models[0]; i++)
        if (!strcmp(file, k_models[i].file)) want_v = k_models[i].v, want_f = k_models[i].f;
    CHECK(s.load_stats.obj_vertices == want_v && s.load_stats.faces == want_f, "%s: %d v, %d f lines; SOURCES.md: %d, %d",
          label, s.load_stats.obj_vertices, s.load_stats.faces, want_v, want_f);
    int used = s.load_stats.obj_vertices - s.load_stats.welded - s.load_stats.unused;
    CHECK(s.floor_first_vertex == used, "%s: %d model vertices, want %d read - %d welded - %d unused", label,
          s.floor_first_vertex, s.load_stats.obj_vertices, s.load_stats.welded, s.load_stats.unused, used);
    int first[1] = { 0 };
    check_materials_floor(label, &s, e, first);
    printf("  %-24s %6d vertices (%d of the model), %6d triangles\n", label, s.mesh.nverts, s.floor_first_vertex, s.mesh.ntris);
    scene_free(&s);
}

/* Scenes that name a shared model: loaded where ../shared/data is (the main checkout),
 * else the clear error. Where the shared data is found elsewhere ($PRT_DATA), the scene
 * file is copied unchanged into a scratch tree that has it at ../../shared/data. */
static void shared_models(void) {
    int with_obj = 0;
    for (int i = 0; i < NSCENES; i++) {
        const char *path = data_path(k_scenes[i]);
        expect e;
        if (read_expect(path, &e) != 0 || !e.nobj) continue;
        with_obj++;
        CHECK(e.nobj == 1 && !strncmp(e.obj[0], "../../shared/data/models/", 25),
              "%s: one model from ../shared/data (repository root), i.e. ../../shared/data from data/: '%s'", k_scenes[i], e.obj[0]);
        char obj[PATH_MAX + 300];
        snprintf(obj, sizeof obj, "%s/%s", g_data, e.obj[0]);
        if (exists(obj)) check_obj_scene(k_scenes[i], path, &e);
        else {
            prt_scene s;
            prt_error err = { "" };
            int rc = scene_load(path, NULL, &s, &err);
            CHECK(rc == -1 && strstr(err.msg, path) && strstr(err.msg, e.obj[0]) && strstr(err.msg, "cannot open"),
                  "a missing model is one line naming it: %s", err.msg);
            CHECK(s.mesh.nverts == 0 && s.mesh.pos == NULL, "nothing left allocated");
            printf("  %s: model not here, as expected without ../shared/data: %s\n", k_scenes[i], err.msg);
            scene_free(&s);
        }
        if (!g_shared[0] || exists(obj)) continue;
        /* scratch/r/data/X.json with scratch/shared -> the shared folder. */
        char dir[PATH_MAX + 64], cmd[3 * PATH_MAX], copy[PATH_MAX + 128], label[128];
        snprintf(dir, sizeof dir, "%s/mirror", check_tmpdir());
        sfmt(cmd, sizeof cmd, "mkdir -p '%s/r/data' && ln -sfn '%s' '%s/shared' && cp '%s' '%s/r/data/'", dir, g_shared, dir,
                 path, dir);
        CHECK(system(cmd) == 0, "%s", cmd);
        snprintf(copy, sizeof copy, "%s/r/data/%s", dir, k_scenes[i]);
        sfmt(label, sizeof label, "%s (via %s)", k_scenes[i], g_shared);
        check_obj_scene(label, copy, &e);
    }
    CHECK(with_obj == 5, "teapot (twice), bunny (twice) and spot scenes name a shared model (%d)", with_obj);
    if (!g_shared[0]) printf("  ../shared/data not found (set PRT_DATA): shared models checked by their error only\n");
}

/* Bit for bit, exact by construction: both sides run the same generators and loaders, the same
 * double cos/sin of the same angles (deg * pi / 180) rounded to float and the same float matrix
 * products, in one process, so any CPU's libm gives both the same bits. */
static int same_scene(const char *what, const prt_scene *a, const prt_scene *b) {
    int ok = a->mesh.nverts == b->mesh.nverts && a->mesh.ntris == b->mesh.ntris && a->nmaterials == b->nmaterials &&
             a->floor_first_vertex == b->floor_first_vertex;
    CHECK(ok, "%s: %d/%d vertices, %d/%d triangles, %d/%d materials, floor at %d/%d", what, a->mesh.nverts, b->mesh.nverts,
          a->mesh.ntris, b->mesh.ntris, a->nmaterials, b->nmaterials, a->floor_first_vertex, b->floor_first_vertex);
    if (!ok) return 0;
    size_t nv = (size_t)a->mesh.nverts;
    int pos = !memcmp(a->mesh.pos, b->mesh.pos, 3 * nv * sizeof(float));
    int nrm = !memcmp(a->mesh.nrm, b->mesh.nrm, 3 * nv * sizeof(float));
    int tri = !memcmp(a->mesh.tris, b->mesh.tris, 3 * (size_t)a->mesh.ntris * sizeof(uint32_t));
    int mat = !memcmp(a->mesh.mat, b->mesh.mat, nv * sizeof(uint16_t));
    int spec = 1;
    for (int i = 0; i < a->nmaterials; i++)
        spec &= !strcmp(a->material_spec[i], b->material_spec[i]) && !memcmp(&a->materials[i], &b->materials[i], sizeof a->materials[i]);
    CHECK(pos && nrm && tri && mat && spec, "%s: bit-identical positions %d, normals %d, triangles %d, vertex materials %d, materials %d",
          what, pos, nrm, tri, mat, spec);
    return pos && nrm && tri && mat && spec;
}

/* The demo scene built in code (an independent construction of data/demo.json's scene: the mesh
 * generators, rotations and translations its keys name, written out). */
static void rot_y_deg(float R[9], double deg) {
    double a = deg * M_PI / 180.0;
    float cs = (float)cos(a), sn = (float)sin(a);
    const float M[9] = { cs, 0, sn, 0, 1, 0, -sn, 0, cs };
    memcpy(R, M, sizeof M);
}
static int demo_add(prt_scene *s, prt_mesh *m, const char *spec, const float R[9], const float t[3], prt_error *err) {
    int mi = scene_material(s, spec, err);
    if (mi < 0) { mesh_free(m); return -1; }
    if (R) mesh_transform(m, R, 1.f, t);
    for (int v = 0; v < m->nverts; v++) m->mat[v] = (uint16_t)mi;
    int rc = mesh_append(&s->mesh, m, err);
    mesh_free(m);
    return rc;
}
static int demo_in_code(prt_scene *out, int floor_verts, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->floor_first_vertex = -1;
    prt_mesh m;
    const float origin[3] = { 0, 0, 0 }, chrome[3] = { 0, 0.5f, 0 }, red[3] = { 0.71f, 0.3f, -0.59f };
    if (mesh_make_sphere(&m, chrome, 0.5f, 32, 64, err) || demo_add(out, &m, "phong:kd=0.02;ks=0.9;n=1000", NULL, NULL, err) ||
        mesh_make_sphere(&m, red, 0.3f, 24, 48, err) || demo_add(out, &m, "phong:kd=0.5,0.05,0.04;ks=0.3;n=200", NULL, NULL, err))
        return -1;
    float R[9], Rx[9] = { 1, 0, 0, 0, 0, -1, 0, 1, 0 }, Ry[9];
    const float lo[3] = { -0.35f, 0.f, -0.35f }, hi[3] = { 0.35f, 1.2f, 0.35f }, bt[3] = { -1.33f, 0.f, 0.67f };
    rot_y_deg(R, 24.0);
    if (mesh_make_box(&m, lo, hi, 10, false, err) || demo_add(out, &m, "lambert:kd=0.9,0.4,0.06", R, bt, err)) return -1;
    rot_y_deg(Ry, 17.0);   /* p' = Ry Rx p + t (scene.h) */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R[3 * i + j] = Ry[3 * i] * Rx[j] + Ry[3 * i + 1] * Rx[3 + j] + Ry[3 * i + 2] * Rx[6 + j];
    const float tt[3] = { 0.53f, 0.4f, 0.85f };
    if (mesh_make_torus(&m, origin, 0.3f, 0.1f, 48, 16, err) || demo_add(out, &m, "lambert:kd=0.1,0.3,0.65", R, tt, err)) return -1;
    return scene_add_floor(out, floor_verts, 5.f, "lambert:kd=0.65", err);
}

/* `prt demo` builds its scene from the built-in JSON, which is data/demo.json byte for
 * byte, and that is the demo scene built in code: same vertices, normals, triangles and
 * materials, bit for bit, at the default floor (prt demo's 10,000) and another; it asks for
 * refinement to 40,000 vertices and names city-512.exr, which data/ holds, as its light prior. */
static void demo(void) {
    size_t len = 0;
    char *text = check_read_file(data_path("demo.json"), &len);
    const char *builtin = scene_demo_json();
    CHECK(text && len == strlen(builtin) && !memcmp(text, builtin, len),
          "data/demo.json differs from the built-in demo (src/scene/scene.c k_demo_json): keep them identical");
    free(text);
    prt_error err = { "" };
    prt_scene file, built, code;
    CHECK(scene_load(data_path("demo.json"), NULL, &file, &err) == 0, "%s", err.msg);
    CHECK(scene_make_demo(&built, 10000, &err) == 0, "%s", err.msg);
    CHECK(demo_in_code(&code, 10000, &err) == 0, "%s", err.msg);
    same_scene("data/demo.json vs prt demo", &file, &built);
    same_scene("prt demo vs the demo in code", &built, &code);
    CHECK(built.refine.on && built.refine.budget == 40000 && built.refine.threshold == 0 && !built.refine.models,
          "demo refine: on %d budget %d threshold %g models %d", built.refine.on, built.refine.budget,
          (double)built.refine.threshold, built.refine.models);
    CHECK(!strcmp(built.light_prior, "city-512.exr") && exists(data_path("city-512.exr")),
          "demo light prior '%s' (relative to the working directory for the built-in text), data/city-512.exr", built.light_prior);
    printf("  demo: %d vertices (%d models + %d floor), %d triangles, %d materials\n", built.mesh.nverts,
           built.floor_first_vertex, built.mesh.nverts - built.floor_first_vertex, built.mesh.ntris, built.nmaterials);
    scene_free(&file);
    scene_free(&built);
    scene_free(&code);
    /* prt demo --floor 5000 */
    CHECK(scene_make_demo(&built, 5000, &err) == 0 && demo_in_code(&code, 5000, &err) == 0, "%s", err.msg);
    same_scene("--floor 5000", &built, &code);
    scene_free(&built);
    scene_free(&code);
    CHECK(scene_make_demo(&built, 0, &err) == -1 && strstr(err.msg, "demo"), "%s", err.msg);
}

/* data/bunny-floor.json is make bench's scene and data/spot-floor.json make study's
 * glossy one: loading the JSON gives exactly the scene of their command lines. */
static void bench_scenes(void) {
    static const struct { const char *json, *obj, *mat; int floor; } k[] = {
        { "bunny-floor.json", "stanford-bunny.obj", "paper-phong", 31000 },   /* tools/bench.sh */
        { "spot-floor.json", "spot.obj", "paper-phong", 2500 },               /* tools/study.sh */
    };
    for (int i = 0; i < 2; i++) {
        char obj[PATH_MAX + 64];
        snprintf(obj, sizeof obj, "%s/data/models/%s", g_shared, k[i].obj);
        if (!g_shared[0] || !exists(obj)) {
            printf("  %s: %s not found (set PRT_DATA): not compared with its command line\n", k[i].json, k[i].obj);
            continue;
        }
        /* The JSON as shipped, with its model path pointed at the found file. */
        size_t len;
        char *text = check_read_file(data_path(k[i].json), &len), *at = text ? strstr(text, "../../shared/data/models/") : NULL;
        CHECK(at != NULL, "%s names ../../shared/data/models/", k[i].json);
        if (!at) { free(text); continue; }
        char *fixed = malloc(len + strlen(g_shared) + 64);
        snprintf(fixed, len + strlen(g_shared) + 64, "%.*s%s/data/models/%s", (int)(at - text), text, g_shared,
                 at + strlen("../../shared/data/models/"));
        prt_error err = { "" };
        prt_scene a, b;
        CHECK(scene_parse_json(k[i].json, fixed, strlen(fixed), NULL, &a, &err) == 0, "%s", err.msg);
        scene_desc d = { .material = k[i].mat, .floor = 1, .floor_verts = k[i].floor };
        CHECK(scene_load(obj, &d, &b, &err) == 0, "%s", err.msg);
        char what[128];
        snprintf(what, sizeof what, "%s vs %s --material %s --floor %d", k[i].json, k[i].obj, k[i].mat, k[i].floor);
        if (same_scene(what, &a, &b)) printf("  %s\n", what);
        scene_free(&a);
        scene_free(&b);
        free(text);
        free(fixed);
    }
}

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL, "cannot write %s", path);
    if (!f) return;
    fputs(text, f);
    fclose(f);
}

/* OBJ paths resolve against the JSON file's folder, whatever the working directory. */
static void relative_paths(void) {
    char root[PATH_MAX], cwd[PATH_MAX], cmd[PATH_MAX + 64], p[PATH_MAX + 64];
    CHECK(getcwd(cwd, sizeof cwd) != NULL);
    CHECK(realpath(check_tmpdir(), root) != NULL);
    sfmt(cmd, sizeof cmd, "mkdir -p '%s/a/b' '%s/a/m'", root, root);
    CHECK(system(cmd) == 0);
    snprintf(p, sizeof p, "%s/a/m/tri.obj", root);
    write_text(p, "v 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n");
    snprintf(p, sizeof p, "%s/a/b/s.json", root);
    write_text(p, "{ \"models\": [ { \"obj\": \"../m/tri.obj\", \"translate\": [0, 2, 0] } ] }");
    const char *where[3] = { "/", root, "a/b" };   /* cwd: elsewhere, the scratch root, the JSON's folder */
    const char *path[3] = { p, "a/b/s.json", "s.json" };
    for (int i = 0; i < 3; i++) {
        if (i == 2) CHECK(chdir(root) == 0);
        CHECK(chdir(where[i]) == 0, "cd %s", where[i]);
        prt_scene s;
        prt_error err = { "" };
        int rc = scene_load(path[i], NULL, &s, &err);
        CHECK(rc == 0 && s.mesh.nverts == 3 && s.mesh.pos[1] == 2.f, "cwd %s, scene %s: %s", where[i], path[i], err.msg);
        if (rc == 0) scene_free(&s);
        CHECK(chdir(cwd) == 0);
    }
}

/* "rotate_x" (the demo's torus stands on its rim): degrees about +x, applied before
 * rotate_y, p' = Ry Rx p + t; a quarter turn is exact. */
static void rotate_x(void) {
    const char *j = "rx.json";
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/%s", check_tmpdir(), j);
    /* One plane quad of 2x2 vertices at y = 0 over x, z in [0,1]; its normal is +y. */
    write_text(path, "{ \"models\": [ { \"plane\": {\"x\": [0, 1], \"z\": [0, 1], \"nx\": 2, \"nz\": 2}, \"rotate_x\": 90 },\n"
                     "  { \"plane\": {\"x\": [0, 1], \"z\": [0, 1], \"nx\": 2, \"nz\": 2}, \"rotate_x\": 90, \"rotate_y\": 90,"
                     " \"translate\": [5, 0, 0] },\n"
                     "  { \"plane\": {\"x\": [0, 1], \"z\": [0, 1], \"nx\": 2, \"nz\": 2}, \"rotate_x\": -45 } ] }");
    prt_scene s;
    prt_error err = { "" };
    if (scene_load(path, NULL, &s, &err) != 0) { CHECK(0, "%s", err.msg); return; }
    CHECK(s.mesh.nverts == 12);
    /* Rx(90): (x, y, z) -> (x, -z, y) exactly (scene.c takes a multiple of 90 degrees' cos and
     * sin as 0 and +-1, no libm); the normal +y -> +z. */
    int exact = 1;
    for (int v = 0; v < 4; v++) {
        const float *q = s.mesh.pos + 3 * v, *n = s.mesh.nrm + 3 * v;
        exact &= (q[0] == 0.f || q[0] == 1.f) && (q[1] == 0.f || q[1] == -1.f) && q[2] == 0.f;
        exact &= n[0] == 0.f && n[1] == 0.f && n[2] == 1.f;
    }
    CHECK(exact, "rotate_x 90 is an exact quarter turn");
    /* Then Ry(90) (x, y, z) -> (z, y, -x): (x, -z, 0) -> (0, -z, -x), + (5,0,0); the
     * normal +z -> +x. The plane's corner (1, 0, 1) lands at (5, -1, -1). */
    double e = 0;
    int corner = 0;
    for (int v = 4; v < 8; v++) {
        const float *q = s.mesh.pos + 3 * v, *n = s.mesh.nrm + 3 * v;
        e = fmax(e, fabs(q[0] - 5) + fabs(n[0] - 1) + fabs(n[1]) + fabs(n[2]));
        e = fmax(e, fmin(fabs(q[1]), fabs(q[1] + 1)) + fmin(fabs(q[2]), fabs(q[2] + 1)));
        corner += fabs(q[1] + 1) < 1e-6 && fabs(q[2] + 1) < 1e-6;
    }
    CHECK_NEAR(e, 0, 1e-6, "rotate_x then rotate_y: the quad lies in x = 5, y and z in {0, -1}, facing +x");
    CHECK(corner == 1, "corner (1,0,1) -> (5,-1,-1): %d", corner);
    /* Rx(-45): the normal +y -> (0, cos 45, -sin 45). */
    const float *n = s.mesh.nrm + 3 * 8;
    CHECK_NEAR(n[1], sqrt(0.5), 1e-6);
    CHECK_NEAR(n[2], -sqrt(0.5), 1e-6);
    scene_free(&s);
    write_text(path, "{ \"models\": [ { \"sphere\": {}, \"rotate_x\": \"up\" } ] }");
    CHECK(scene_load(path, NULL, &s, &err) == -1 && strstr(err.msg, "models[0].rotate_x: expected a number"), "%s", err.msg);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    find_dirs(argc > 0 ? argv[0] : NULL);
    CHECK_CASE(listed);
    CHECK_CASE(procedural);
    CHECK_CASE(sphere_phong);
    CHECK_CASE(shared_models);
    CHECK_CASE(demo);
    CHECK_CASE(bench_scenes);
    CHECK_CASE(relative_paths);
    CHECK_CASE(rotate_x);
    return check_summary();
}
