/* scene.c - scenes for prt: models with transforms and materials, plus a floor.
 *
 * A scene is the one merged mesh that precomputation samples (one transport
 * vector per vertex, Wang, Tran & Luebke 2006 Sec. 3) with a material index per
 * vertex. It comes from an OBJ alone, or from a small JSON file (parsed with
 * cJSON) listing OBJ and procedural models; the built-in demo is such JSON text
 * (the same as data/demo.json).
 *
 * The floor matters for the paper's look: the shadows a model casts on it are
 * the visibility term the precomputation captures, so it is a finely
 * tessellated diffuse plane (about 31,000 vertices for the bunny benchmark,
 * Table I), centred under the models and lowered by 0.1% of the scene size so
 * a model resting on it does not z-fight with it.
 *
 * Errors name the scene file and the problem (a JSON syntax error with its
 * line and column, a key of the wrong type, an unknown key, a model that fails
 * to load). */
#include "scene.h"
#include "asset.h"
#include "vec3.h"
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define SCENE_DEFAULT_MATERIAL "lambert:kd=0.8"
#define SCENE_DEFAULT_FLOOR_MATERIAL "lambert:kd=0.7"
#define SCENE_DEFAULT_FLOOR_VERTS 31000
#define SCENE_DEFAULT_FLOOR_SIZE 3.0f
#define SCENE_MAX_JSON_BYTES (16 << 20)

void scene_free(prt_scene *s) {
    mesh_free(&s->mesh);
    for (int t = 0; t < s->ntextures && t < SCENE_MAX_TEXTURES; t++) texture_free(&s->textures[t]);
    memset(s, 0, sizeof *s);
    s->floor_first_vertex = -1;
}

void scene_update_bounds(prt_scene *s) { mesh_bounds(&s->mesh, s->bmin, s->bmax); }

/* Largest |coordinate| of vertices [begin, end) and the diagonal of their bounding box (double:
 * the sum of squares of a 1e30 box passes FLT_MAX). */
static void scene_extent(const prt_mesh *m, int begin, int end, double *maxabs, double *diag) {
    double lo[3] = { 0, 0, 0 }, hi[3] = { 0, 0, 0 }, mx = 0;
    for (int v = begin; v < end; v++)
        for (int c = 0; c < 3; c++) {
            double x = m->pos[3 * (size_t)v + c];
            if (v == begin || x < lo[c]) lo[c] = x;
            if (v == begin || x > hi[c]) hi[c] = x;
            mx = fmax(mx, fabs(x));
        }
    *maxabs = mx;
    *diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

/* See scene.h. The floor is checked apart from the models so that the message names what the
 * user can change (a model inside the range under a floor that is not: the floor's size). */
int scene_check_scale(const prt_scene *s, prt_error *err) {
    const prt_mesh *m = &s->mesh;
    int nmodel = s->floor_first_vertex >= 0 && s->floor_first_vertex < m->nverts ? s->floor_first_vertex : m->nverts;
    double mx, diag, fmx = 0, fdiag;
    scene_extent(m, 0, nmodel, &mx, &diag);
    if (nmodel < m->nverts) scene_extent(m, nmodel, m->nverts, &fmx, &fdiag);
    if (mx > SCENE_MAX_COORD)
        return prt_fail(err, "coordinates up to %.3g overflow float arithmetic; prt takes coordinates within "
                        "+-%.0e: scale the model down (a JSON scene's \"scale\")", mx, SCENE_MAX_COORD);
    if (fmx > SCENE_MAX_COORD)
        return prt_fail(err, "the floor reaches coordinates of %.3g, which overflow float arithmetic; prt takes "
                        "coordinates within +-%.0e: a smaller floor size, or scale the model down", fmx, SCENE_MAX_COORD);
    if (m->nverts > 0 && diag < SCENE_MIN_SIZE && mx > 0)
        return prt_fail(err, "the model is only %.3g across, which underflows float arithmetic; prt takes scenes at "
                        "least %.0e across: scale the model up (a JSON scene's \"scale\")", diag, SCENE_MIN_SIZE);
    for (int i = 0; i < s->lights.count; i++)
        for (int c = 0; c < 3; c++)
            if (fabs(s->lights.light[i].pos[c]) > SCENE_MAX_COORD)
                return prt_fail(err, "lights[%d]: position coordinate %.3g overflows float arithmetic; prt takes "
                                "coordinates within +-%.0e", i, (double)s->lights.light[i].pos[c], SCENE_MAX_COORD);
    return 0;
}

/* Returns the index of the material with this spec, adding it if new; -1 with err set. */
int scene_material(prt_scene *s, const char *spec, prt_error *err) {
    if (!spec || !*spec) return prt_fail(err, "empty material spec");
    size_t len = strlen(spec);
    if (len >= sizeof s->material_spec[0])
        return prt_fail(err, "material spec '%.40s...' too long (%zu characters, at most %zu)", spec, len,
                        sizeof s->material_spec[0] - 1);
    for (int i = 0; i < s->nmaterials; i++)
        if (strcmp(s->material_spec[i], spec) == 0) return i;
    brdf_params p;
    memset(&p, 0, sizeof p);
    if (brdf_parse(spec, &p, err) != 0) return -1;
    /* Different spellings of one material ("lambert:kd=0.8" and "lambert:kd=0.8,0.8,0.8")
     * share it too: compare canonical forms. */
    char canon[512], other[512];
    brdf_format(&p, canon, sizeof canon);
    for (int i = 0; i < s->nmaterials; i++) {
        brdf_format(&s->materials[i], other, sizeof other);
        if (strcmp(canon, other) == 0) return i;
    }
    if (s->nmaterials >= PRT_MAX_MATERIALS)
        return prt_fail(err, "too many materials (at most %d): '%s'", PRT_MAX_MATERIALS, spec);
    int i = s->nmaterials++;
    s->materials[i] = p;
    memcpy(s->material_spec[i], spec, len + 1);
    return i;
}

int scene_material_from(prt_scene *s, const char *spec, const char *from, prt_error *err) {
    return scene_material_textured(s, spec, from, -1, err);
}

int scene_material_textured(prt_scene *s, const char *spec, const char *from, int tex, prt_error *err) {
    if (tex < -1 || tex >= s->ntextures) return prt_fail(err, "texture %d of %d", tex, s->ntextures);
    brdf_params p;
    if (spec && brdf_parse(spec, &p, err)) return -1;
    int i = -1;
    for (int m = 0; m < s->nmaterials && i < 0 && spec; m++) {   /* the same BRDF (canonical forms) and texture */
        char a[512], b[512];
        brdf_format(&p, a, sizeof a);
        brdf_format(&s->materials[m], b, sizeof b);
        if (!strcmp(a, b) && s->material_texture[m] == tex + 1) i = m;
    }
    if (i >= 0) return i;
    int had = s->nmaterials;
    if (tex < 0) i = scene_material(s, spec, err);
    else {   /* a new slot, even when an untextured material has this spec */
        char canon[256];
        size_t len = spec ? strlen(spec) : 0;
        if (!spec || len >= sizeof canon) return scene_material(s, spec, err);
        if (s->nmaterials >= PRT_MAX_MATERIALS)
            return prt_fail(err, "too many materials (at most %d): '%s'", PRT_MAX_MATERIALS, spec);
        i = s->nmaterials++;
        s->materials[i] = p;
        memcpy(s->material_spec[i], spec, len + 1);
    }
    if (i >= had && i >= 0) {
        if (from) snprintf(s->material_from[i], sizeof s->material_from[i], "%.191s", from);
        s->material_texture[i] = (uint8_t)(tex + 1);
    }
    return i;
}

const scene_texture *scene_material_tex(const prt_scene *s, int m) {
    int t = m >= 0 && m < s->nmaterials ? s->material_texture[m] - 1 : -1;
    return t >= 0 && t < s->ntextures && s->mesh.uv ? &s->textures[t] : NULL;
}

void scene_vertex_albedo(const prt_scene *s, int v, float rgb[3]) {
    const scene_texture *t = s->mesh.mat ? scene_material_tex(s, s->mesh.mat[v]) : NULL;
    if (t) texture_sample(t, s->mesh.uv[2 * (size_t)v], s->mesh.uv[2 * (size_t)v + 1], rgb);
    else rgb[0] = rgb[1] = rgb[2] = 1;
}

void scene_triangle_albedo(const prt_scene *s, int t, float rgb[3]) {
    const uint32_t *x = s->mesh.tris + 3 * (size_t)t;
    const scene_texture *tx = s->mesh.mat ? scene_material_tex(s, s->mesh.mat[x[0]]) : NULL;
    if (!tx) {
        rgb[0] = rgb[1] = rgb[2] = 1;
        return;
    }
    float uv[6];
    for (int k = 0; k < 3; k++) memcpy(uv + 2 * k, s->mesh.uv + 2 * (size_t)x[k], 2 * sizeof(float));
    texture_mean_triangle(tx, uv, rgb);
}

void scene_note(prt_scene *s, const char *fmt, ...) {
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    size_t at = strlen(s->notes), n = strlen(line);
    if (at + n + 2 <= sizeof s->notes) snprintf(s->notes + at, sizeof s->notes - at, "%s\n", line);
    else if (at + 5 <= sizeof s->notes && (at < 4 || strcmp(s->notes + at - 4, "...\n")))
        snprintf(s->notes + at, sizeof s->notes - at, "...\n");
}

/* Whether the MTL library named on line `line` of the OBJ at path (relative to its folder) can be
 * read; its path into lib[cap]. */
static bool obj_mtllib(const char *path, int line, char *lib, size_t cap) {
    FILE *f = fopen(path, "rb");
    char buf[4096] = "";
    for (int i = 0; f && i < line && fgets(buf, sizeof buf, f); i++) {}
    if (f) fclose(f);
    char *name = strstr(buf, "mtllib");
    name = name ? name + 6 : buf + strlen(buf);
    name += strspn(name, " \t");
    name[strcspn(name, "\r\n#")] = 0;
    for (size_t n = strlen(name); n > 0 && (name[n - 1] == ' ' || name[n - 1] == '\t'); n--) name[n - 1] = 0;
    const char *slash = strrchr(path, '/');
    if (name[0] == '/' || !slash) snprintf(lib, cap, "%s", name);
    else snprintf(lib, cap, "%.*s/%s", (int)(slash - path), path, name);
    FILE *m = *name ? fopen(lib, "rb") : NULL;
    if (m) fclose(m);
    return m != NULL;
}

/* Reads a model file into am: an OBJ through mesh.c unless it names an MTL library, a glTF, PLY
 * or OBJ + MTL through asset.h (its materials, lights and cameras; ad says which material wins).
 * Returns 1 when am's vertices carry scene materials, 0 when the caller assigns one, -1 with err. */
static int model_file(const char *path, const asset_desc *ad, prt_scene *s, asset_model *am, prt_error *err) {
    char ext[16];
    prt_path_ext(path, ext);
    memset(am, 0, sizeof *am);
    if (!strcmp(ext, "obj")) {
        if (mesh_load_obj(path, &am->stats, &am->mesh, err)) return -1;
        if (!am->stats.mtllib_line) return 0;
        char lib[4096];
        if (!obj_mtllib(path, am->stats.mtllib_line, lib, sizeof lib)) {
            scene_note(s, "%s:%d: its MTL library %s cannot be read: the model takes --material or the default", path,
                       am->stats.mtllib_line, lib);
            return 0;
        }
        asset_model_free(am);   /* it names materials: the asset path reads them */
    } else if (!asset_handles(path))
        return prt_fail(err, "%s: unknown model format '%s' (expected .obj, .gltf, .glb or .ply)", path,
                        ext[0] ? ext : "no extension");
    return asset_load(path, ad, s, am, err) ? -1 : 1;
}

static void set_material(prt_mesh *m, int mat) {
    for (int v = 0; v < m->nverts; v++) m->mat[v] = (uint16_t)mat;
}

/* Takes *mesh (zeroed on return, success or not). */
int scene_from_mesh(prt_mesh *mesh, const char *material, prt_scene *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->floor_first_vertex = -1;
    out->mesh = *mesh;
    memset(mesh, 0, sizeof *mesh);
    if (!out->mesh.mat && out->mesh.nverts > 0 && !(out->mesh.mat = calloc((size_t)out->mesh.nverts, sizeof(uint16_t)))) {
        scene_free(out);
        return prt_fail(err, "out of memory");
    }
    int mat = scene_material_from(out, material ? material : SCENE_DEFAULT_MATERIAL, material ? "given" : "default", err);
    if (mat < 0) { scene_free(out); return -1; }
    set_material(&out->mesh, mat);
    scene_update_bounds(out);
    return 0;
}

int scene_add_floor(prt_scene *s, int verts, float size, const char *material, prt_error *err) {
    if (s->floor_first_vertex >= 0) return prt_fail(err, "the scene already has a floor");
    if (verts <= 0 || verts > (1 << 24))
        return prt_fail(err, "floor: vertex count must be between 1 and %d (got %d)", 1 << 24, verts);
    if (size == 0.f) size = SCENE_DEFAULT_FLOOR_SIZE;
    if (!(size > 0.f) || !isfinite(size)) return prt_fail(err, "floor: size must be positive (got %g)", (double)size);
    if (s->mesh.nverts <= 0) return prt_fail(err, "floor: the scene has no models to put a floor under");
    int mat = scene_material_from(s, material ? material : SCENE_DEFAULT_FLOOR_MATERIAL,
                                  material ? "the floor's material" : "the default floor", err);
    if (mat < 0) return -1;
    float bmin[3], bmax[3], d[3];
    mesh_bounds(&s->mesh, bmin, bmax);
    v3_sub(d, bmax, bmin);
    float extent = fmaxf(d[0], d[2]);
    if (!(extent > 0.f)) extent = d[1] > 0.f ? d[1] : 1.f; /* a vertical sliver: use its height */
    float diag = v3_len(d);
    if (!(diag > 0.f)) diag = extent;
    float half = 0.5f * size * extent;
    float cx = 0.5f * (bmin[0] + bmax[0]), cz = 0.5f * (bmin[2] + bmax[2]);
    float y = bmin[1] - 1e-3f * diag;
    /* A square grid with n*n as close to verts as possible (176^2 = 30,976 for 31,000). */
    int n = (int)lround(sqrt((double)verts));
    if (n < 2) n = 2;
    prt_mesh floor;
    if (mesh_make_plane(&floor, cx - half, cx + half, cz - half, cz + half, y, n, n, err) != 0) return -1;
    set_material(&floor, mat);
    int first = s->mesh.nverts;
    int rc = mesh_append(&s->mesh, &floor, err);
    mesh_free(&floor);
    if (rc != 0) return -1;
    s->floor_first_vertex = first;
    scene_update_bounds(s);
    return 0;
}

/* ---------------------------------------------------------------- JSON scenes */

/* Context for error messages: "scene.json: models[2].sphere.radius: ...". */
typedef struct json_ctx {
    const char *path;
    char where[160];
    prt_error *err;
} json_ctx;

static int jfail_type(json_ctx *c, const char *key, const char *want) {
    return prt_fail(c->err, "%s: %s%s%s: expected %s", c->path, c->where, *c->where ? "." : "", key, want);
}

/* Reads an optional finite number; returns 0 (absent: *out unchanged) or -1. */
static int jnum(json_ctx *c, const cJSON *obj, const char *key, double *out) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!it) return 0;
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble)) return jfail_type(c, key, "a number");
    *out = it->valuedouble;
    return 0;
}

static int jfloat(json_ctx *c, const cJSON *obj, const char *key, float *out) {
    double d = *out;
    if (jnum(c, obj, key, &d)) return -1;
    if (fabs(d) > 1e30) return jfail_type(c, key, "a number of reasonable size");
    *out = (float)d;
    return 0;
}

static int jint(json_ctx *c, const cJSON *obj, const char *key, int lo, int hi, int *out) {
    double d = *out;
    if (jnum(c, obj, key, &d)) return -1;
    if (d != floor(d) || d < lo || d > hi) {
        char want[64];
        snprintf(want, sizeof want, "an integer in [%d, %d]", lo, hi);
        return jfail_type(c, key, want);
    }
    *out = (int)d;
    return 0;
}

static int jbool(json_ctx *c, const cJSON *obj, const char *key, bool *out) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!it) return 0;
    if (!cJSON_IsBool(it)) return jfail_type(c, key, "true or false");
    *out = cJSON_IsTrue(it);
    return 0;
}

/* An array of n finite numbers. */
static int jvec(json_ctx *c, const cJSON *obj, const char *key, int n, float *out) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!it) return 0;
    char want[48];
    snprintf(want, sizeof want, "an array of %d numbers", n);
    if (!cJSON_IsArray(it) || cJSON_GetArraySize(it) != n) return jfail_type(c, key, want);
    for (int i = 0; i < n; i++) {
        const cJSON *e = cJSON_GetArrayItem(it, i);
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || fabs(e->valuedouble) > 1e30) return jfail_type(c, key, want);
        out[i] = (float)e->valuedouble;
    }
    return 0;
}

/* Fails on any key of obj not in the NULL-terminated list. */
static int jkeys(json_ctx *c, const cJSON *obj, const char *const *allowed) {
    for (const cJSON *it = obj->child; it; it = it->next) {
        bool ok = false;
        for (const char *const *a = allowed; *a && !ok; a++) ok = it->string && strcmp(it->string, *a) == 0;
        if (!ok) {
            char list[256] = "";
            for (const char *const *a = allowed; *a; a++) {
                strncat(list, *a, sizeof list - strlen(list) - 1);
                if (a[1]) strncat(list, ", ", sizeof list - strlen(list) - 1);
            }
            return prt_fail(c->err, "%s: %s%sunknown key '%.60s' (expected one of: %s)", c->path, c->where,
                            *c->where ? ": " : "", it->string ? it->string : "?", list);
        }
    }
    return 0;
}

/* Joins dir (of the JSON file) and a relative path into out[cap]. */
static void join_path(const char *json_path, const char *rel, char *out, size_t cap) {
    const char *slash = strrchr(json_path, '/');
    if (rel[0] == '/' || !slash) snprintf(out, cap, "%s", rel);
    else snprintf(out, cap, "%.*s/%s", (int)(slash - json_path), json_path, rel);
}

/* Builds one model's mesh (untransformed) from its geometry key. */
static int json_geometry(json_ctx *c, const cJSON *model, asset_model *am, prt_scene *s, const asset_desc *ad) {
    static const char *const kinds[] = { "obj", "sphere", "box", "torus", "plane" };
    const cJSON *g = NULL;
    int kind = -1;
    memset(am, 0, sizeof *am);
    prt_mesh *m = &am->mesh;
    for (int k = 0; k < 5; k++) {
        const cJSON *it = cJSON_GetObjectItemCaseSensitive(model, kinds[k]);
        if (!it) continue;
        if (g) return prt_fail(c->err, "%s: %s: has both '%s' and '%s' (one shape per model)", c->path, c->where, kinds[kind], kinds[k]);
        g = it;
        kind = k;
    }
    if (!g) return prt_fail(c->err, "%s: %s: no shape (expected one of obj, sphere, box, torus, plane)", c->path, c->where);
    if (kind == 0) {
        if (!cJSON_IsString(g) || !*g->valuestring) return jfail_type(c, "obj", "a file name");
        char objpath[4096];
        join_path(c->path, g->valuestring, objpath, sizeof objpath);
        prt_error e2;
        int carried = model_file(objpath, ad, s, am, &e2);
        if (carried < 0) return prt_fail(c->err, "%s: %s: %s", c->path, c->where, e2.msg);
        const mesh_load_stats *st = &am->stats;
        s->load_stats.obj_vertices += st->obj_vertices;
        s->load_stats.faces += st->faces;
        s->load_stats.welded += st->welded;
        s->load_stats.degenerate += st->degenerate;
        s->load_stats.unused += st->unused;
        return carried;
    }
    if (!cJSON_IsObject(g)) return jfail_type(c, kinds[kind], "an object");
    size_t wl = strlen(c->where);
    snprintf(c->where + wl, sizeof c->where - wl, ".%s", kinds[kind]);
    prt_error e2;
    int rc = -1;
    if (kind == 1) {
        static const char *const keys[] = { "center", "radius", "rings", "segments", NULL };
        float ctr[3] = { 0, 0, 0 }, r = 1;
        int rings = 32, segs = 64;
        if (jkeys(c, g, keys) || jvec(c, g, "center", 3, ctr) || jfloat(c, g, "radius", &r) ||
            jint(c, g, "rings", 2, 4096, &rings) || jint(c, g, "segments", 3, 4096, &segs)) return -1;
        rc = mesh_make_sphere(m, ctr, r, rings, segs, &e2);
    } else if (kind == 2) {
        static const char *const keys[] = { "min", "max", "open_top", "n", NULL };
        float lo[3] = { -0.5f, 0, -0.5f }, hi[3] = { 0.5f, 1, 0.5f };
        bool open = false;
        int n = 8;
        if (jkeys(c, g, keys) || jvec(c, g, "min", 3, lo) || jvec(c, g, "max", 3, hi) || jbool(c, g, "open_top", &open) ||
            jint(c, g, "n", 1, 1024, &n)) return -1;
        rc = mesh_make_box(m, lo, hi, n, open, &e2);
    } else if (kind == 3) {
        static const char *const keys[] = { "center", "major", "minor", "nu", "nv", NULL };
        float ctr[3] = { 0, 0, 0 }, R = 1, r = 0.25f;
        int nu = 64, nv = 32;
        if (jkeys(c, g, keys) || jvec(c, g, "center", 3, ctr) || jfloat(c, g, "major", &R) || jfloat(c, g, "minor", &r) ||
            jint(c, g, "nu", 3, 4096, &nu) || jint(c, g, "nv", 3, 4096, &nv)) return -1;
        rc = mesh_make_torus(m, ctr, R, r, nu, nv, &e2);
    } else {
        static const char *const keys[] = { "x", "z", "height", "nx", "nz", NULL };
        float x[2] = { -1, 1 }, z[2] = { -1, 1 }, h = 0;
        int nx = 32, nz = 32;
        if (jkeys(c, g, keys) || jvec(c, g, "x", 2, x) || jvec(c, g, "z", 2, z) || jfloat(c, g, "height", &h) ||
            jint(c, g, "nx", 2, 4096, &nx) || jint(c, g, "nz", 2, 4096, &nz)) return -1;
        rc = mesh_make_plane(m, x[0], x[1], z[0], z[1], h, nx, nz, &e2);
    }
    if (rc != 0) return prt_fail(c->err, "%s: %s: %s", c->path, c->where, e2.msg);
    c->where[wl] = 0;
    return 0;
}

/* Rotation by deg degrees about +y (right-handed: +x turns towards -z). */
static void rot_y(float R[9], double deg) {
    double a = deg * M_PI / 180.0;
    float cs = (float)cos(a), sn = (float)sin(a);
    const float M[9] = { cs, 0, sn, 0, 1, 0, -sn, 0, cs };
    memcpy(R, M, sizeof M);
}

/* Rotation by deg degrees about +x (right-handed: +y turns towards +z). A multiple of
 * 90 degrees is exact (cos 90 is 0, not 6e-17), so a model stood up with "rotate_x": 90
 * gets exactly the coordinates a hand-written permutation would give (the demo's torus).
 * rot_y takes cos/sin at every angle, so rotate_y scenes keep the coordinates their stored .prt files hold. */
static void rot_x(float R[9], double deg) {
    double q = deg / 90.0;
    float cs, sn;
    if (q == floor(q) && fabs(q) < 1e9) {
        static const float c4[4] = { 1, 0, -1, 0 }, s4[4] = { 0, 1, 0, -1 };
        int k = (int)fmod(fmod(q, 4.0) + 4.0, 4.0);
        cs = c4[k], sn = s4[k];
    } else {
        double a = deg * M_PI / 180.0;
        cs = (float)cos(a), sn = (float)sin(a);
    }
    const float M[9] = { 1, 0, 0, 0, cs, -sn, 0, sn, cs };
    memcpy(R, M, sizeof M);
}

/* C = A B for row-major 3x3 matrices (C must not alias A or B). */
static void mat3_mul(float C[9], const float A[9], const float B[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* The model transform of "scale", "rotate_x", "rotate_y" and "translate":
 * p' = scale * Ry * Rx * p + t. Only rotate_y: R is Ry itself, not Ry * I (the same bits without rotate_x). */
static void model_transform(prt_mesh *m, float scale, double rx, double ry, const float t[3]) {
    if (scale == 1 && rx == 0 && ry == 0 && t[0] == 0 && t[1] == 0 && t[2] == 0) return;
    float R[9], Ry[9], Rx[9];
    rot_y(Ry, ry);
    if (rx == 0) memcpy(R, Ry, sizeof R);
    else {
        rot_x(Rx, rx);
        mat3_mul(R, Ry, Rx);
    }
    mesh_transform(m, R, scale, t);
}

/* The lights and cameras an asset carries, under the model transform p' = scale R p + t. */
static void transform_extras(asset_model *am, float scale, double rx, double ry, const float t[3]) {
    float R[9], Ry[9], Rx[9];
    rot_y(Ry, ry);
    rot_x(Rx, rx);
    mat3_mul(R, Ry, Rx);
    for (int i = 0; i < am->lights.count + 2 * am->ncameras; i++) {
        bool light = i < am->lights.count;
        const int ci = (i - am->lights.count) / 2;
        float *p = light ? am->lights.light[i].pos : (i - am->lights.count) % 2 ? am->cameras[ci].cam.target : am->cameras[ci].cam.eye;
        float q[3];
        for (int k = 0; k < 3; k++) q[k] = scale * (R[3 * k] * p[0] + R[3 * k + 1] * p[1] + R[3 * k + 2] * p[2]) + t[k];
        memcpy(p, q, sizeof q);
        float *d = light ? am->lights.light[i].dir : (i - am->lights.count) % 2 ? am->cameras[ci].cam.up : NULL;
        if (!d) continue;
        for (int k = 0; k < 3; k++) q[k] = R[3 * k] * d[0] + R[3 * k + 1] * d[1] + R[3 * k + 2] * d[2];
        memcpy(d, q, sizeof q);
    }
}

/* Adds an asset's lights and cameras to s (what names them in errors: the model's place). */
static int add_extras(prt_scene *s, const asset_model *am, const char *what, prt_error *err) {
    for (int i = 0; i < am->lights.count; i++)
        if (lights_add(&s->lights, &am->lights.light[i], what, err)) return -1;
    if (s->ncameras + am->ncameras > SCENE_MAX_CAMERAS)
        return prt_fail(err, "%s: more than %d cameras in the scene", what, SCENE_MAX_CAMERAS);
    memcpy(s->cameras + s->ncameras, am->cameras, (size_t)am->ncameras * sizeof am->cameras[0]);
    s->ncameras += am->ncameras;
    return 0;
}

static int json_model(json_ctx *c, const cJSON *model, int index, const scene_desc *desc, prt_scene *s) {
    snprintf(c->where, sizeof c->where, "models[%d]", index);
    if (!cJSON_IsObject(model)) return prt_fail(c->err, "%s: %s: expected an object", c->path, c->where);
    static const char *const keys[] = { "obj", "sphere", "box", "torus", "plane", "material", "scale", "translate",
                                        "rotate_x", "rotate_y", "name", NULL };
    if (jkeys(c, model, keys)) return -1;
    const cJSON *mat = cJSON_GetObjectItemCaseSensitive(model, "material");
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(model, "name");
    if (mat && !cJSON_IsString(mat)) return jfail_type(c, "material", "a BRDF spec string");
    if (name && !cJSON_IsString(name)) return jfail_type(c, "name", "a string");
    float scale = 1, t[3] = { 0, 0, 0 }, rx = 0, ry = 0;
    if (jfloat(c, model, "scale", &scale) || jvec(c, model, "translate", 3, t) || jfloat(c, model, "rotate_x", &rx) ||
        jfloat(c, model, "rotate_y", &ry)) return -1;
    if (!(scale > 0)) return jfail_type(c, "scale", "a positive number");
    /* A JSON "material" wins over --material, which wins over the file's own materials (asset.h). */
    char from[192];
    snprintf(from, sizeof from, "%s.material", c->where);
    asset_desc ad = { .material = mat ? mat->valuestring : desc ? desc->material : NULL,
                      .material_from = mat ? from : "--material", .fallback = SCENE_DEFAULT_MATERIAL };
    prt_error e2;
    brdf_params bp;
    if (ad.material && brdf_parse(ad.material, &bp, &e2)) return prt_fail(c->err, "%s: %s.material: %s", c->path, c->where, e2.msg);
    asset_model am;
    int carried = json_geometry(c, model, &am, s, &ad);
    if (carried < 0) return -1;
    int mi = carried ? 0 : scene_material_from(s, ad.material ? ad.material : SCENE_DEFAULT_MATERIAL,
                                               ad.material ? ad.material_from : "default", &e2);
    if (mi < 0) {
        asset_model_free(&am);
        return prt_fail(c->err, "%s: %s.material: %s", c->path, c->where, e2.msg);
    }
    if (!carried) set_material(&am.mesh, mi);
    model_transform(&am.mesh, scale, rx, ry, t);
    transform_extras(&am, scale, rx, ry, t);
    char what[300];
    snprintf(what, sizeof what, "%s: %s", c->path, c->where);
    int rc = mesh_append(&s->mesh, &am.mesh, c->err) ? -1 : add_extras(s, &am, what, c->err);
    asset_model_free(&am);
    return rc;
}

static char *read_text(const char *path, size_t *len, prt_error *err) {
    struct stat sb;
    if (stat(path, &sb) != 0) { prt_fail(err, "%s: cannot open: %s", path, strerror(errno)); return NULL; }
    if (!S_ISREG(sb.st_mode)) { prt_fail(err, "%s: not a regular file", path); return NULL; }
    if (sb.st_size > SCENE_MAX_JSON_BYTES) { prt_fail(err, "%s: too large for a scene file", path); return NULL; }
    FILE *f = fopen(path, "rb");
    if (!f) { prt_fail(err, "%s: cannot open: %s", path, strerror(errno)); return NULL; }
    char *buf = malloc((size_t)sb.st_size + 1);
    if (!buf) { fclose(f); prt_fail(err, "%s: out of memory", path); return NULL; }
    *len = fread(buf, 1, (size_t)sb.st_size, f);
    bool bad = ferror(f);
    fclose(f);
    if (bad) { free(buf); prt_fail(err, "%s: read error", path); return NULL; }
    buf[*len] = 0;
    return buf;
}

/* One light of the "lights" array: a spec string, or an object with the same fields. */
static int json_light(json_ctx *c, const cJSON *it, prt_light *l) {
    char what[200];
    snprintf(what, sizeof what, "%s: %s", c->path, c->where);
    if (cJSON_IsString(it)) return light_parse(it->valuestring, what, l, c->err);
    if (!cJSON_IsObject(it)) return prt_fail(c->err, "%s: expected a light spec string or object", what);
    static const char *const keys[] = { "type", "pos", "dir", "inner", "outer", "intensity", "colour", "name", NULL };
    if (jkeys(c, it, keys)) return -1;
    const cJSON *ty = cJSON_GetObjectItemCaseSensitive(it, "type");
    const char *tname = cJSON_IsString(ty) ? ty->valuestring : "";
    if (strcmp(tname, "point") && strcmp(tname, "spot")) return jfail_type(c, "type", "\"point\" or \"spot\"");
    if (!cJSON_GetObjectItemCaseSensitive(it, "pos")) return prt_fail(c->err, "%s: no \"pos\"", what);
    /* Start from the spec parser's defaults, then overwrite with the object's fields. */
    char spec[64];
    snprintf(spec, sizeof spec, "%s:pos=0,0,0", tname);
    if (light_parse(spec, what, l, c->err)) return -1;
    bool spot = l->type == PRT_LIGHT_SPOT;
    if (!spot && (cJSON_GetObjectItemCaseSensitive(it, "dir") || cJSON_GetObjectItemCaseSensitive(it, "inner") ||
                  cJSON_GetObjectItemCaseSensitive(it, "outer")))
        return prt_fail(c->err, "%s: dir, inner and outer are for spot lights only", what);
    if (jvec(c, it, "pos", 3, l->pos) || jvec(c, it, "dir", 3, l->dir) || jvec(c, it, "colour", 3, l->colour) ||
        jfloat(c, it, "inner", &l->inner_deg) || jfloat(c, it, "outer", &l->outer_deg) ||
        jfloat(c, it, "intensity", &l->intensity))
        return -1;
    float n = v3_len(l->dir);
    if (!(n > 1e-12f)) return prt_fail(c->err, "%s: dir must not be zero", what);
    v3_scale(l->dir, l->dir, 1.f / n);
    return light_validate(l, what, c->err);
}

/* The optional top-level "lights" array into s->lights. */
static int json_lights(json_ctx *c, const cJSON *root, prt_scene *s) {
    const cJSON *arr = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!arr) return 0;
    c->where[0] = 0;
    if (!cJSON_IsArray(arr)) return jfail_type(c, "lights", "an array of lights");
    int i = 0;
    for (const cJSON *it = arr->child; it; it = it->next, i++) {
        snprintf(c->where, sizeof c->where, "lights[%d]", i);
        prt_light l;
        if (json_light(c, it, &l) || lights_add(&s->lights, &l, c->path, c->err)) return -1;
    }
    return 0;
}

#define SCENE_STR_(x) #x
#define SCENE_STR(x) SCENE_STR_(x)   /* a limit spelt in an error from its one definition */

/* The optional top-level "light_prior": a probe path or an array of them (relative to the JSON's
 * folder), comma-joined into s->light_prior for precompute's --light-prior (prior.h). A path with a
 * comma, an empty one or more than SCENE_MAX_PRIOR_PROBES are refused: the list is comma-joined. */
static int json_light_prior(json_ctx *c, const cJSON *root, prt_scene *s) {
    const cJSON *lp = cJSON_GetObjectItemCaseSensitive(root, "light_prior");
    if (!lp) return 0;
    c->where[0] = 0;
    const char *want = "a probe path or an array of 1 to " SCENE_STR(SCENE_MAX_PRIOR_PROBES) " probe paths";
    int n = cJSON_IsArray(lp) ? cJSON_GetArraySize(lp) : 1;
    if (n < 1 || n > SCENE_MAX_PRIOR_PROBES) return jfail_type(c, "light_prior", want);
    const cJSON *it = cJSON_IsArray(lp) ? lp->child : lp;   /* one path: the loop's single item */
    for (int i = 0; i < n; i++, it = it->next) {
        if (!cJSON_IsString(it) || !it->valuestring[0] || strchr(it->valuestring, ','))
            return jfail_type(c, "light_prior", want);
        char path[4096];
        join_path(c->path, it->valuestring, path, sizeof path);
        size_t at = strlen(s->light_prior);
        if (at + strlen(path) + 2 > sizeof s->light_prior) return jfail_type(c, "light_prior", "shorter paths");
        snprintf(s->light_prior + at, sizeof s->light_prior - at, "%s%s", i ? "," : "", path);
    }
    return 0;
}

/* The optional top-level "refine": true/false or {"threshold", "budget", "models"} into s->refine. */
static int json_refine(json_ctx *c, const cJSON *root, prt_scene *s) {
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(root, "refine");
    if (!r) return 0;
    c->where[0] = 0;
    if (cJSON_IsBool(r)) {
        s->refine.on = cJSON_IsTrue(r);
        return 0;
    }
    if (!cJSON_IsObject(r)) return jfail_type(c, "refine", "true/false or an object");
    static const char *const rk[] = { "threshold", "budget", "models", NULL };
    snprintf(c->where, sizeof c->where, "refine");
    int budget = 4;   /* jint reads an absent key as its initial value */
    if (jkeys(c, r, rk) || jfloat(c, r, "threshold", &s->refine.threshold) || jint(c, r, "budget", 4, 1 << 28, &budget) ||
        jbool(c, r, "models", &s->refine.models))
        return -1;
    s->refine.budget = cJSON_GetObjectItemCaseSensitive(r, "budget") ? budget : 0;
    if (cJSON_GetObjectItemCaseSensitive(r, "threshold") && !(s->refine.threshold > 0 && s->refine.threshold < 1))
        return jfail_type(c, "threshold", "a share of directions, above 0 and below 1");
    s->refine.on = true;
    return 0;
}

/* Parses JSON text (path names it in errors and anchors its relative OBJ paths). */
static int json_scene(const char *path, const char *text, size_t len, const scene_desc *desc, prt_scene *s,
                      prt_error *err) {
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!root) {
        /* Line and column of where cJSON gave up. */
        if (!end || end < text || end > text + len) end = text + len;
        int line = 1, col = 1;
        for (const char *p = text; p < end; p++) {
            if (*p == '\n') { line++; col = 1; } else col++;
        }
        return len == 0 ? prt_fail(err, "%s: empty file (expected a JSON scene)", path)
                        : prt_fail(err, "%s:%d:%d: JSON syntax error", path, line, col);
    }
    json_ctx c = { .path = path, .err = err };
    int rc = -1;
    static const char *const top[] = { "models", "floor", "lights", "light_prior", "refine", "comment", NULL };
    const cJSON *models = NULL, *fl = NULL;
    if (!cJSON_IsObject(root)) { prt_fail(err, "%s: expected a JSON object at the top level", path); goto done; }
    if (jkeys(&c, root, top)) goto done;
    models = cJSON_GetObjectItemCaseSensitive(root, "models");
    if (!models) { prt_fail(err, "%s: no \"models\" array", path); goto done; }
    if (!cJSON_IsArray(models) || cJSON_GetArraySize(models) == 0) { jfail_type(&c, "models", "a non-empty array"); goto done; }
    int i = 0;
    for (const cJSON *m = models->child; m; m = m->next, i++)
        if (json_model(&c, m, i, desc, s)) goto done;

    /* Floor: the JSON's, unless desc forces one on or off. */
    fl = cJSON_GetObjectItemCaseSensitive(root, "floor");
    snprintf(c.where, sizeof c.where, "floor");
    bool want = false;
    int verts = SCENE_DEFAULT_FLOOR_VERTS;
    float size = SCENE_DEFAULT_FLOOR_SIZE;
    const char *fmat = SCENE_DEFAULT_FLOOR_MATERIAL;
    if (fl) {
        c.where[0] = 0;
        if (cJSON_IsBool(fl)) want = cJSON_IsTrue(fl);
        else if (cJSON_IsObject(fl)) {
            static const char *const fk[] = { "vertices", "material", "size", NULL };
            snprintf(c.where, sizeof c.where, "floor");
            want = true;
            if (jkeys(&c, fl, fk) || jint(&c, fl, "vertices", 1, 1 << 24, &verts) || jfloat(&c, fl, "size", &size)) goto done;
            if (!(size > 0)) { jfail_type(&c, "size", "a positive number"); goto done; }
            const cJSON *fm = cJSON_GetObjectItemCaseSensitive(fl, "material");
            if (fm && !cJSON_IsString(fm)) { jfail_type(&c, "material", "a BRDF spec string"); goto done; }
            if (fm) fmat = fm->valuestring;
        } else { jfail_type(&c, "floor", "an object or true/false"); goto done; }
    }
    if (desc && desc->floor >= 0) want = desc->floor == 1;
    if (desc && desc->floor_verts > 0) verts = desc->floor_verts;
    if (desc && desc->floor_material) fmat = desc->floor_material;
    if (want) {
        prt_error e2;
        if (scene_add_floor(s, verts, size, fmat, &e2)) { prt_fail(err, "%s: %s", path, e2.msg); goto done; }
    }
    if (json_lights(&c, root, s) || json_light_prior(&c, root, s) || json_refine(&c, root, s)) goto done;
    rc = 0;
done:
    cJSON_Delete(root);
    return rc;
}

/* One model file as the scene (model_file): --material or its own materials, its lights and
 * cameras, the floor desc asks for. Frees out on failure. */
static int scene_load_model(const char *path, const scene_desc *desc, prt_scene *out, prt_error *err) {
    asset_desc ad = { .material = desc ? desc->material : NULL, .material_from = "--material", .fallback = SCENE_DEFAULT_MATERIAL };
    asset_model am;
    int carried = model_file(path, &ad, out, &am, err);
    int rc = carried < 0 ? -1 : 0;
    prt_error e2;
    if (!rc && !carried) {
        int mi = scene_material_from(out, ad.material ? ad.material : SCENE_DEFAULT_MATERIAL, ad.material ? "--material" : "default", err);
        if (mi < 0) rc = -1;
        else set_material(&am.mesh, mi);
    }
    if (!rc) {
        out->mesh = am.mesh;
        memset(&am.mesh, 0, sizeof am.mesh);
        out->load_stats = am.stats;
        rc = add_extras(out, &am, path, err);
    }
    asset_model_free(&am);
    if (!rc && desc && desc->floor == 1 &&
        scene_add_floor(out, desc->floor_verts > 0 ? desc->floor_verts : SCENE_DEFAULT_FLOOR_VERTS, SCENE_DEFAULT_FLOOR_SIZE,
                        desc->floor_material, &e2) != 0)
        rc = prt_fail(err, "%s: %s", path, e2.msg);
    if (!rc) scene_update_bounds(out);
    if (!rc && scene_check_scale(out, &e2) != 0) rc = prt_fail(err, "%s: %s", path, e2.msg);
    if (rc) scene_free(out);
    return rc;
}

int scene_load(const char *path, const scene_desc *desc, prt_scene *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->floor_first_vertex = -1;
    char ext[16];
    prt_path_ext(path, ext);
    if (strcmp(ext, "obj") == 0 || asset_handles(path)) return scene_load_model(path, desc, out, err);
    if (strcmp(ext, "json") == 0) {
        size_t len = 0;
        char *text = read_text(path, &len, err);
        if (!text) return -1;
        int rc = scene_parse_json(path, text, len, desc, out, err);
        free(text);
        return rc;
    }
    return prt_fail(err, "%s: unknown scene format '%s' (expected .obj, .gltf, .glb, .ply or .json)", path,
                    ext[0] ? ext : "no extension");
}

int scene_parse_json(const char *name, const char *text, size_t len, const scene_desc *desc, prt_scene *out,
                     prt_error *err) {
    memset(out, 0, sizeof *out);
    out->floor_first_vertex = -1;
    if (json_scene(name, text, len, desc, out, err) != 0) { scene_free(out); return -1; }
    scene_update_bounds(out);
    prt_error e2;
    if (scene_check_scale(out, &e2) != 0) {
        scene_free(out);
        return prt_fail(err, "%s: %s", name, e2.msg);
    }
    return 0;
}

/* ---------------------------------------------------------------- the demo */

/* The demo scene is data: this text is byte for byte data/demo.json (tests/test_data.c
 * checks it), built in so that `prt demo` needs no file and runs from any directory.
 * Laid out for city-512.exr's sun (about 48 degrees up, from +x -z) and the demo's camera
 * (cli_demo.c, looking from +x +z with the sun at its right): the shadows fall left, each
 * about as long as its object is tall, onto a floor 5x the models' extent so that the
 * picture shows floor only. The box's sunlit face looks at the floor beside it and at the
 * chrome sphere; the torus stands on its rim (rotate_x 90), turned between the sun and the
 * camera so that both see through it. A light prior is not read from here by `prt demo`
 * (the built-in text has no folder): it names the probe it found (cli_demo.c). */
static const char k_demo_json[] =
    "{ \"comment\": \"prt demo: a chrome sphere mirroring its neighbours, a glossy red sphere with a crisp highlight, a diffuse orange box and a blue torus on its rim, over a light floor refined where visibility changes, for data/city-512.exr (its sun casts the sharp shadows, its overcast sky the soft ones; light from the box tints the floor). Built into prt (src/scene/scene.c: scene_make_demo); keep the two identical (tests/test_data.c checks).\",\n"
    "  \"models\": [\n"
    "    { \"name\": \"chrome sphere, centre\",\n"
    "      \"sphere\": { \"center\": [0, 0.5, 0], \"radius\": 0.5, \"rings\": 32, \"segments\": 64 },\n"
    "      \"material\": \"phong:kd=0.02;ks=0.9;n=1000\" },\n"
    "    { \"name\": \"glossy red sphere, front right\",\n"
    "      \"sphere\": { \"center\": [0.71, 0.3, -0.59], \"radius\": 0.3, \"rings\": 24, \"segments\": 48 },\n"
    "      \"material\": \"phong:kd=0.5,0.05,0.04;ks=0.3;n=200\" },\n"
    "    { \"name\": \"orange box, back left, a face turned to the sun\",\n"
    "      \"box\": { \"min\": [-0.35, 0, -0.35], \"max\": [0.35, 1.2, 0.35], \"n\": 10 },\n"
    "      \"rotate_y\": 24, \"translate\": [-1.33, 0, 0.67],\n"
    "      \"material\": \"lambert:kd=0.9,0.4,0.06\" },\n"
    "    { \"name\": \"blue torus, front left, standing on its rim\",\n"
    "      \"torus\": { \"center\": [0, 0, 0], \"major\": 0.3, \"minor\": 0.1, \"nu\": 48, \"nv\": 16 },\n"
    "      \"rotate_x\": 90, \"rotate_y\": 17, \"translate\": [0.53, 0.4, 0.85],\n"
    "      \"material\": \"lambert:kd=0.1,0.3,0.65\" }\n"
    "  ],\n"
    "  \"floor\": { \"vertices\": 10000, \"size\": 5, \"material\": \"lambert:kd=0.65\" },\n"
    "  \"refine\": { \"budget\": 40000 },\n"
    "  \"light_prior\": \"city-512.exr\"\n"
    "}\n";

const char *scene_demo_json(void) { return k_demo_json; }

int scene_make_demo(prt_scene *out, int floor_verts, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->floor_first_vertex = -1;
    if (floor_verts <= 0) return prt_fail(err, "demo: floor vertex count must be positive (got %d)", floor_verts);
    scene_desc d = { .floor = -1, .floor_verts = floor_verts };
    return scene_parse_json("demo.json (built in)", k_demo_json, sizeof k_demo_json - 1, &d, out, err);
}

/* Bounds of vertices [0, floor_first_vertex): the models a default camera frames. */
void scene_focus_bounds(const prt_scene *s, float bmin[3], float bmax[3]) {
    int n = s->floor_first_vertex > 0 ? s->floor_first_vertex : s->mesh.nverts;
    if (n <= 0) {
        for (int c = 0; c < 3; c++) bmin[c] = bmax[c] = 0;
        return;
    }
    for (int c = 0; c < 3; c++) bmin[c] = bmax[c] = s->mesh.pos[c];
    for (int v = 1; v < n; v++)
        for (int c = 0; c < 3; c++) {
            float x = s->mesh.pos[3 * v + c];
            if (x < bmin[c]) bmin[c] = x;
            if (x > bmax[c]) bmax[c] = x;
        }
}
